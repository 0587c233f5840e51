"""Three-axis fluxgate GDS, Watson FGM-200A/300A (SPEC §11.1, Table 2.1)."""
import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from .lowpass import FirstOrderLag

MILLIGAUSS = 1e-7  # tesla


@dataclass(frozen=True)
class FluxgateParams:
    """Data-sheet errors in mG/deg: zero bias ±10 mG, hard iron of the vehicle (uniform ±, constant in the
    sensor frame), axis misalignment ±1°, linearity/scale ±0.5 %, ripple 1.25 mG rms, DC-20 Hz, ±1000 mG;
    soft_iron: symmetric distortion of the vehicle's steel (entries uniform ±, fraction; 0 for the bare sensor)."""

    zero_bias_mg: float = 10.0
    hard_iron_mg: float = 30.0
    misalignment_deg: float = 1.0
    scale_error: float = 0.005
    noise_mg: float = 1.25
    bandwidth_hz: float = 20.0
    range_mg: float = 1000.0
    soft_iron: float = 0.0


class Fluxgate:
    """Samples the sensor-frame field (tesla) from the ENU field and the sensor attitude."""

    def __init__(self, params: FluxgateParams, rng: np.random.Generator):
        self.params = params
        self._rng = rng
        mis = Rotation.from_rotvec(np.radians(params.misalignment_deg) * rng.uniform(-1, 1, 3) / math.sqrt(3))
        self.matrix = np.diag(1 + rng.uniform(-params.scale_error, params.scale_error, 3)) @ mis.as_matrix()
        self.hard_iron = MILLIGAUSS * (rng.uniform(-params.hard_iron_mg, params.hard_iron_mg, 3)
                                       + rng.uniform(-params.zero_bias_mg, params.zero_bias_mg, 3))
        self._lpf = FirstOrderLag.from_bandwidth(params.bandwidth_hz)
        if params.soft_iron:
            s = rng.uniform(-params.soft_iron, params.soft_iron, (3, 3))
            self.matrix = (np.eye(3) + 0.5 * (s + s.T)) @ self.matrix

    def sample(self, dt, r_enu_from_sensor, field_enu):
        """Measured field (tesla, sensor frame); r_enu_from_sensor rotates sensor-frame vectors into ENU."""
        p = self.params
        b = self.matrix @ (r_enu_from_sensor.T @ field_enu) + self.hard_iron
        b = self._lpf.update(b, dt) + p.noise_mg * MILLIGAUSS * self._rng.standard_normal(3)
        return np.clip(b, -p.range_mg * MILLIGAUSS, p.range_mg * MILLIGAUSS)

    @property
    def variance(self):
        """Per-axis white-noise variance (tesla^2)."""
        return (self.params.noise_mg * MILLIGAUSS) ** 2
