"""Navigation front end, input side: what every estimator needs once before a measurement reaches it.

`InputGuard` applies agnav_common.input_guard's rules per stream (imu, incl, gnss, vel, wheel): finite values,
stream time (bad, backwards and lone future stamps are rejected and never move the clock), GNSS stamps against the
IMU clock, fix covariances (NaN/negative/indefinite rejected; zero or implausibly small ones replaced by the
receiver's last good covariance, or floored), a stuck IMU (the same reading repeated bit for bit: dropped, so the
estimator bridges it as a gap), and counts every event in totals and over a recent window, so that diagnostics
describe the present; `on_problem(event)` (e.g. a node publishing its diagnostics at once) sees every problem.
"""
from dataclasses import dataclass

import numpy as np
from agnav_common.input_guard import EventWindow, StreamClock, StreamClockSettings, covariance, finite

STREAMS = ("imu", "incl", "gnss", "vel", "wheel")
NORMAL = ("imu", "gnss", "wheel")  # events that count accepted inputs, not problems


@dataclass
class InputGuardSettings:
    max_stamp_jump: float = 5.0     # s, a larger forward step of a stream's stamps needs 3 more stamps to be believed
    gnss_max_lead: float = 1.0      # s a GNSS stamp may lie ahead of the IMU clock
    min_fix_sigma: float = 0.005    # m, a smaller fix sigma is not believed (last good covariance, else this floor)
    diagnostic_window: float = 10.0  # s over which rejections are reported
    stuck_samples: int = 10         # identical consecutive IMU readings that mark a stuck sensor (dropped from there;
    #                                 0: off, e.g. for a coarsely quantized gyro that repeats its reading at rest)


class InputGuard:
    """accept(stream, t, *values, ref=None) -> bool; fix_covariance(cov) -> 3x3 or None; totals and recent()."""

    def __init__(self, settings=None):
        self.settings = s = settings or InputGuardSettings()
        clock = StreamClockSettings(max_jump=s.max_stamp_jump)
        self.clocks = {k: StreamClock(clock) for k in STREAMS}
        self.clocks["gnss"] = StreamClock(StreamClockSettings(max_jump=s.max_stamp_jump, max_lead=s.gnss_max_lead))
        self.totals = {}
        self.events = EventWindow(s.diagnostic_window)
        self.now = 0.0            # latest accepted IMU time: the time base of the recent window
        self.on_problem = None
        self._good_fix_cov = None
        self._last_imu, self._repeats = None, 0

    def count(self, name):
        self.totals[name] = self.totals.get(name, 0) + 1
        self.events.add(name, self.now)
        if self.on_problem and name not in NORMAL:
            self.on_problem(name)

    def recent(self):
        """{event: count} over the last diagnostic_window s of IMU time."""
        return self.events.recent(self.now)

    def accept(self, stream, t, *values, ref=None):
        """True when the values are finite and the stamp passes the stream's time rules; else counted as
        {stream}_bad_value or {stream}_{reason}."""
        if not finite(*values):
            self.count(f"{stream}_bad_value")
            return False
        if stream == "imu" and self.settings.stuck_samples and self._stuck(values):
            self.count("imu_stuck")
            return False
        reason = self.clocks[stream].check(t, ref)
        if reason is not None:
            self.count(f"{stream}_{reason}")
            return False
        if stream == "imu":
            self.now = t
        return True

    def _stuck(self, values):
        """True from the stuck_samples-th bit-identical IMU reading in a row (real sensors have noise)."""
        same = self._last_imu is not None and all(np.array_equal(a, b) for a, b in zip(values, self._last_imu))
        self._repeats = self._repeats + 1 if same else 0
        self._last_imu = [np.array(v, dtype=float) for v in values]
        return self._repeats >= self.settings.stuck_samples - 1

    def fix_covariance(self, cov):
        """A usable 3x3 fix covariance, or None (counted) when it cannot be believed at all."""
        c, problem = covariance(cov)
        if c is None:
            self.count(f"gnss_{problem}")
            return None
        if np.min(np.diag(c)[:2]) < self.settings.min_fix_sigma ** 2:
            self.count("gnss_floored_covariance")
            if self._good_fix_cov is not None:
                return self._good_fix_cov.copy()
            c[np.diag_indices_from(c)] = np.maximum(np.diag(c), self.settings.min_fix_sigma ** 2)
            return c
        self._good_fix_cov = c
        return c

    def velocity_variance(self, var, floor):
        """Per-axis variance of a receiver velocity: None (counted) when not finite or negative, else >= floor."""
        if var is None:
            return floor
        if not finite(var) or var < 0:
            self.count("vel_bad_covariance")
            return None
        if var == 0:
            self.count("vel_zero_covariance")
        return max(float(var), floor)
