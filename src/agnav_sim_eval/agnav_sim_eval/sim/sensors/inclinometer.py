"""Two single-axis capacitive inclinometers (D5R-L02-15 / AccuStar, SPEC §11.5–11.6 model [RECON])."""
import math
from dataclasses import dataclass

import numpy as np

from .lowpass import FirstOrderLag

G = 9.80665


@dataclass(frozen=True)
class InclParams:
    """Angles from the specific-force direction through a first-order lag, plus zero offset (uniform ±),
    scale error (uniform ±), cross-axis coupling, white noise and range clipping; degrees as in the data sheets.
    accel_sensitivity = 1 for a pendulous sensor; 0 models an attitude output that is not fooled (FOG IMU)."""

    tau_s: float = 1.1
    offset_deg: float = 0.3
    scale_error: float = 0.03
    cross_axis: float = 0.01
    noise_deg: float = 0.1
    range_deg: float = 15.0
    accel_sensitivity: float = 1.0


class Inclinometer:
    """Samples (roll, pitch) REP-103 rad from the true attitude and specific force at the sensor."""

    def __init__(self, params: InclParams, rng: np.random.Generator):
        self.params = params
        self._rng = rng
        self.offset = np.radians(params.offset_deg) * rng.uniform(-1, 1, 2)
        self.scale = rng.uniform(-params.scale_error, params.scale_error, 2)
        self._lag = FirstOrderLag(params.tau_s)

    @staticmethod
    def apparent_tilt(specific_force):
        """(roll, pitch) a pendulum reads from the specific force f (FLU): roll = asin(f_y/g), pitch = asin(-f_x/g)."""
        fx, fy, _ = specific_force
        return np.array([math.asin(max(-1.0, min(1.0, fy / G))), math.asin(max(-1.0, min(1.0, -fx / G)))])

    def sample(self, dt, roll, pitch, specific_force):
        """Measured (roll, pitch) rad; specific_force in the inclinometer frame (m/s^2)."""
        p = self.params
        true = np.array([roll, pitch])
        tilt = true + p.accel_sensitivity * (self.apparent_tilt(specific_force) - true)
        tilt = (1 + self.scale) * tilt + p.cross_axis * tilt[::-1]
        out = self._lag.update(tilt, dt) + self.offset
        out = out + math.radians(p.noise_deg) * self._rng.standard_normal(2)
        lim = math.radians(p.range_deg)
        return np.clip(out, -lim, lim)

    @property
    def variance(self):
        """Honest per-axis variance (rad^2): noise plus the offset spread (lag and acceleration are not white)."""
        p = self.params
        return math.radians(p.noise_deg) ** 2 + math.radians(p.offset_deg) ** 2 / 3
