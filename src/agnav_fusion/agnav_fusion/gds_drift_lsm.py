"""Gyro drift LSM against the delayed GDS and GDS–gyro VWA with delay compensation (SPEC §4.5–4.7, eq 3.14–3.24).

Fixed-rate samples; rates in rad/s and headings in rad, clockwise positive (thesis convention).
The GDS sample fed at step t represents epoch t − delay (tilt compensation with ALE-filtered roll/pitch, §4.4).
"""
import math
from collections import deque
from dataclasses import dataclass

from agnav_common.frames import wrap_angle
from agnav_common.variance_weighted_average import VariableTargetVwa, VwaSettings


@dataclass
class DriftLsmSettings:
    """§4.5 parameters at 50 Hz: M = 175 (3.5 s), delay 35 samples (0.7 s)."""

    window: int = 175
    delay: int = 35
    dt: float = 0.02


class Unwrapper:
    """Continuous heading from wrapped samples."""

    def __init__(self):
        self.value: float | None = None

    def __call__(self, heading: float) -> float:
        self.value = heading if self.value is None else self.value + wrap_angle(heading - self.value)
        return self.value


class GyroDriftLsm:
    """d_t = Σ(ω_GDS(i) − ω_gyro(i − delay)) / (M + 1) (3.18), O(1) by telescoping both sums (SPEC §4.5 note)."""

    def __init__(self, settings: DriftLsmSettings | None = None):
        self.s = settings or DriftLsmSettings()
        self._gds = deque(maxlen=self.s.window + 2)                     # φ_GDS(t−M−1) … φ_GDS(t)
        self._cum = deque(maxlen=self.s.window + self.s.delay + 2)      # Σ_{j≤k} ω_gyro(j) dt
        self._unwrap = Unwrapper()
        self.drift = 0.0          # d (3.14), rad/s; 0 until the first full window
        self.ready = False

    def update(self, omega_gyro: float, heading_gds_delayed: float) -> float:
        """Add ω_gyro(t) and the GDS sample available at t; return the current drift estimate."""
        self._cum.append((self._cum[-1] if self._cum else 0.0) + omega_gyro * self.s.dt)
        self._gds.append(self._unwrap(heading_gds_delayed))
        if len(self._gds) == self._gds.maxlen and len(self._cum) == self._cum.maxlen:
            gyro_change = self._cum[self.s.window + 1] - self._cum[0]    # Σ ω_gyro(i−delay) dt, i = t−M … t
            self.drift = (self._gds[-1] - self._gds[0] - gyro_change) / ((self.s.window + 1) * self.s.dt)
            self.ready = True
        return self.drift


@dataclass
class DelayedVwaSettings:
    """§4.6: window T = 15 s, statistics every 5 s, GDS delay in samples, sample interval."""

    window: float = 15.0
    interval: float = 5.0
    delay: int = 35
    dt: float = 0.02


class DelayCompensatedVwa:
    """φ_VWA(t−D) from (3.19)–(3.23), advanced to t with the drift-corrected gyro (3.24)."""

    def __init__(self, settings: DelayedVwaSettings | None = None):
        self.s = settings or DelayedVwaSettings()
        self._vwa = VariableTargetVwa(VwaSettings(self.s.window, self.s.interval))
        self._gyro = deque(maxlen=self.s.delay + 1)     # φ_Gyro(t−D) … φ_Gyro(t)
        self._unwrap = Unwrapper()
        self._n = 0

    @property
    def stats(self):
        """Window statistics of the last update (σ², means) or None."""
        return self._vwa.stats

    def update(self, omega_gyro: float, drift: float, heading_gds_delayed: float,
               gds_variance_scale: float = 1.0) -> tuple[float, float]:
        """Return (φ_estimate(t) wrapped, variance rad²)."""
        prev = self._gyro[-1] if self._gyro else None
        if prev is None:   # anchor the relative gyro heading on the first GDS sample
            prev = heading_gds_delayed
        self._gyro.append(prev + (omega_gyro + drift) * self.s.dt)
        gds = self._unwrap(heading_gds_delayed)
        self._n += 1
        out = self._vwa.update(self._n * self.s.dt, gds, self._gyro[0], gds_variance_scale)
        if out is None:   # before the first window: delayed GDS advanced by the gyro
            return wrap_angle(gds + self._gyro[-1] - self._gyro[0]), math.nan
        _, est_delayed, var = out
        return wrap_angle(est_delayed + self._gyro[-1] - self._gyro[0]), var


class GdsGyroSystem:
    """§4.7 steps 3–4: drift LSM then delay-compensated VWA on one stream of (ω_gyro, delayed GDS)."""

    def __init__(self, lsm: DriftLsmSettings | None = None, vwa: DelayedVwaSettings | None = None):
        self.lsm = GyroDriftLsm(lsm)
        self.vwa = DelayCompensatedVwa(vwa)

    def update(self, omega_gyro: float, heading_gds_delayed: float, gds_variance_scale: float = 1.0):
        """Return (heading, variance, drift)."""
        d = self.lsm.update(omega_gyro, heading_gds_delayed)
        heading, var = self.vwa.update(omega_gyro, d, heading_gds_delayed, gds_variance_scale)
        return heading, var, d
