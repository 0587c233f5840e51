"""Attitude-package LSM: roll or pitch from a vibratory gyro and a lagging capacitive inclinometer
(SPEC §6.2, eq 5.1-5.11). One instance per axis; angles rad, rates rad/s, thesis sign conventions."""
import math
from collections import deque
from dataclasses import dataclass

from agnav_fusion.drift_lsm import WindowDriftLSM


@dataclass
class AttitudeLSMSettings:
    window: int = 270          # M samples: 270 roll / 200 pitch at 100 Hz (R5-13)
    delay: int = 110           # inclinometer lag Delta_i in samples (D5R tau ~1.1 s, SPEC §11.6) [IMPL]
    anchor_time: float = 20.0  # s, time constant pulling the angle to the lagged inclinometer [IMPL]; 0 = off


class AttitudeLSM:
    """Drift d_t by (5.11); angle theta(t) = theta(t-1) + (omega + d_t) dT [RECON], anchored to the inclinometer."""

    def __init__(self, settings=None):
        self.settings = settings or AttitudeLSMSettings()
        self._lsm = WindowDriftLSM(self.settings.window, self.settings.delay)
        self._history = deque(maxlen=self.settings.delay + 1)  # past angle estimates for the lagged residual
        self._resid = deque(maxlen=self.settings.window + 1)
        self._sums = [0.0, 0.0]  # running sum and sum of squares of _resid (its variance per sample in O(1))
        self._count = 0
        self.angle = None

    @property
    def drift(self):
        return self._lsm.drift

    def update(self, rate, incl, dt):
        """One sample of gyro rate (rad/s) and inclinometer angle (rad, or None: gyro only); returns the angle."""
        if incl is None:
            if self.angle is not None:
                self.angle += (rate + self._lsm.drift) * dt
            return self.angle
        drift = self._lsm.update(rate, incl, dt)
        angle = incl if self.angle is None else self.angle + (rate + drift) * dt
        history, resids, sums = self._history, self._resid, self._sums
        history.append(angle)
        # anchor: running mean at start-up (initial standstill), then a slow pull (IMPL)
        self._count += 1
        resid = incl - history[0]
        if len(resids) == resids.maxlen:
            old = resids[0]
            sums[0] -= old
            sums[1] -= old * old
        resids.append(resid)
        sums[0] += resid
        sums[1] += resid * resid
        if self._count % resids.maxlen == 0:  # re-sum now and then: no drift from the running updates
            sums[:] = math.fsum(resids), math.fsum(r * r for r in resids)
        gain = 1.0 / self._count
        anchor_time = self.settings.anchor_time
        if anchor_time > 0:
            gain = max(gain, dt / anchor_time)
        if anchor_time > 0 or not self._lsm.ready:
            angle += gain * resid
            history[-1] = angle
        self.angle = angle
        return angle

    @property
    def variance(self):
        """Window variance of the inclinometer-minus-estimate residual (conservative, rad^2)."""
        n = len(self._resid)
        if n < 2:
            return float("inf")
        mean = self._sums[0] / n
        return max(self._sums[1] / n - mean * mean, 0.0)
