"""Absolute heading and yaw-gyro drift from the GNSS track (SPEC §5.1-5.2, eq 4.1-4.17).

Thesis conventions: X east, Y north, heading phi clockwise from north, yaw rate clockwise positive;
angles rad, rates rad/s. Fixes are processed at their measurement epochs; the caller supplies the
gyro headings sampled at those epochs (from its IMU history, so GNSS latency does not matter).
"""
import math
from collections import deque
from dataclasses import dataclass

from agnav_fusion.drift_lsm import WindowDriftLSM, wrap


@dataclass
class KiseLSMSettings:
    window: int = 10         # N GNSS epochs in (4.6) (not given by the thesis [AMBIG] #14)
    min_speed: float = 0.2   # m/s, epochs slower than this add no terms (no heading information)


class KiseLSM:
    """Gyro heading bias b_k from GNSS displacements (4.6)-(4.10); heading phi_k = phi_gk + b_k (4.3)."""

    def __init__(self, settings=None):
        self.settings = settings or KiseLSMSettings()
        self._terms = deque(maxlen=self.settings.window + 1)  # (num_i, den_i, S_i^2 + C_i^2)
        self._prev = None
        self.bias = None

    def update(self, x, y, speed, gyro_heading, dt):
        """One epoch: position (m), speed V (m/s), gyro heading phi_g (rad), epoch interval dt (s); returns b_k."""
        prev, self._prev = self._prev, (x, y, gyro_heading)
        if prev is None or speed < self.settings.min_speed:
            return self.bias
        dx, dy = x - prev[0], y - prev[1]                                             # (4.7), (4.8)
        s = 0.5 * speed * dt * (math.sin(gyro_heading) + math.sin(prev[2]))          # (4.9)
        c = 0.5 * speed * dt * (math.cos(gyro_heading) + math.cos(prev[2]))          # (4.10)
        self._terms.append((dx * c - dy * s, dx * s + dy * c, s * s + c * c))
        num = sum(t[0] for t in self._terms)
        den = sum(t[1] for t in self._terms)
        self.bias = math.atan2(num, den)                                             # (4.6)
        return self.bias

    def variance(self, position_variance):
        """Approximate var(b_k): per-axis displacement variance 2*sigma^2 over the window's sum of S^2+C^2."""
        norm = sum(t[2] for t in self._terms)
        return 2.0 * position_variance / norm if norm > 0 else float("inf")


@dataclass
class GnssGyroHeadingSettings:
    kise: KiseLSMSettings = None
    drift_window: int = 20      # M GNSS epochs of (4.16) (not given [AMBIG] #14)
    anchor_gain: float = 0.1    # per-epoch pull of the corrected gyro heading to the Kise heading [RECON]

    def __post_init__(self):
        self.kise = self.kise or KiseLSMSettings()


class GnssGyroHeading:
    """Kise LSM (4.6) + drift LSM (4.16)-(4.17): drift-corrected gyro heading anchored to the Kise heading."""

    def __init__(self, settings=None):
        self.settings = settings or GnssGyroHeadingSettings()
        self.kise = KiseLSM(self.settings.kise)
        self._drift = WindowDriftLSM(self.settings.drift_window, circular=True)
        self._prev_gyro_heading = None
        self._anchors = 0
        self.raw_heading = 0.0        # integrated raw gyro, phi_g (relative)
        self.heading = None           # drift-corrected, anchored heading (absolute once a Kise fix exists)

    @property
    def drift(self):
        return self._drift.drift

    def on_gyro(self, rate, dt):
        """Integrate one yaw-gyro sample (clockwise rad/s): raw phi_g and corrected heading (omega + d) dT."""
        self.raw_heading += rate * dt
        if self.heading is not None:
            self.heading = wrap(self.heading + (rate + self.drift) * dt)
        return self.heading

    def on_fix(self, x, y, speed, gyro_heading, heading_at_epoch, dt):
        """Process one fix with the raw / corrected gyro headings at its epoch; returns the Kise heading or None."""
        bias = self.kise.update(x, y, speed, gyro_heading, dt)
        if bias is None:
            return None
        kise_heading = wrap(gyro_heading + bias)                                     # (4.3)
        if self._prev_gyro_heading is not None:
            mean_rate = (gyro_heading - self._prev_gyro_heading) / dt                # (4.17)
            self._drift.update(mean_rate, kise_heading, dt)                          # (4.13)-(4.16)
        self._prev_gyro_heading = gyro_heading
        if self.heading is None:
            self.heading = kise_heading
        else:
            self._anchors += 1
            gain = max(1.0 / self._anchors, self.settings.anchor_gain)
            self.heading = wrap(self.heading + gain * wrap(kise_heading - heading_at_epoch))
        return kise_heading
