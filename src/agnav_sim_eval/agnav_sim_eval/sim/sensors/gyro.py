"""Three-axis rate gyro: vibratory (ENV-05D/05F, SPEC §11.3–11.4, (3.8)) or fibre-optic (SPEC §11.2)."""
import math
from dataclasses import dataclass

import numpy as np

from .lowpass import FirstOrderLag


@dataclass(frozen=True)
class GyroParams:
    """Error model in data-sheet units (deg/s); per-axis tuples are (x, y, z) of the sensor frame.

    Output = clip(LPF_bw[(1+s)ω] + b(t) + n) with b(t) = b_off + b_motion·m(t) + b_warm(1-e^{-t/τw}) + random walk.
    b_off: V_static error left after the pre-run standstill mean, or a FOG's turn-on drift (random sign, magnitude
    uniform in [offset_min_dps, offset_dps]); b_motion: offset that appears once the
    vehicle moves (vibration, supply load; the thesis' equivalent mean biases, SPEC §11.4), spread per seed;
    m(t): motion indicator through a lag; angle_noise_deg: white noise on the integrated angle (FOG, SPEC §11.2).
    """

    bandwidth_hz: float | None = 10.0
    range_dps: float = 60.0
    scale_error: float = 0.01
    offset_dps: float = 0.0
    offset_min_dps: float = 0.0
    motion_bias_dps: tuple = (0.0, 0.0, 0.0)
    motion_bias_spread: float = 0.2
    motion_tau_s: float = 5.0
    warmup_dps: float = 0.0
    warmup_tau_s: float = 900.0
    random_walk_dps_rt_s: float = 6e-4
    noise_dps: float = 0.25
    angle_noise_deg: float = 0.0


class Gyro:
    """Samples body rates (rad/s, sensor frame) into measured rates (rad/s)."""

    def __init__(self, params: GyroParams, rng: np.random.Generator):
        self.params = params
        self._rng = rng
        d = math.radians
        self.scale = rng.uniform(-params.scale_error, params.scale_error, 3)
        u = rng.uniform(-1, 1, 3)
        magnitude = params.offset_min_dps + (params.offset_dps - params.offset_min_dps) * np.abs(u)
        self.offset = np.sign(u) * np.radians(magnitude)
        self.motion_bias = np.radians(params.motion_bias_dps) * (1 + params.motion_bias_spread * rng.standard_normal(3))
        self._lpf = FirstOrderLag.from_bandwidth(params.bandwidth_hz)
        self._motion = FirstOrderLag(params.motion_tau_s)
        self._walk = np.zeros(3)
        self._angle_noise = np.zeros(3)
        self.bias = self.offset.copy()

    def variance(self, dt):
        """Per-axis variance (rad/s)^2 of one sample's white error (rate noise, differentiated angle noise)."""
        p = self.params
        return math.radians(p.noise_dps) ** 2 + 2 * (math.radians(p.angle_noise_deg) / dt) ** 2

    def sample(self, t, dt, omega, moving):
        """Measured rates at time t (s) for true sensor-frame rates omega (rad/s); moving: vehicle in motion."""
        p, rng = self.params, self._rng
        self._walk += math.radians(p.random_walk_dps_rt_s) * math.sqrt(dt) * rng.standard_normal(3)
        m = self._motion.update(1.0 if moving else 0.0, dt)
        warm = math.radians(p.warmup_dps) * (1 - math.exp(-t / p.warmup_tau_s))
        self.bias = self.offset + self.motion_bias * m + warm + self._walk
        out = self._lpf.update((1 + self.scale) * omega, dt) + self.bias
        out = out + math.radians(p.noise_dps) * rng.standard_normal(3)
        if p.angle_noise_deg:
            e = math.radians(p.angle_noise_deg) * rng.standard_normal(3)
            out = out + (e - self._angle_noise) / dt
            self._angle_noise = e
        lim = math.radians(p.range_dps)
        return np.clip(out, -lim, lim)
