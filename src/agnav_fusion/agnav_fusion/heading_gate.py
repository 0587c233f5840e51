"""Magnetic-disturbance gate of the GDS heading (agnav issue 16 item 10). ROS-free; rad, s, clockwise headings.

A GDS sample is disturbed when its field is off the reference (intensity/inclination, geomagnetic_model.disturbance)
or when its heading disagrees with the integrated gyro: the GDS−gyro offset o = φ_GDS − φ_gyro is constant up to
the GDS noise and the gyro drift, so o is compared with the mean offset ō of the last `reference_window` s of clean
samples. The test keeps the rotations of the field that leave its strength and dip unchanged from being fused.
While disturbed the GDS is not fused and the heading is the gyro's alone, its variance growing with the gyro's
residual bias, angle random walk and bias random walk (`propagation_variance`). The gate reopens after
`recover_time` s of in-tolerance samples whose mean innovation is within `k_recover` σ (hysteresis: an offset
that just passes the per-sample test is not taken back while the gyro still contradicts it).
"""
import math
from collections import deque
from dataclasses import dataclass

from agnav_common.frames import wrap_angle


@dataclass
class GyroErrorSettings:
    """Yaw gyro errors that a gyro-only heading accumulates (1σ)."""

    bias: float = math.radians(0.05)         # rad/s residual rate bias (JCS-7401A FOG: 2°/min spec = 0.033°/s)
    arw: float = math.radians(0.05)          # rad/√s angle random walk
    bias_walk: float = math.radians(0.001)   # rad/s/√s rate random walk


def propagation_variance(g: GyroErrorSettings, tau: float) -> float:
    """Heading variance (rad²) a gyro-only propagation over tau seconds adds."""
    tau = max(tau, 0.0)
    return g.arw ** 2 * tau + (g.bias * tau) ** 2 + g.bias_walk ** 2 * tau ** 3 / 3.0


@dataclass
class GateSettings:
    k_sigma: float = 4.0                  # per-sample innovation threshold in σ of the offset
    k_recover: float = 2.0                # mean innovation over recover_time that reopens the gate, in σ
    reference_window: float = 10.0        # s of clean offsets forming the reference ō
    min_reference: float = 1.0            # s of clean offsets before the test starts
    recover_time: float = 1.0             # s of consistent samples before the GDS is fused again
    offset_sigma_floor: float = math.radians(0.2)   # lower bound of the offset spread s
    gyro: GyroErrorSettings = None

    def __post_init__(self):
        if self.gyro is None:
            self.gyro = GyroErrorSettings()


class MagneticGate:
    """`update(t, gds_heading, gyro_heading, field_disturbed)` -> True while the GDS must not be fused."""

    def __init__(self, settings: GateSettings | None = None):
        self.s = settings or GateSettings()
        self._ref: deque = deque()   # (t, offset) of clean samples, offsets continuous with each other
        self.disturbed = False
        self.reason = None           # "field" | "innovation" while disturbed
        self.innovation = 0.0        # e = o − ō of the last sample (rad)
        self.sigma = math.inf        # its 1σ (inf while the reference is too short)
        self._clean_since = None     # first in-tolerance sample after the last flagged one
        self._recent = deque()       # (t, innovation) of the last recover_time s while disturbed

    def _reference(self, t):
        """(ō, σ of a new offset against ō) or None while the reference is shorter than min_reference."""
        if len(self._ref) < 2 or self._ref[-1][0] - self._ref[0][0] < self.s.min_reference:
            return None
        n = len(self._ref)
        ts = sum(r[0] for r in self._ref) / n
        mean = sum(r[1] for r in self._ref) / n
        spread = max(math.sqrt(sum((r[1] - mean) ** 2 for r in self._ref) / (n - 1)), self.s.offset_sigma_floor)
        # a new sample: its own spread, the mean's, and the gyro drift since the reference's mean epoch
        return mean, math.sqrt(spread ** 2 * (1.0 + 1.0 / n) + propagation_variance(self.s.gyro, t - ts))

    def update(self, t: float, gds_heading: float, gyro_heading: float, field_disturbed: bool) -> bool:
        offset = wrap_angle(gds_heading - gyro_heading)
        ref = self._reference(t)
        if ref is not None:
            mean, self.sigma = ref
            self.innovation = wrap_angle(offset - mean)
            offset = mean + self.innovation        # continuous with the reference
        else:
            self.innovation, self.sigma = 0.0, math.inf
            if self._ref:
                offset = self._ref[-1][1] + wrap_angle(offset - self._ref[-1][1])
        inconsistent = abs(self.innovation) > self.s.k_sigma * self.sigma
        if field_disturbed or inconsistent:
            self.disturbed, self._clean_since = True, None
            self._recent.clear()
            self.reason = "field" if field_disturbed else "innovation"
        elif self.disturbed:
            self._clean_since = t if self._clean_since is None else self._clean_since
            self._recent.append((t, self.innovation))
            while self._recent[0][0] < t - self.s.recover_time:
                self._recent.popleft()
            mean = sum(e for _, e in self._recent) / len(self._recent)
            if t - self._clean_since >= self.s.recover_time and abs(mean) <= self.s.k_recover * self.sigma:
                self.disturbed, self.reason, self._clean_since = False, None, None
                self._recent.clear()
        if not self.disturbed:
            self._ref.append((t, offset))
            while self._ref[0][0] <= t - self.s.reference_window:
                self._ref.popleft()
        return self.disturbed
