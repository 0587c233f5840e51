"""A rate gyro's first-order response undone (agnav; SPEC §11.3-11.4: vibratory gyros are DC-7 or DC-10 Hz).

A gyro with a first-order low-pass of bandwidth f reads its rate τ = 1/(2πf) late: in a turn at 30°/s the heading
integrated from a 10 Hz gyro trails by 0.5°, and on a swaying body the roll and pitch trail by 2πfτ of the sway.
The response y' = (ω - y)/τ is inverted for a rate held over each sample: ω = y₀ + (y - y₀) / (1 - e^(-dt/τ)).
The bias passes unchanged; the white noise grows (2.4x at 100 Hz for 10 Hz) but its integral does not (the added
terms telescope), so the angles keep their noise and lose the lag. A gap (dt ≫ τ) passes the reading through.
"""
import math

from agnav_common.input_guard import finite


class GyroLag:
    """undo(t, rate) -> the rate before the gyro's first-order lag (bandwidth_hz <= 0: the reading unchanged)."""

    def __init__(self, bandwidth_hz=0.0):
        self.tau = 1.0 / (2.0 * math.pi * bandwidth_hz) if bandwidth_hz > 0 else 0.0
        self._last = None   # (t, reading) of the last finite sample

    def undo(self, t, rate):
        if self.tau <= 0.0:
            return rate
        last = self._last
        if not finite(t, rate) or (last is not None and t <= last[0]):
            return rate     # the input guard rejects it; it does not become the next sample's reference
        self._last = (t, rate)
        if last is None:
            return rate
        gain = 1.0 / -math.expm1(-(t - last[0]) / self.tau)
        return last[1] + gain * (rate - last[1])
