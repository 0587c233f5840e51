"""Simulated raw GNSS observations of a rover antenna on a simulated vehicle and of a static base (issue 18 item 6).

Orbits and satellite clocks come from a real broadcast navigation file through agnav_fusion.gnss_raw.ephemeris
(the same maths the filters use, so the simulated geometry and the processed one agree exactly). Per receiver
and satellite, on one frequency (GPS L1 C/A, Galileo E1, QZSS L1):

    code    P = ρ + c(δt_r − δt_s) + I + T + m_P + n_P
    phase   Φ = (ρ + c(δt_r − δt_s) − I + T + λN + m_Φ + n_Φ) / λ        [cycles]
    Doppler D = −(ρ̇ + c(δṫ_r − δṫ_s)) / λ + n_D                          [Hz, positive approaching]
    C/N0 from the elevation.

ρ is the range to the satellite at its true transmission time in the ECEF frame of reception (the ephemeris
module's Sagnac handling). Receiver clocks: bias + drift random walks. Atmosphere: slant ionosphere (zenith
`iono_zenith_m`) and troposphere at the base; the rover's differ by a per-satellite random gradient of
`iono_ppm`/`tropo_ppm` × horizontal distance to the base (residuals growing with the baseline). Multipath:
first-order Gauss-Markov per satellite, larger at low elevation. Cycle slips: random (`slip_rate`), with the
loss-of-lock flag; a satellite coming back from behind a mask restarts with a new integer ambiguity and LLI.
Sky masks (`SkyMask`) hide satellites from the rover in a time window: an azimuth sector below an elevation
(tree line on one side) or all but the `keep` highest satellites of one system (a 3–4 satellite window).

The rover antenna follows a simulator run's truth (`antenna_truth`: base_link + attitude × gnss_link lever).
"""
from dataclasses import dataclass, field

import numpy as np
from agnav_common.frames import rotation_matrix
from cssrlib.gnss import sat2id

from agnav_fusion.gnss_raw.ephemeris import satellite_state
from agnav_fusion.gnss_raw.geometry import elevation_azimuth, enu_basis, llh_to_ecef
from agnav_fusion.gnss_raw.observations import CLIGHT, ObsEpoch

FREQ_L1 = 1575.42e6
WAVELENGTH = CLIGHT / FREQ_L1


@dataclass
class SkyMask:
    """Rover-side blockage in [t0, t1) (simulation s): satellites with azimuth in [az0, az1) (deg, clockwise
    from north, wrapping) below `max_el_deg` are hidden; `keep` (int) instead hides all but the `keep` highest
    satellites of system `keep_system` above the elevation mask (and every other system's)."""
    t0: float
    t1: float
    az_deg: tuple = (0.0, 360.0)
    max_el_deg: float = 90.0
    keep: int = None
    keep_system: str = "G"

    def active(self, t):
        return self.t0 <= t < self.t1

    def hides(self, el_deg, az_deg):
        a0, a1 = self.az_deg
        inside = (a0 <= az_deg % 360.0 < a1) if a0 <= a1 else (az_deg % 360.0 >= a0 or az_deg % 360.0 < a1)
        return inside and el_deg < self.max_el_deg


@dataclass
class RawSimConfig:
    week: int = 2320
    tow0: float = 116400.0              # GPS time of simulation t = 0 (inside the nav file's validity)
    rate_hz: float = 1.0
    systems: str = "GEJ"
    elevation_min_deg: float = 5.0      # below: not tracked at all
    base_offset_enu: tuple = (800.0, 600.0, 0.0)   # base antenna from the map datum [m]
    clock_bias_s: tuple = (2e-7, -1e-7)            # rover, base initial receiver clock bias
    clock_drift: tuple = (5e-9, -3e-9)             # s/s initial drift
    clock_drift_rw: float = 1e-10                  # s/s per √s random walk of the drift
    iono_zenith_m: float = 5.0
    iono_ppm: float = 1.0               # σ of the rover−base slant ionosphere difference per metre of distance [1e-6]
    tropo_zenith_m: float = 2.4
    tropo_ppm: float = 0.3
    code_sigma: float = 0.3             # m, zenith-ish white noise (scaled by sqrt((1 + 1/sin²el)/2))
    phase_sigma: float = 0.0015         # m
    doppler_sigma: float = 0.03         # m/s
    mp_code: float = 0.3                # m, Gauss-Markov multipath σ at zenith (÷ sin el, capped ×4)
    mp_phase: float = 0.002             # m
    mp_tau: float = 10.0                # s
    slip_rate: float = 1.0 / 900.0      # per satellite per second (rover); the base is clean
    slip_flagged: float = 1.0           # probability that the receiver flags a slip (LLI); others pass silently
    masks: list = field(default_factory=list)
    seed: int = 0


@dataclass
class RawEpoch:
    t: float                  # simulation time [s]
    rover: ObsEpoch
    base: ObsEpoch
    antenna: np.ndarray       # true rover antenna ECEF [m]
    antenna_vel: np.ndarray   # ECEF m/s
    visible: list             # rover satellites tracked this epoch
    slipped: list = field(default_factory=list)   # rover satellites with a cycle slip this epoch (flagged or not)


@dataclass
class RawSim:
    epochs: list
    base_pos: np.ndarray      # base antenna ECEF
    origin: np.ndarray        # map datum ECEF
    enu_axes: np.ndarray      # (3, 3) rows east, north, up (ECEF) at the datum
    config: RawSimConfig

    def to_enu(self, xyz):
        return (np.asarray(xyz, float) - self.origin) @ self.enu_axes.T


def enu_frame(datum):
    """(origin ECEF, rows of the E/N/U axes in ECEF) of a map datum (lat deg, lon deg, ellipsoidal h)."""
    origin = llh_to_ecef(*datum)
    return origin, np.array(enu_basis(origin))


def antenna_truth(run):
    """(t, ECEF position, ECEF velocity) of the GNSS antenna of a SimRun at its truth rate."""
    tr, lever = run.truth, np.asarray(run.mounts["gnss_link"][0], float)
    origin, axes = enu_frame(run.datum)
    pos, vel = np.empty((len(tr.t), 3)), np.empty((len(tr.t), 3))
    for k in range(len(tr.t)):
        r = rotation_matrix(tr.roll[k], tr.pitch[k], tr.yaw[k])
        w = np.array([tr.wx[k], tr.wy[k], tr.wz[k]])
        pos[k] = np.array([tr.x[k], tr.y[k], tr.z[k]]) + r @ lever
        vel[k] = np.array([tr.vx[k], tr.vy[k], tr.vz[k]]) + r @ np.cross(w, lever)
    return tr.t, origin + pos @ axes, vel @ axes


def _satellites(nav, systems):
    return sorted({sat2id(e.sat) for e in nav.eph if sat2id(e.sat)[0] in systems})


class _Receiver:
    """Clock, per-satellite ambiguity/multipath/lock state of one receiver."""

    def __init__(self, bias, drift, rng):
        self.bias, self.drift, self.rng = bias, drift, rng
        self.amb, self.mp_code, self.mp_phase, self.tracked = {}, {}, {}, set()
        self.slipped = []

    def tick(self, dt, drift_rw):
        self.bias += self.drift * dt
        self.drift += self.rng.normal(0.0, drift_rw * np.sqrt(dt))

    def markov(self, store, sid, sigma, dt, tau):
        phi = np.exp(-dt / tau)
        prev = store.get(sid)
        store[sid] = self.rng.normal(0.0, sigma) if prev is None else \
            phi * prev + self.rng.normal(0.0, sigma * np.sqrt(1.0 - phi * phi))
        return store[sid]


def _observe(rx, sid, sv, pos, vel, el, atmos, cfg, slip_rate, dt):
    """One satellite's (code, phase, doppler, snr, lli) at receiver rx; sv = (sat pos, vel, clock, drift)."""
    s_pos, s_vel, s_clk, s_drift = sv
    los = s_pos - pos
    rng_ = np.linalg.norm(los)
    rate = (s_vel - vel) @ los / rng_
    se = max(np.sin(el), 0.05)
    scale = np.sqrt((1.0 + 1.0 / se ** 2) / 2.0)
    mp_scale = min(1.0 / se, 4.0)
    iono, tropo = atmos
    clk = CLIGHT * (rx.bias - s_clk)
    lli = False
    if sid not in rx.tracked:                               # (re)acquisition: new ambiguity, loss of lock
        rx.amb[sid] = float(rx.rng.integers(-50, 50))
        rx.tracked.add(sid)
        lli = True
    elif rx.rng.random() < slip_rate * dt:
        rx.amb[sid] += float(rx.rng.choice([-3, -2, -1, 1, 2, 3]))
        lli = bool(rx.rng.random() < cfg.slip_flagged)
        rx.slipped.append(sid)
    m_p = rx.markov(rx.mp_code, sid, cfg.mp_code * mp_scale, dt, cfg.mp_tau)
    m_f = rx.markov(rx.mp_phase, sid, cfg.mp_phase * mp_scale, dt, cfg.mp_tau)
    code = rng_ + clk + iono + tropo + m_p + rx.rng.normal(0.0, cfg.code_sigma * scale)
    phase = (rng_ + clk - iono + tropo + m_f + rx.rng.normal(0.0, cfg.phase_sigma * scale)) / WAVELENGTH \
        + rx.amb[sid]
    dop = -(rate + CLIGHT * (rx.drift - s_drift) + rx.rng.normal(0.0, cfg.doppler_sigma)) / WAVELENGTH
    snr = 32.0 + 18.0 * np.sin(el) + rx.rng.normal(0.0, 1.0)
    return code, phase, dop, snr, lli


def _epoch(cfg, tow, rows):
    n = len(rows)
    arr = {k: np.full((n, 1), np.nan) for k in ("code", "phase", "doppler", "snr")}
    lli = np.zeros((n, 1), bool)
    for i, (_, obs) in enumerate(rows):
        arr["code"][i, 0], arr["phase"][i, 0], arr["doppler"][i, 0], arr["snr"][i, 0], lli[i, 0] = obs
    return ObsEpoch(cfg.week, tow, [r[0] for r in rows], arr["code"], arr["phase"], arr["doppler"], arr["snr"],
                    lli, np.full((n, 1), WAVELENGTH))


def _sat_state(sid, cfg, tow, rx_pos, rx_bias, nav, cache):
    """Satellite state for a signal received at receiver time `tow` (two passes: the pseudorange sets the
    transmission time exactly as the processing will compute it)."""
    pr = 2.2e7
    for _ in range(2):
        st = satellite_state(sid, cfg.week, tow, pr, nav, rx_pos, cache)
        if st is None:
            return None
        pr = np.linalg.norm(st[0] - rx_pos) + CLIGHT * (rx_bias - st[2])
    return st


def _visible_after_masks(t, cand, cfg):
    """cand: {sid: (el deg, az deg)} -> set of sids the rover tracks at t."""
    keep = set(cand)
    for m in cfg.masks:
        if not m.active(t):
            continue
        if m.keep is not None:
            sys_sats = sorted((s for s in keep if s[0] == m.keep_system and cand[s][0] >= 15.0),
                              key=lambda s: -cand[s][0])
            keep = set(sys_sats[:m.keep])
        else:
            keep = {s for s in keep if not m.hides(*cand[s])}
    return keep


def simulate_raw(times, ant_pos, ant_vel, nav, origin, axes, config=None):
    """RawSim of rover (antenna track `ant_pos`/`ant_vel` ECEF at `times`, simulation s) + base observations at
    the epochs of `config.rate_hz` that fall on `times`."""
    cfg = config or RawSimConfig()
    rng = np.random.default_rng(cfg.seed)
    base_pos = origin + np.asarray(cfg.base_offset_enu, float) @ axes
    rover = _Receiver(cfg.clock_bias_s[0], cfg.clock_drift[0], np.random.default_rng(rng.integers(1 << 32)))
    base = _Receiver(cfg.clock_bias_s[1], cfg.clock_drift[1], np.random.default_rng(rng.integers(1 << 32)))
    sats = _satellites(nav, cfg.systems)
    grad = {s: rng.normal(0.0, 1.0, 2) for s in sats}       # per-satellite iono/tropo gradient draws
    step = 1.0 / cfg.rate_hz
    epochs, last_t = [], None
    for k, t in enumerate(times):
        if abs(t / step - round(t / step)) > 1e-6:
            continue
        dt = step if last_t is None else t - last_t
        last_t = t
        rover.tick(dt, cfg.clock_drift_rw)
        base.tick(dt, cfg.clock_drift_rw)
        tow = cfg.tow0 + round(t / step) * step
        pos, vel = ant_pos[k], ant_vel[k]
        dist = np.linalg.norm((pos - base_pos) @ axes[:2].T)
        cache, states, cand = {}, {}, {}
        for sid in sats:
            sb = _sat_state(sid, cfg, tow, base_pos, base.bias, nav, cache)
            sr = _sat_state(sid, cfg, tow, pos, rover.bias, nav, cache) if sb is not None else None
            if sr is None:
                continue
            el, az = (np.degrees(v[0]) for v in elevation_azimuth(base_pos, sb[0]))
            if el < cfg.elevation_min_deg:
                continue
            states[sid] = (sb, sr, np.radians(el))
            cand[sid] = (el, az)
        vis = _visible_after_masks(t, cand, cfg)
        rover.tracked &= vis
        base_rows, rover_rows, rover.slipped = [], [], []
        for sid, (sb, sr, el) in states.items():
            mi = 1.0 / max(np.sin(el), 0.1)          # simple slant mapping for both delays
            i_b, t_b = cfg.iono_zenith_m * mi, cfg.tropo_zenith_m * mi
            base_rows.append((sid, _observe(base, sid, sb, base_pos, np.zeros(3), el, (i_b, t_b), cfg, 0.0, dt)))
            if sid in vis:
                g = grad[sid] * dist * 1e-6
                atm = (i_b + cfg.iono_ppm * g[0] * mi, t_b + cfg.tropo_ppm * g[1] * mi)
                rover_rows.append((sid, _observe(rover, sid, sr, pos, vel, el, atm, cfg, cfg.slip_rate, dt)))
        epochs.append(RawEpoch(t, _epoch(cfg, tow, rover_rows), _epoch(cfg, tow, base_rows), pos.copy(),
                               vel.copy(), sorted(vis), list(rover.slipped)))
    return RawSim(epochs, base_pos, origin, axes, cfg)


def simulate_run_raw(run, nav, config=None):
    """RawSim synchronised with a SimRun (agnav_sim_eval.sim.run.simulate): the rover antenna follows its truth."""
    t, pos, vel = antenna_truth(run)
    origin, axes = enu_frame(run.datum)
    return simulate_raw(t, pos, vel, nav, origin, axes, config)
