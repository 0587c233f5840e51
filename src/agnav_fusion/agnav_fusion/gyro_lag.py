"""A rate gyro's first-order response undone (agnav; SPEC §11.3-11.4: vibratory gyros are DC-7 or DC-10 Hz).

A gyro with a first-order low-pass of bandwidth f reads its rate τ = 1/(2πf) late: in a turn at 30°/s the heading
integrated from a 10 Hz gyro trails by 0.5°, and on a body swaying at f_s the roll and pitch trail by 2π f_s τ of
the sway. The response y' = (ω - y)/τ is inverted for a rate held over each sample:
ω = y₀ + (y - y₀) / (1 - e^(-dt/τ)). The bias passes unchanged; the white noise grows (2.4x at 100 Hz for 10 Hz)
but its integral does not (the added terms telescope), so the angles keep their noise and lose the lag.
A stamp that does not advance or jumps beyond MAX_GAP time constants (a gap, or one the input guard refuses)
passes as read and restarts from that sample; a step shorter than half the usual period (stamps taken on arrival,
bunched) counts as half the period, so the gain stays bounded.
"""
import math

from agnav_common.input_guard import finite

MAX_GAP = 10.0   # time constants: a longer step is a gap (the lag has settled: the reading is the rate)


class GyroLag:
    """undo(t, rate) -> the rate before the gyro's first-order lag (bandwidth_hz <= 0: the reading unchanged)."""

    def __init__(self, bandwidth_hz=0.0):
        self.tau = 1.0 / (2.0 * math.pi * bandwidth_hz) if bandwidth_hz > 0 else 0.0
        self._last = None    # (t, reading) of the last finite sample
        self.period = None   # s, running mean of the sample steps

    def undo(self, t, rate):
        if self.tau <= 0.0 or not finite(t, rate):
            return rate      # (a bad value is the input guard's to count; it never becomes the reference)
        last, self._last = self._last, (t, rate)
        dt = t - last[0] if last is not None else 0.0
        if not 0.0 < dt <= MAX_GAP * self.tau:
            return rate
        step, self.period = (dt, dt) if self.period is None else (max(dt, 0.5 * self.period),
                                                                  self.period + 0.05 * (dt - self.period))
        return last[1] + (rate - last[1]) / -math.expm1(-step / self.tau)
