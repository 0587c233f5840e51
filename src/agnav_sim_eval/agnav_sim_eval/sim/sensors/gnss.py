"""GNSS receivers of SPEC §11.7: antenna position with Gauss-Markov (coloured) + white errors, latency."""
import math
from dataclasses import dataclass

import numpy as np

FIX_DGPS, FIX_RTK_FLOAT, FIX_RTK_FIXED = 2, 3, 4


@dataclass(frozen=True)
class GnssParams:
    """Per-axis horizontal errors (m): second-order Gauss-Markov bias (sigma, tau; smooth from epoch to epoch, as
    differential corrections drift) + white; vertical ×vertical_ratio.
    latency_s: epoch -> message arrival, plus uniform [0, latency_jitter_s) (arrivals stay in order);
    vel_noise_mps: white on the ENU antenna velocity. outages: ((start, end) s, ...) without fixes;
    float_episodes: ((start, end) s, ...) of RTK float, whose extra Gauss-Markov error (float_sigma_m, float_tau_s)
    is added to the fix and to its covariance."""

    model: str = "StarFire SF-2050M"
    rate_hz: float = 1.0
    bias_sigma_m: float = 0.06
    bias_tau_s: float = 120.0
    white_sigma_m: float = 0.025
    vertical_ratio: float = 2.0
    latency_s: float = 0.02
    vel_noise_mps: float = 0.03
    fix_type: int = FIX_DGPS
    satellites: int = 9
    hdop: float = 0.9
    correction_age_s: float = 3.0
    latency_jitter_s: float = 0.0
    outages: tuple = ()
    float_episodes: tuple = ()
    float_sigma_m: float = 0.15
    float_tau_s: float = 20.0


class GnssReceiver:
    """Samples the antenna position/velocity at each epoch; errors in map ENU metres."""

    def __init__(self, params: GnssParams, rng: np.random.Generator):
        self.params = params
        self._rng = rng
        self._scale = np.array([1.0, 1.0, params.vertical_ratio])
        # two cascaded first-order stages with equal tau; the second has half the first's variance
        self._stage = params.bias_sigma_m * math.sqrt(2.0) * self._scale * rng.standard_normal(3)
        self.bias = params.bias_sigma_m * self._scale * rng.standard_normal(3)
        self._float = params.float_sigma_m * self._scale * rng.standard_normal(3) if params.float_episodes else None
        self._last_arrival = -math.inf

    @staticmethod
    def _inside(t, windows):
        return any(a <= t < b for a, b in windows)

    def available(self, t):
        """False inside an outage."""
        return not self._inside(t, self.params.outages)

    def floating(self, t):
        """True inside an RTK float episode."""
        return self._inside(t, self.params.float_episodes)

    def arrival(self, t):
        """Arrival time of the epoch at t: latency plus jitter, never before the previous arrival."""
        p = self.params
        jitter = self._rng.uniform(0.0, p.latency_jitter_s) if p.latency_jitter_s else 0.0
        self._last_arrival = max(self._last_arrival, t + p.latency_s + jitter)
        return self._last_arrival

    def sample(self, dt, antenna_enu, antenna_vel_enu, t=0.0):
        """(position ENU m, velocity ENU m/s) measured at the epoch t; dt = time since the previous epoch."""
        p, rng = self.params, self._rng
        a = math.exp(-dt / p.bias_tau_s)
        drive = math.sqrt(2.0) * p.bias_sigma_m * self._scale
        self._stage = a * self._stage + math.sqrt(1 - a * a) * drive * rng.standard_normal(3)
        self.bias = a * self.bias + (1 - a) * self._stage
        pos = antenna_enu + self.bias + p.white_sigma_m * self._scale * rng.standard_normal(3)
        if self._float is not None:
            b = math.exp(-dt / p.float_tau_s)
            self._float = b * self._float + math.sqrt(1 - b * b) * p.float_sigma_m * self._scale * rng.standard_normal(3)
            pos = pos + self._float * self.floating(t)
        vel = antenna_vel_enu + p.vel_noise_mps * self._scale * rng.standard_normal(3)
        return pos, vel

    @property
    def position_cov(self):
        """Honest ENU covariance (m^2): Gauss-Markov variance plus white variance per axis."""
        p = self.params
        return np.diag((p.bias_sigma_m ** 2 + p.white_sigma_m ** 2) * self._scale ** 2)

    def status(self, t):
        """(fix type, ENU covariance m^2) at the epoch t: RTK float episodes add their error variance."""
        if self.floating(t):
            return FIX_RTK_FLOAT, self.position_cov + np.diag((self.params.float_sigma_m * self._scale) ** 2)
        return self.params.fix_type, self.position_cov

    @property
    def velocity_cov(self):
        """ENU velocity covariance (m^2/s^2)."""
        return np.diag((self.params.vel_noise_mps * self._scale) ** 2)
