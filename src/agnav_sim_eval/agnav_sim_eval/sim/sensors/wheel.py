"""Wheel (or ISO 11783 wheel-based) speed with traction slip: the speed the wheels turn at, not the ground speed."""
import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class WheelParams:
    """Output = (1 + scale)(1 + slip(t))·v_ground + noise while moving; slip: Gauss-Markov around slip_mean
    (fraction; 0.05-0.15 on soil), rolling-radius scale error uniform ±scale_error."""

    rate_hz: float = 10.0
    slip_mean: float = 0.05
    slip_sigma: float = 0.02
    slip_tau_s: float = 10.0
    scale_error: float = 0.02
    noise_mps: float = 0.02


class WheelSpeed:
    """Samples the measured forward speed (m/s) from the true ground speed."""

    def __init__(self, params: WheelParams, rng: np.random.Generator):
        self.params = params
        self._rng = rng
        self.scale = rng.uniform(-params.scale_error, params.scale_error)
        self.slip = params.slip_mean

    def sample(self, dt, ground_speed):
        """Measured wheel speed; exactly 0 at standstill (encoders do not move)."""
        p = self.params
        a = math.exp(-dt / p.slip_tau_s)
        self.slip = p.slip_mean + a * (self.slip - p.slip_mean) + math.sqrt(1 - a * a) * p.slip_sigma * self._rng.normal()
        if ground_speed <= 0.0:
            return 0.0
        return (1 + self.scale) * (1 + self.slip) * ground_speed + p.noise_mps * self._rng.normal()

    @property
    def variance(self):
        """Honest (m/s)^2 at 1 m/s: noise plus the slip and scale spreads (the filter sees them as speed error)."""
        p = self.params
        return p.noise_mps ** 2 + p.slip_mean ** 2 + p.slip_sigma ** 2 + p.scale_error ** 2 / 3
