"""Tightly coupled GNSS/INS (SPEC §7.7, §7.8): the INS error state augmented with the receiver clock drift and the
double-difference ambiguities in metres, updated with DD code, DD phase and undifferenced Doppler.

State: the 16 INS error states of agnav_fusion.ins (Table 5-6-1, closed loop: fed back and reset after each
update), the crab state of the loosely coupled filter's non-holonomic constraint (same model, same updates), then
c·δṫ_r [m/s], the height reference of gnss_raw.height_aid [m] and the ambiguities λN [m] (total states, kept across updates; ambiguities.reindex when satellites
rise/set, slip or the reference changes). Observation models (x = computed − true):

    DD code   z = Δ_A − h(r̂)        = −G δr_E + n_A
    DD phase  z = Δ_Φ − h(r̂) − N̂    = −G δr_E + δN + n_I
    Doppler   z = −λD − u·(v_s − v̂) − c·δṫ_r + c·δṫ_s = u·δv_E − δ(cδṫ_r) + ε

r̂, v̂: the INS antenna position/velocity (IMU point + attitude × lever arm, ω × l), G = ∂h/∂r (double_difference).
δr_E, δv_E (ECEF) per error state are the Jacobians of the antenna state through the feedback itself
(ins.feedback.apply on a copy: a correction by ε·e_i moves the antenna by −J ε e_i), so lever arm, tilt and
azimuth (γ) terms follow the INS's own conventions — the γ/β extension of §7.8 comes out of it. A fresh ambiguity
starts at Δ_Φ − h(r̂) with a wide σ: the first phase update then gives it (5-8-1)'s value and its covariance and
cross-covariances with the INS states ([IMPL] of §7.9). Cycle slips: the loss-of-lock flag, Doppler–phase
consistency per satellite, and a phase innovation beyond both 4σ and half a wavelength reset that ambiguity.
Integer fixing (fixing.fix, LAMBDA + ratio) with hold: an accepted fix is applied as a tight measurement of the
ambiguities. In poor geometry (few DDs) the antenna height is held to the reference learnt while it was good
(gnss_raw.height_aid). ROS-free; drive with add_imu / add_epoch in time order (epochs on IMU stamps).
"""
import copy
import math
from dataclasses import dataclass, field

import numpy as np

from agnav_fusion import kalman
from agnav_fusion.gnss_raw import fixing, height_aid
from agnav_fusion.gnss_raw.ambiguities import reindex
from agnav_fusion.gnss_raw.double_difference import DDConfig, form_double_differences
from agnav_fusion.gnss_raw.ephemeris import satellite_states
from agnav_fusion.gnss_raw.geometry import elevation_azimuth
from agnav_fusion.gnss_raw.observations import CLIGHT
from agnav_fusion.ins import earth, error_model as em, feedback
from agnav_fusion.ins.lever_arm import lever_velocity

DRIFT = em.N_INS          # c·receiver clock drift [m/s] (after the INS states, crab and gyro scale)
HEIGHT = DRIFT + 1        # antenna height reference [m] (height_aid)
N_CORE = HEIGHT + 1       # ambiguities follow
POS_COLS = (em.RX, em.RY, em.H, em.TX, em.TY, em.GAMMA)
VEL_COLS = (em.VX, em.VY, em.VZ, em.TX, em.TY, em.GAMMA)
STEP = {em.RX: 1e-7, em.RY: 1e-7, em.H: 0.1, em.VX: 0.01, em.VY: 0.01, em.VZ: 0.01, em.TX: 1e-4, em.TY: 1e-4,
        em.GAMMA: 1e-4}


@dataclass
class TightConfig:
    dd: DDConfig = field(default_factory=lambda: DDConfig(sigma_code=0.5))  # masks and DD noise
    sigma_amb_init: float = 10.0      # m, a fresh ambiguity's σ about Δ_Φ − h(r̂)
    sigma_amb_rate: float = 1e-4      # m/√s ambiguity random walk
    sigma_doppler: float = 0.05       # m/s undifferenced range rate (× elevation factor); ≤ 0: no Doppler
    sigma_drift_rate: float = 0.1     # m/s/√s random walk of c·δṫ_r
    sigma_drift_init: float = 1.0     # m/s about the first epoch's mean Doppler residual
    slip_doppler_cycles: float = 0.6  # |Δφ + mean(D)·Δt| beyond this flags a slip (4σ of 3 cm/s Doppler at 1 Hz)
    fix: bool = True                  # integer ambiguity fixing (LAMBDA + ratio test)
    hold: bool = True                 # an accepted fix is applied as a measurement of the ambiguities
    sigma_hold: float = 0.002         # m, the held ambiguities
    ratio_threshold: float = fixing.RATIO_THRESHOLD  # second-best / best squared norm to accept a fix
    height: height_aid.HeightAidConfig = field(default_factory=height_aid.HeightAidConfig)  # poor-geometry aid


@dataclass
class TightSolution:
    t: float
    antenna: np.ndarray       # ECEF m
    antenna_cov: np.ndarray   # ECEF 3x3 m²
    n_dd: int
    fixed: bool
    ratio: float
    slips: int                # ambiguities reset this epoch (flags, Doppler–phase, innovation)
    height_aided: bool        # the antenna height held to the reference (poor geometry)


def geodetic_to_ecef(lat, lon, h):
    rn = earth.radii(lat)[1]
    cl = math.cos(lat)
    return np.array([(rn + h) * cl * math.cos(lon), (rn + h) * cl * math.sin(lon),
                     (rn * (1.0 - earth.E2) + h) * math.sin(lat)])


def ned_to_ecef(lat, lon):
    """Columns: north, east, down in ECEF."""
    sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
    return np.array([[-sl * co, -so, -cl * co], [-sl * so, co, -cl * so], [cl, 0.0, -sl]])


def antenna_state(mech, lever_frd, omega_b):
    """(ECEF position, ECEF velocity) of the point at `lever_frd` (body FRD) from the IMU of `mech`."""
    st = mech.state
    lat, lon = st.lat, st.lon
    c, r = st.c_b_ned(), ned_to_ecef(lat, lon)
    return (geodetic_to_ecef(lat, lon, st.h) + r @ (c @ lever_frd),
            r @ (st.v_ned() + lever_velocity(lever_frd, c, omega_b)))


def antenna_jacobians(mech, lever_frd, omega_b, n):
    """(J_pos, J_vel) 3 x n: ECEF position / velocity error of the point at `lever_frd` per INS error state,
    through feedback.apply on a copy (a correction by ε·e_i moves the antenna by −J ε e_i)."""
    p0, v0 = antenna_state(mech, lever_frd, omega_b)
    jp, jv = np.zeros((3, n)), np.zeros((3, n))
    for i in sorted(set(POS_COLS) | set(VEL_COLS)):
        m = copy.deepcopy(mech)
        x = np.zeros(em.N_STATES)
        x[i] = STEP[i]
        feedback.apply(m, x)
        p1, v1 = antenna_state(m, lever_frd, omega_b)
        jp[:, i], jv[:, i] = (p0 - p1) / STEP[i], (v0 - v1) / STEP[i]
    return jp, jv


def doppler_phase_slips(prev, rover, threshold=0.6):
    """Satellites of ObsEpoch `rover` whose phase change since `prev` disagrees with the mean Doppler over the
    interval by more than `threshold` cycles (receiver clock drift is in both and cancels)."""
    out = set()
    if prev is None or not 0.0 < rover.time - prev.time <= 5.0:
        return out
    dt = rover.time - prev.time
    for i, sid in enumerate(rover.sats):
        k = prev.row(sid)
        if k is not None:
            d = rover.phase[i] - prev.phase[k] + 0.5 * (rover.doppler[i] + prev.doppler[k]) * dt
            if np.any(np.abs(d[np.isfinite(d)]) > threshold):
                out.add(sid)
    return out


class TightFilter:
    """INS error EKF (an InsEkf's mechanization, propagation and feedback) augmented for DD code/phase and Doppler
    (see module docstring)."""

    def __init__(self, ins, base_pos, config=None):
        """ins: an InsEkf holding the INS state (taken over; its extension API propagates and feeds back the INS
        error states of this filter's augmented P); base_pos: ECEF base antenna [m]."""
        self.ins, self.s, self.c = ins, ins.s, config or TightConfig()
        self.lever = np.asarray(self.s.lever_gnss_frd, float)
        self.base_pos = np.asarray(base_pos, float)
        n = ins.n_states
        self.p = np.zeros((N_CORE, N_CORE))
        self.p[:n, :n] = ins.p
        self.p[DRIFT, DRIFT] = self.c.sigma_drift_init ** 2
        self.x_drift, self.drift_ok = 0.0, False
        self.amb = np.zeros(0)
        self.keys, self.refs = [], {}
        self._cov_dt, self._nhc_t = 0.0, -math.inf
        self._prev_rover = None
        self.stats = {"epochs": 0, "fixed": 0, "slips": 0, "height_aided": 0}
        self._learn_height(self.antenna()[0], self.jacobians()[0])

    @classmethod
    def from_ins(cls, ekf, base_pos, config=None):
        """Hand-over from a loosely coupled InsEkf (SPEC §7.9 loose → tight): its export_state() (mechanization,
        error covariance, crab) adopted by a fresh InsEkf; the clock drift and ambiguities start at the first epoch
        ((5-8-1)–(5-8-3))."""
        ins = type(ekf)(ekf.s)
        ins.adopt(**ekf.export_state())
        return cls(ins, base_pos, config)

    def export_state(self):
        """Hand-back (tight → loose, InsEkf.adopt): the INS part of the state and its covariance."""
        self._propagate()
        out = self.ins.export_state()
        out["p"] = self.p[:DRIFT, :DRIFT].copy()
        return out

    @property
    def mech(self):
        return self.ins.mech

    @property
    def t(self):
        return self.ins.t

    @property
    def n(self):
        return N_CORE + len(self.amb)

    # ------------------------------------------------------------------ INS
    def add_imu(self, t, gyro_frd, accel_frd):
        self._cov_dt += self.ins.step(t, gyro_frd, accel_frd)
        if self._cov_dt >= self.s.covariance_interval:
            self._propagate()
        nhc = self.ins.nhc
        if nhc is not None and t - self._nhc_t >= nhc.s.interval:
            self._nhc_t = t
            self._propagate()
            st = self.mech.state
            lin = nhc.linearize(st.c_b_cbar(), st.v, self.ins.omega_b, self.ins.crab, self.n)
            if self.ins.gated(lin, self.p):
                self._apply(*kalman.update(np.zeros(self.n), self.p, lin.z, lin.h @ self.p @ lin.h.T + lin.r,
                                           lin.h, lin.r))

    def _propagate(self):
        dt, self._cov_dt = self._cov_dt, 0.0
        if dt > 0.0:
            q = np.zeros(self.n - self.ins.n_states)
            q[DRIFT - self.ins.n_states] = self.c.sigma_drift_rate ** 2
            q[HEIGHT - self.ins.n_states] = self.c.height.walk ** 2 * np.linalg.norm(self.mech.state.v_ned())
            q[N_CORE - self.ins.n_states:] = self.c.sigma_amb_rate ** 2
            self.p = self.ins.propagate_covariance(self.p, dt, q)

    def _apply(self, x, p):
        """Closed loop: INS errors and crab fed back and reset (InsEkf.feedback); drift, height reference and
        ambiguities are total states."""
        self.p = self.ins.feedback(x, p)
        self.x_drift += x[DRIFT]
        self.x_height += x[HEIGHT]
        self.amb = self.amb + x[N_CORE:]

    def solution(self):
        """The INS NavSolution (InsEkf.solution) with this filter's covariance: the INS block of the augmented P."""
        held, n = self.ins.p, self.ins.n_states
        self.ins.p = self.p[:n, :n]
        try:
            return self.ins.solution()
        finally:
            self.ins.p = held

    def antenna(self):
        return antenna_state(self.mech, self.lever, self.ins.omega_b)

    def jacobians(self):
        """(J_pos, J_vel) 3 x n: antenna ECEF position / velocity error per state (antenna_jacobians)."""
        return antenna_jacobians(self.mech, self.lever, self.ins.omega_b, self.n)

    def _learn_height(self, pos, jp):
        """The height reference := the antenna height estimate (height_aid.learn)."""
        self.x_height, a = height_aid.height_row(pos, jp)
        self.p = height_aid.learn(self.p, HEIGHT, a)

    # ------------------------------------------------------------------ GNSS
    def _doppler_slips(self, rover):
        prev, self._prev_rover = self._prev_rover, rover
        return doppler_phase_slips(prev, rover, self.c.slip_doppler_cycles)

    def _reindex(self, dd, h, flagged):
        reset = np.array([dd.slip[i] or dd.ref_slip.get(k[:2], False) or k[2] in flagged
                          or dd.refs[k[:2]] in flagged for i, k in enumerate(dd.keys)], bool)
        x = np.concatenate([np.zeros(N_CORE), self.amb])
        x, self.p, fresh = reindex(x, self.p, N_CORE, self.keys, self.refs, dd.keys, dd.refs, reset,
                                   dd.phase - h, np.full(len(dd), self.c.sigma_amb_init ** 2))
        self.amb, self.keys, self.refs = x[N_CORE:], list(dd.keys), dict(dd.refs)
        return int(fresh.sum())

    def _reset_ambiguity(self, i, value):
        k = N_CORE + i
        self.p[k, :], self.p[:, k] = 0.0, 0.0
        self.p[k, k] = self.c.sigma_amb_init ** 2
        self.amb[i] = value

    def _doppler_rows(self, rover, sv, pos, vel, jv):
        """(z, H, R) of the rover's undifferenced Doppler (elevation and SNR masks of the DD config)."""
        rows, z, var = [], [], []
        el_all = elevation_azimuth(pos, np.where(sv.valid[:, None], sv.pos, pos + 1e7))[0]
        for i, sid in enumerate(rover.sats):
            d, snr = rover.doppler[i, 0], rover.snr[i, 0]
            if not (sv.valid[i] and np.isfinite(d)) or el_all[i] < math.radians(self.c.dd.elevation_mask_deg) \
                    or not snr >= self.c.dd.snr_mask_dbhz:
                continue
            los = sv.pos[i] - pos
            u = los / np.linalg.norm(los)
            pred = u @ (sv.vel[i] - vel) + self.x_drift - CLIGHT * sv.drift[i]
            row = np.zeros(self.n)
            row[:] = u @ jv
            row[DRIFT] = 1.0
            rows.append(row)
            z.append(-rover.wavelength[i, 0] * d - pred)
            var.append(self.c.sigma_doppler ** 2 * (1.0 + 1.0 / math.sin(el_all[i]) ** 2))
        if not rows:
            return None
        z = np.array(z)
        if not self.drift_ok:                     # (5-8-3) + [IMPL]: start at the mean residual
            self.x_drift += float(np.median(z))
            z -= np.median(z)
            self.drift_ok = True
        return z, np.array(rows), np.diag(var)

    def add_epoch(self, rover, base, nav):
        """One rover + base ObsEpoch pair at the current IMU time -> TightSolution (None without DDs or Doppler)."""
        self._propagate()
        flagged = self._doppler_slips(rover)
        pos, vel = self.antenna()
        cache = {}
        sv_b = satellite_states(base, nav, self.base_pos, cache)
        sv_r = satellite_states(rover, nav, pos, cache)
        dd = form_double_differences(rover, base, sv_r, sv_b, self.base_pos, self.c.dd)
        jp, jv = self.jacobians()
        blocks, slips = [], 0
        if dd is not None and len(dd) > 0:
            h, g = dd.geometry(pos)
            slips = self._reindex(dd, h, flagged)
            jp = np.hstack([jp[:, :N_CORE], np.zeros((3, len(self.amb)))])
            jv = np.hstack([jv[:, :N_CORE], np.zeros((3, len(self.amb)))])
            m = len(dd)
            hc = -g @ jp
            hp = hc.copy()
            hp[:, N_CORE:] = np.eye(m)
            zp = dd.phase - h - self.amb
            s_ii = np.einsum("ij,jk,ik->i", hp, self.p, hp) + np.diag(dd.cov_phase)
            for i in np.flatnonzero((np.abs(zp) > 4.0 * np.sqrt(s_ii)) & (np.abs(zp) > 0.5 * dd.wavelength)):
                self._reset_ambiguity(i, dd.phase[i] - h[i])
                slips += 1
            zp = dd.phase - h - self.amb
            blocks += [(dd.code - h, hc, dd.cov_code), (zp, hp, dd.cov_phase)]
        else:
            self.amb, self.keys, self.refs = np.zeros(0), [], {}
            self.p = self.p[:N_CORE, :N_CORE]
            jp, jv = jp[:, :N_CORE], jv[:, :N_CORE]
        if self.c.sigma_doppler > 0:
            rows = self._doppler_rows(rover, sv_r, pos, vel, jv)
            if rows is not None:
                blocks.append(rows)
        if not blocks:
            return None
        n_dd = 0 if dd is None else len(dd)
        height, a = height_aid.height_row(pos, jp)
        aided = height_aid.poor_geometry(self.c.height, n_dd, a, self.p)
        if aided:
            blocks.append(height_aid.block(self.c.height, HEIGHT, self.x_height, height, a))
        self._update(blocks)
        fixed, ratio = self._fix(dd) if dd is not None and self.c.fix else (False, 0.0)
        self.stats["epochs"] += 1
        self.stats["fixed"] += int(fixed)
        self.stats["slips"] += slips
        self.stats["height_aided"] += int(aided)
        pos = self.antenna()[0]
        jp = self.jacobians()[0]
        if not aided:
            self._learn_height(pos, jp)
        return TightSolution(self.t, pos, jp @ self.p @ jp.T, n_dd, fixed, ratio, slips, aided)

    def _update(self, blocks):
        z = np.concatenate([b[0] for b in blocks])
        h = np.vstack([b[1] for b in blocks])
        r = np.zeros((len(z), len(z)))
        k = 0
        for b in blocks:
            r[k:k + len(b[0]), k:k + len(b[0])] = b[2]
            k += len(b[0])
        self._apply(*kalman.update(np.zeros(self.n), self.p, z, h @ self.p @ h.T + r, h, r))

    def _fix(self, dd):
        x = np.concatenate([np.zeros(N_CORE), self.amb])
        fx = fixing.fix(x, self.p, N_CORE, dd.wavelength, self.c.ratio_threshold)
        if not fx.ok:
            return False, fx.ratio
        if self.c.hold:
            m = len(self.amb)
            h = np.zeros((m, self.n))
            h[:, N_CORE:] = np.eye(m)
            r = np.eye(m) * self.c.sigma_hold ** 2
            z = fx.integers * dd.wavelength - self.amb
            self._apply(*kalman.update(np.zeros(self.n), self.p, z, h @ self.p @ h.T + r, h, r))
        return True, fx.ratio
