"""GNSS/INS loosely coupled extended Kalman filter (SPEC §7.6, §7.9–7.11, report 5-9-1 … 5-9-8).

`InsEkf` owns the mechanization, the error covariance and the guards: IMU-rate propagation (Euler F, Q = U dt), IMU
gaps bridged in sub-steps with unknown-motion noise, in-motion alignment from an unknown heading (γ/β), GNSS latency
compensation (solution history, fixes applied against the INS state at their epoch), chi-square innovation gating,
Joseph-form update with closed-loop correction, outage coasting and health statistics.
[IMPL] A non-holonomic constraint with an augmented crab state (`constraints`) makes the heading observable on
straight runs and bounds outage drift; an augmented z gyro scale-factor state, learnt in turns, keeps a U-turn from
leaving its heading error (0.5 % of 180° is 0.9°); a wheel speed with an augmented scale state and a tractor's
steady speed (`SpeedHold`; a real speed change fails its gate) hold the speed in outages; an augmented IMU yaw mount
(`mount`) turns the samples onto the vehicle axes; augmented receiver slow-error states (`gnss_bias`) keep 5-10 Hz
fixes from averaging their drift down; fix-difference velocities only seed the in-motion alignment (they lag and
repeat the fixes); a filter whose fixes stay rejected re-aligns.
"""
import math
from collections import deque

import numpy as np

from agnav_fusion import kalman

from . import chi2, error_model as em, feedback
from .constraints import CRAB, MOUNT, WHEEL, NonHolonomic, SpeedHold, WheelSpeed
from .handover import HandOver
from .history import ImuPeriod, SolutionHistory
from .alignment import FixTrack, initial_state, initial_variances
from .gnss_bias import GnssBias
from .measurements import GnssPosition, GnssVelocity
from .mechanization import Mechanization, _floats
from .mount import YawMount
from .standstill import StandstillBias
from .settings import InsEkfSettings, NavSolution  # noqa: F401 (re-exported)
from .solution import filter_health, nav_solution

UNINITIALIZED, ALIGNING, ALIGNED = "uninitialized", "aligning", "aligned"
MAX_GAP_STEPS = 1000        # sub-steps bridging one IMU gap at most


class InsEkf(HandOver):
    """Strapdown INS + 16-state error EKF + crab, z gyro scale, wheel scale, yaw mount and receiver bias (em.N_INS);
    feed `add_imu` and `add_gnss` in arrival order."""

    def __init__(self, settings=None):
        self.s = settings or InsEkfSettings()
        self.mech = None
        self.p = None
        e = self.s.error        # crab noise: roll-dependent (propagate_covariance); scale: a slow random walk
        self.psd = np.append(e.psd(), (0.0, 2.0 * e.gyro_scale_sigma ** 2 / e.gyro_scale_tau,
                                       self.s.wheel.scale_walk ** 2, 0.0, 0.0, 0.0, 0.0))
        self.gnss_bias = GnssBias(self.s.gnss_bias)
        self.nhc = NonHolonomic(self.s.nhc, self.s.lever_base_frd) if self.s.nhc.enabled else None
        self.wheel = WheelSpeed(self.s.wheel, self.s.lever_base_frd)
        self.hold = SpeedHold(self.s.speed_hold, self.s.lever_base_frd) if self.s.speed_hold.enabled else None
        self.wheel_scale, self._wheel = 0.0, None   # a wheel reads (1 + scale) x speed; (t, speed, var) to fuse
        self.crab = 0.0
        self.mount = YawMount()           # the IMU's yaw mount estimate: the samples are turned by it
        self._nhc_t = -math.inf
        self.models = [GnssPosition(self.s.lever_gnss_frd), GnssVelocity(self.s.lever_gnss_frd)]
        self.t = None
        self.omega_b = np.zeros(3)
        self.last_gap = 0.0               # s of missing IMU samples bridged by the last add_imu
        self._period = ImuPeriod()        # nominal IMU period
        self._last_imu = None             # (gyro, accel) of the last accepted sample
        self._gap_var = None              # unknown-motion variance of a gap, added at the next P propagation
        self._cov_dt = 0.0
        self._f = None
        self._level = deque()
        self._fix_track = FixTrack()
        self._standstill = StandstillBias(self.s.standstill, self.s.error.gyro_arw)
        self._history = SolutionHistory(self.s.history)
        self._pending = []
        self._gates = {}
        self._corr = np.zeros(6)          # accumulated corrections (lat, lon, h, v_ned)
        self._last_gnss_t = None
        self._last_accept_t = None
        self._first_reject_t = None
        self.stats = {"imu": 0, "gnss": 0, "accepted": {}, "rejected": {}, "bridged": {}, "nis": {}}

    # ----------------------------------------------------------------- public API
    @property
    def n_states(self):
        return self.p.shape[0] if self.p is not None else em.N_INS

    @property
    def alignment(self):
        if self.mech is None:
            return UNINITIALIZED
        return ALIGNED if self.heading_sigma() < self.s.aligned_heading_sigma else ALIGNING

    @property
    def imu_period(self):
        """Nominal IMU period [s] (running mean of the regular intervals; 1 before two samples)."""
        return self._period.dt or 1.0

    def gnss_age(self):
        """s of IMU time since the last accepted GNSS epoch (inf before any)."""
        return self.t - self._last_accept_t if self._last_accept_t is not None else math.inf

    def heading_sigma(self):
        """1-sigma heading uncertainty [rad] (γ ≈ δα once small)."""
        return math.sqrt(max(self.p[em.GAMMA, em.GAMMA], 0.0)) if self.p is not None else math.inf

    def add_imu(self, t, gyro_frd, accel_frd):
        """One IMU sample (body FRD, rad/s and m/s^2) stamped at t [s]; returns a rejection reason or None.

        Missing samples (an interval over 1.5 nominal periods) are bridged, never skipped: the rates and specific
        force are interpolated across the gap in nominal sub-steps (GNSS epochs inside it are applied on the way)
        and the covariance grows by an unknown acceleration and rate over the gap length (`gap_*_sigma`)."""
        gyro, accel = _floats(gyro_frd), _floats(accel_frd)
        if not math.isfinite(t + sum(gyro) + sum(accel)) and not all(map(math.isfinite, [t, *gyro, *accel])):
            return self._reject("imu_nan")
        if self.t is not None and t <= self.t:
            return self._reject("imu_stamp")
        t0, dt = self.t, None if self.t is None else t - self.t
        self.last_gap = 0.0
        self.stats["imu"] += 1
        self._level.append((t, accel, gyro))
        while self._level[0][0] < t - self.s.level_window:
            self._level.popleft()
        nominal = self._period.update(dt)
        if self.mech is None:
            self._standstill.add_imu(t, gyro, accel)
            self.t, self._last_imu = t, (gyro, accel)
            self._process_pending()
            return None
        n = 1 if dt <= 1.5 * nominal else min(math.ceil(dt / nominal - 1e-6), MAX_GAP_STEPS)
        if n > 1:
            self.last_gap = dt - nominal
            self._stat("bridged", "imu_gap")
            gap_psd = np.zeros(self.n_states)
            gap_psd[list(em.V3)] = self.s.gap_accel_sigma ** 2 * self.last_gap
            gap_psd[[em.TX, em.TY, em.GAMMA]] = self.s.gap_rate_sigma ** 2 * self.last_gap
        if n == 1:
            self.t = t
            self._propagate(gyro, accel, dt)
            self._process_pending()
        else:
            g0, a0 = (np.asarray(v) for v in (self._last_imu or (gyro, accel)))   # (none yet after adopt)
        for k in range(1, n + 1 if n > 1 else 1):
            w = k / n
            self.t = t if k == n else t0 + w * dt
            self._gap_var = (0.0 if self._gap_var is None else self._gap_var) + gap_psd * dt / n
            self._propagate(g0 + w * (np.asarray(gyro) - g0), a0 + w * (np.asarray(accel) - a0), dt / n)
            self._process_pending()
        self._last_imu = (gyro, accel)
        return None

    def add_gnss(self, g):
        """One GNSS epoch (may arrive after later IMU samples); returns a rejection reason or None."""
        vals = [g.t, g.lat, g.lon, g.alt] + list(np.ravel(g.pos_cov_enu))
        if not all(math.isfinite(v) for v in vals) or np.any(np.diag(g.pos_cov_enu) <= 0):
            return self._reject("gnss_nan")
        if self._last_gnss_t is not None and g.t <= self._last_gnss_t:
            return self._reject("gnss_stamp")
        if self.t is not None and g.t > self.t + self.s.max_gnss_lead:
            return self._reject("gnss_future")         # would shut out every later epoch
        if g.vel_enu is not None and not (np.all(np.isfinite(g.vel_enu)) and np.all(np.isfinite(g.vel_cov_enu))
                                          and np.all(np.diag(g.vel_cov_enu) > 0)):
            g.vel_enu = None
        if self.mech is None:
            self._standstill.add_fix(g)
        if g.vel_enu is None:       # the INS's own fix differences: alignment only (ignored by the updates)
            vel = self._fix_track.velocity(g)
            if vel is not None:
                g.vel_enu, g.vel_cov_enu, g.vel_from_fixes = vel[0], vel[1], True
        self._last_gnss_t = g.t
        self.stats["gnss"] += 1
        self._pending.append(g)
        self._process_pending()
        return None

    def solution(self):
        """Current IMU-point NavSolution, or None before initialisation."""
        return None if self.mech is None else nav_solution(self)

    def add_wheel(self, t, speed, var):
        """A wheel or radar speed (m/s, variance; <= 0: unknown) at t: fused at the next IMU sample."""
        self._wheel = (t, float(speed), var) if self.mech is not None and math.isfinite(speed) else None

    health = filter_health      # diagnostics: alignment, NIS means, counts, GNSS age, 1-sigma errors

    # ------------------------------------------------- extension API (augmented filters, hand-over)
    # An augmented filter (gnss_raw.tight) owns a P whose first n_states rows are these error states (em.N_INS).
    def step(self, t, gyro_frd, accel_frd):
        """Mechanization only, up to t (no covariance, constraint or GNSS processing)."""
        dt, self.t = t - self.t, t
        self._mechanize(gyro_frd, accel_frd, dt)
        return dt

    def propagate_covariance(self, p, dt, q_extra=()):
        """Φ P Φᵀ + U Δt (5-9-4, 5-6-2), Φ = I + F Δt over dt at the last mechanization step; crab: NonHolonomic's
        roll-driven model; the z scale error acts as the z gyro bias times the z rate. Rows beyond n_states: Φ = I,
        white noise `q_extra` [unit²/s]."""
        st = self.mech.state
        rho, omega, a_c, c_bc = self._f
        lat, _, alpha = st.geo()
        phi = em.transition(self.s.error, st.v, a_c, rho, omega, em.body_to_c(c_bc), lat, st.h, alpha, dt, len(p))
        q = (np.concatenate([self.psd, np.asarray(q_extra, dtype=float)]) if len(q_extra) else self.psd) * dt
        self.gnss_bias.propagate(phi, q, dt)
        bgz = em.BG.start + 2
        phi[:, em.GYRO_SCALE] = phi[:, bgz] * self.omega_b[2]
        phi[bgz, em.GYRO_SCALE], phi[em.GYRO_SCALE, em.GYRO_SCALE] = 0.0, 1.0
        if self.nhc is not None:
            (_, _, _), (_, _, _), (_, c7, c8) = st.dcm_rows()
            self.crab, phi[CRAB, CRAB], q[CRAB] = self.nhc.propagate_crab(self.crab, math.atan2(c7, c8), dt,
                                                                          self.heading_sigma())
        p = phi @ p @ phi.T
        p.flat[::len(p) + 1] += q
        return p

    def feedback(self, x, p):
        """Closed loop: x[:n_states] fed back into the mechanization and crab (then zero); returns P after the
        azimuth reset (rows beyond n_states: extra states, untouched by the feedback)."""
        feedback.apply(self.mech, x[:em.N_STATES])
        self.mech.gyro_scale += float(x[em.GYRO_SCALE])
        self.wheel_scale -= float(x[WHEEL])
        self.mount.correct(self.mech.state, float(x[MOUNT]))
        self.gnss_bias.feedback(x)
        if self.nhc is not None:
            self.crab -= x[CRAB]
        p = feedback.azimuth_reset(p, x[em.GAMMA], x[em.BETA])
        p[em.BETA, em.BETA] = 0.5 * p[em.GAMMA, em.GAMMA] ** 2 + 1e-12
        return 0.5 * (p + p.T)

    def gated(self, lin, p=None):
        """True (and counted) if the linearised observation's innovation passes the chi-square gate under P."""
        p = self.p if p is None else p
        nis = kalman.mahalanobis2(lin.h @ p @ lin.h.T + lin.r, lin.z)
        if nis > self._gate(len(lin.z)):
            return not self._reject(lin.name)
        n, total = self.stats["nis"].get(lin.name, (0, 0.0))
        self.stats["nis"][lin.name] = (n + 1, total + nis)
        self._stat("accepted", lin.name)
        return True

    # ----------------------------------------------------------------- internals
    def _gate(self, dof):
        if dof not in self._gates:
            self._gates[dof] = float(chi2.ppf(self.s.gate_probability, dof))
        return self._gates[dof]

    def _stat(self, kind, name):
        counts = self.stats[kind]
        counts[name] = counts.get(name, 0) + 1

    def _reject(self, reason):
        self._stat("rejected", reason)
        return reason

    def _initialize(self, g, heading, heading_var):
        """Initial state at fix g (alignment.initial_state); False: not yet (standing with an unknown heading)."""
        still = self._standstill.estimate(g.lat) if self.mech is None else None   # gyro bias and level standing
        bias = np.array(still.bias) if still else np.zeros(3)
        level = self._standstill.level(still) if still else None
        init = initial_state(self.s, g, self._level, heading, heading_var, self.mech.gyro_bias if self.mech else bias,
                             level)
        if init is None:
            return False
        self.mech = Mechanization(init[0], gyro_bias=bias)
        self.gnss_bias.reset(self.gnss_bias.initial_var(g))
        self.p = np.diag(initial_variances(self.s, g, init[1], self.nhc is not None, still.var if still else None,
                                           self.gnss_bias.var))
        self.crab, self._f = 0.0, None
        if self.nhc:
            self.nhc.reset()
        if self.hold:
            self.hold.prev = None
        self._history.clear()
        self._snapshot()
        return True

    def _propagate(self, gyro, accel, dt):
        self._mechanize(gyro, accel, dt)
        self._cov_dt += dt
        if self._cov_dt >= self.s.covariance_interval:
            self._propagate_covariance()
        if self.stats["imu"] % 1000 == 0:
            self.mech.renormalize()
        self._snapshot()
        nhc = self.nhc is not None and self.t - self._nhc_t >= self.s.nhc.interval
        if nhc or self._wheel is not None:
            self._nhc_t = self.t if nhc else self._nhc_t
            self._vehicle_update(nhc)

    def _mechanize(self, gyro, accel, dt):
        self._f = self.mech.step(*self.mount.turn(gyro, accel), dt)
        self.omega_b = np.array(self.mech.rate)     # gyro - bias; a new array each time (the history keeps it)

    def _propagate_covariance(self):
        if self._cov_dt > 0.0:      # (+ the unknown motion of a bridged IMU gap)
            self.p = self.propagate_covariance(self.p, self._cov_dt)
            if self._gap_var is not None:
                self.p.flat[::len(self.p) + 1] += self._gap_var
            self._gap_var, self._cov_dt = None, 0.0

    def _snapshot(self):
        st = self.mech.state
        c_bc = self._f[3] if self._f is not None else st.c_b_cbar()
        lat, lon, alpha = st.geo()
        self._history.append((self.t, lat, lon, st.h, alpha, st.v, c_bc, self.omega_b), self._corr)

    def _process_pending(self):
        keep = []
        for g in self._pending:
            if self.mech is None:
                if not self._initialize(g, self.s.initial_heading, self.s.initial_heading_sigma ** 2):
                    continue
                self._last_accept_t = self.t
            elif g.t > self.t:
                keep.append(g)
            elif g.t < self._history.oldest:
                self._reject("gnss_stale")
            else:
                self._update(g)
        self._pending = keep

    def _vehicle_update(self, nhc):
        """The non-holonomic constraint (nhc: it is due) and a wheel speed received since the last sample."""
        self._propagate_covariance()
        rows, v = self.mech.state.dcm_rows(), self.mech.state.v
        lins = [self.nhc.linearize(rows, v, self.omega_b, self.crab, self.n_states)] if nhc else []
        if self._wheel is not None and self.t - self._wheel[0] <= self.s.wheel.max_age:
            lins.append(self.wheel.linearize(rows, v, self.omega_b, self.wheel_scale, *self._wheel[1:],
                                             self.n_states))
        self._wheel = None
        if nhc and self.hold and self.hold.prev and self.gnss_age() > self.s.speed_hold.after:   # an outage
            (rho, omega, a_c, c_bc), (lat, _, alpha) = self._f, self.mech.state.geo()
            f = em.dynamics(self.s.error, v, a_c, rho, omega, em.body_to_c(c_bc), lat, self.mech.state.h, alpha)
            lins.append(self.hold.linearize(rows, v, self.omega_b, f[list(em.V3)], self.t, self.n_states))
        accepted = [lin for lin in lins if self.gated(lin)]
        if accepted:
            self._fuse(accepted)
        if nhc and self.hold:   # the speed the next change is counted from
            self.hold.prev = (self.t, self.hold.forward(self.mech.state.dcm_rows(), self.mech.state.v, self.omega_b))

    def _update(self, g):
        self._propagate_covariance()
        snap = self._history.at(g.t, self._corr)
        alpha, vel = self.mech.state.alpha, g.vel_enu is not None and not g.vel_from_fixes
        fixed, self.p = self.gnss_bias.fix(g, self.p, snap)     # g itself stays the receiver's (re-alignment)
        lins = [self.models[0].linearize(snap, alpha, fixed, self.n_states, self.p[em.GAMMA, em.GAMMA])]
        self.gnss_bias.add_columns(lins[0], snap, alpha)
        lins += [m.linearize(snap, alpha, fixed, self.n_states) for m in self.models[1:] if vel]
        accepted = [lin for lin in lins if self.gated(lin)]
        position = any(lin.name == self.models[0].name for lin in accepted)
        if position:
            self._first_reject_t = None
        else:       # fixes locked out (a velocity may still pass): after reinit_after, re-align from the fixes
            self._first_reject_t = self._first_reject_t if self._first_reject_t is not None else g.t
            if g.t - self._first_reject_t > self.s.reinit_after:
                self._reject("reinitialized")
                self._first_reject_t = None
                heading = self.mech.state.euler()[2]
                if not self._initialize(g, heading, 4.0):     # moving: from the course, else the heading kept
                    self._initialize(g, heading, max(self.p[em.GAMMA, em.GAMMA], self.s.align_fix_course_sigma ** 2))
                return
        if not accepted:
            return
        self._last_accept_t = self.t
        self._fuse(accepted)

    def _fuse(self, accepted):
        """Update with the stacked accepted observations (kalman.update, Joseph form), fed back."""
        z = np.concatenate([m.z for m in accepted])
        h = np.vstack([m.h for m in accepted])
        r, k = np.zeros((len(z), len(z))), 0       # block diagonal of the Rs
        for m in accepted:
            r[k:k + len(m.z), k:k + len(m.z)] = m.r
            k += len(m.z)
        x, p = kalman.update(np.zeros(self.n_states), self.p, z, h @ self.p @ h.T + r, h, r)
        self._feedback(x, p)

    def _feedback(self, x, p):
        st = self.mech.state
        before = (st.lat, st.lon, st.h, *st.v_ned_floats())
        p = self.feedback(x, p)
        after = (st.lat, st.lon, st.h, *st.v_ned_floats())
        self._corr = self._corr + np.array([a - b for a, b in zip(after, before)])    # a new array (history)
        self.p = feedback.bound_heading(p)
