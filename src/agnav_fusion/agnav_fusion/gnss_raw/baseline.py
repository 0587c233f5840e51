"""Float DD baseline filter (EKF: rover position + DD ambiguities in metres) with integer fixing per epoch.

Measurement model (SPEC §7.7, 5-7-5/6): DD code = h(x) + n_A, DD phase = h(x) + N + n_I, correlated covariances
from double_difference. Ambiguities are constant (a small random walk); on loss of lock (LLI at either receiver)
the satellite's ambiguity restarts from DD phase − DD code; satellites rising/setting and reference changes are
carried by ambiguities.reindex. Dynamics 'kinematic' re-estimates the position every epoch (large process noise,
as RTKLIB's kinematic mode without dynamics; what a moving rover needs), 'static' holds it. Fixing is
instantaneous (each epoch from the float state, never fed back), validated by the ratio test.
"""
from dataclasses import dataclass, field

import numpy as np

from agnav_fusion import kalman
from agnav_fusion.gnss_raw import fixing
from agnav_fusion.gnss_raw.ambiguities import reindex
from agnav_fusion.gnss_raw.double_difference import DDConfig, form_double_differences
from agnav_fusion.gnss_raw.ephemeris import satellite_states

N_POS = 3


@dataclass
class BaselineConfig:
    dynamics: str = "kinematic"     # or "static"
    sigma_kinematic: float = 30.0   # m per epoch, position process noise in kinematic mode
    sigma_amb_rate: float = 3e-4    # m/√s, ambiguity random walk (keeps the float ambiguities from growing
    #                                 overconfident on time-correlated code errors; 1e-4: ratio fails after ~3 min)
    sigma_amb_init: float = 5.0     # m, a fresh ambiguity's σ about DD phase − DD code
    sigma_pos_init: float = 100.0   # m, first epoch's position σ about the initial guess
    ratio_threshold: float = fixing.RATIO_THRESHOLD
    fix: bool = True                # integer fixing each epoch (off: float only)
    max_iterations: int = 3         # iterated EKF while the position moves by more than 1 mm
    dd: DDConfig = field(default_factory=DDConfig)


@dataclass
class BaselineSolution:
    time: float                  # GPS s (receiver time of the rover epoch)
    float_pos: np.ndarray        # rover ECEF m
    float_cov: np.ndarray
    fixed: bool
    fixed_pos: np.ndarray        # None when not fixed
    ratio: float
    n_dd: int
    refs: dict


class BaselineFilter:
    """Rover position relative to a base at a known ECEF position, from DDs epoch by epoch."""

    def __init__(self, base_pos, config=None, rover_guess=None):
        self.config = config or BaselineConfig()
        self.base_pos = np.asarray(base_pos, float)
        guess = self.base_pos if rover_guess is None else np.asarray(rover_guess, float)
        self.x = guess.copy()
        self.P = np.eye(N_POS) * self.config.sigma_pos_init ** 2
        self.keys, self.refs, self.time = [], {}, None

    @property
    def position(self):
        return self.x[:N_POS].copy()

    def _predict(self, time):
        c = self.config
        dt = 0.0 if self.time is None else max(time - self.time, 0.0)
        if c.dynamics == "kinematic" and self.time is not None:
            self.P[:N_POS, :N_POS] += np.eye(N_POS) * c.sigma_kinematic ** 2
        self.P[N_POS:, N_POS:] += np.eye(len(self.keys)) * c.sigma_amb_rate ** 2 * dt
        self.time = time

    def _reindex(self, dd):
        reset = np.array([dd.slip[i] or dd.ref_slip.get(k[:2], False) for i, k in enumerate(dd.keys)], bool)
        init = dd.phase - dd.code
        var = np.full(len(dd), self.config.sigma_amb_init ** 2)
        self.x, self.P, fresh = reindex(self.x, self.P, N_POS, self.keys, self.refs, dd.keys, dd.refs, reset,
                                        init, var)
        self.keys, self.refs = list(dd.keys), dict(dd.refs)
        return fresh

    def _correct(self, dd):
        m = len(dd)
        R = np.zeros((2 * m, 2 * m))
        R[:m, :m], R[m:, m:] = dd.cov_code, dd.cov_phase
        z = np.concatenate([dd.code, dd.phase])
        x0, P0 = self.x, self.P
        x = x0.copy()
        for _ in range(self.config.max_iterations):    # iterated EKF about the updated position
            h, G = dd.geometry(x[:N_POS])
            H = np.zeros((2 * m, len(x)))
            H[:m, :N_POS], H[m:, :N_POS] = G, G
            H[m:, N_POS:] = np.eye(m)
            pred = np.concatenate([h, h + x[N_POS:]])
            x_new, P = kalman.update(x0, P0, z - pred - H @ (x0 - x), H @ P0 @ H.T + R, H, R)
            moved = np.linalg.norm(x_new[:N_POS] - x[:N_POS])
            x = x_new
            if moved < 1e-3:
                break
        self.x, self.P = x, P
        return z - pred

    def update(self, dd, time):
        """One epoch of DoubleDifferences (None: prediction only) -> BaselineSolution."""
        self._predict(time)
        if dd is None or len(dd) == 0:
            return BaselineSolution(time, self.position, self.P[:N_POS, :N_POS].copy(), False, None, 0.0, 0, {})
        self._reindex(dd)
        self._correct(dd)
        fx = fixing.fix(self.x, self.P, N_POS, dd.wavelength, self.config.ratio_threshold) if self.config.fix \
            else fixing.FixResult(False, 0.0, len(dd))
        return BaselineSolution(time, self.position, self.P[:N_POS, :N_POS].copy(), fx.ok,
                                fx.pos if fx.ok else None, fx.ratio, len(dd), dict(dd.refs))


def process(pairs, nav, base_pos, config=None, rover_guess=None):
    """BaselineSolution per (rover ObsEpoch, base ObsEpoch) pair of the same time."""
    filt = BaselineFilter(base_pos, config, rover_guess)
    out = []
    for rover, base in pairs:
        cache = {}
        sv_base = satellite_states(base, nav, filt.base_pos, cache)
        sv_rover = satellite_states(rover, nav, filt.position, cache)
        dd = form_double_differences(rover, base, sv_rover, sv_base, filt.base_pos, filt.config.dd)
        out.append(filt.update(dd, rover.time))
    return out
