"""Three-axis accelerometer (servo accelerometers of the JCS-7401A FOG IMU, SPEC §11.2 [IMPL])."""
from dataclasses import dataclass

import numpy as np

from .lowpass import FirstOrderLag


@dataclass(frozen=True)
class AccelParams:
    """Specific-force error model: constant bias (uniform ±), scale error, white noise, band limit, range."""

    bias_mps2: float = 0.01
    scale_error: float = 0.002
    noise_mps2: float = 0.02
    bandwidth_hz: float | None = 50.0
    range_mps2: float = 4 * 9.80665


class Accelerometer:
    """Samples true specific force (m/s^2, sensor frame) into measured specific force."""

    def __init__(self, params: AccelParams, rng: np.random.Generator):
        self.params = params
        self._rng = rng
        self.bias = rng.uniform(-params.bias_mps2, params.bias_mps2, 3)
        self.scale = rng.uniform(-params.scale_error, params.scale_error, 3)
        self._lpf = FirstOrderLag.from_bandwidth(params.bandwidth_hz)

    @property
    def variance(self):
        """Per-axis variance (m/s^2)^2: white noise plus the turn-on bias spread."""
        return self.params.noise_mps2 ** 2 + self.params.bias_mps2 ** 2 / 3

    def sample(self, dt, specific_force):
        """Measured specific force for the true one (level at rest: (0, 0, +g))."""
        p = self.params
        f = self._lpf.update((1 + self.scale) * specific_force, dt) + self.bias
        f = f + p.noise_mps2 * self._rng.standard_normal(3)
        return np.clip(f, -p.range_mps2, p.range_mps2)
