"""Sliding-window least-squares gyro drift against a reference angle (SPEC eq 3.18, 4.16, 5.11).

d_t = (sum omega_ref(i) - sum omega_gyro(i - delay)) / (M + 1) over i = t-M..t, evaluated in O(1) with
the telescoped form (SPEC §4.5 / §6.2 [DERIVED]): reference-angle change over the window minus the
gyro-integrated change over the delayed window, divided by the window duration.
"""
import math
from collections import deque


def wrap(a):
    """Wrap an angle to [-pi, pi]."""
    return math.remainder(a, 2.0 * math.pi)


class WindowDriftLSM:
    """Constant-drift LSM over the last M+1 samples with the gyro delayed by `delay` samples (5.11)."""

    def __init__(self, window, delay=0, circular=False):
        self.window = int(window)
        self.circular = circular
        self._ref = deque(maxlen=self.window + 2)      # reference angles phi(t-M-1..t), unwrapped
        self._lag = deque(maxlen=int(delay) + 1)        # gyro increments omega*dt awaiting the delay
        self._win = deque(maxlen=self.window + 1)       # delayed (increment, dt) pairs in the window
        self._inc_sum = 0.0
        self._dt_sum = 0.0
        self.drift = 0.0
        self.ready = False  # both windows full (they stay full)

    def update(self, rate, ref_angle, dt):
        """Add one sample (gyro rate, reference angle, dt); returns the drift d_t (rate units), 0 until ready."""
        ref, lag, win = self._ref, self._lag, self._win
        if self.circular and ref:
            ref_angle = ref[-1] + wrap(ref_angle - ref[-1])
        ref.append(ref_angle)
        lag.append(rate * dt)
        if len(lag) == lag.maxlen:
            if len(win) == win.maxlen:
                old_inc, old_dt = win[0]
                self._inc_sum -= old_inc
                self._dt_sum -= old_dt
            inc = lag[0]
            win.append((inc, dt))
            self._inc_sum += inc
            self._dt_sum += dt
        if not self.ready:
            self.ready = len(ref) == ref.maxlen and len(win) == win.maxlen
        if self.ready:
            self.drift = (ref[-1] - ref[0] - self._inc_sum) / self._dt_sum
        return self.drift
