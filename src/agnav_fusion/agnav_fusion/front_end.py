"""Navigation front end, input side: what every estimator needs once before a measurement reaches it.

`InputGuard` applies agnav_common.input_guard's rules per stream (imu, incl, gnss, vel, wheel): finite values,
stream time (bad, backwards and lone future stamps are rejected and never move the clock), GNSS fix and velocity
stamps against the IMU clock (which vouches for the receiver back after an outage), fix covariances (NaN/negative/
indefinite rejected; zero or implausibly small ones replaced by the receiver's last good covariance, or floored), a
stuck IMU (the same reading repeated bit for bit: dropped, so the estimator bridges it as a gap; every value passed
to accept counts: gyro and accelerometer together for an INS),
and counts every event in totals and over a recent window, so that diagnostics describe the present;
`on_problem(event)` (e.g. a node publishing its diagnostics at once, rate-limited by `Urgent`) sees every problem.
A stream's clock rules can be set per stream (`clocks`); `Overdue` tells when a periodic stream (GNSS fixes, the
IMU) has not arrived in time.
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

    def __init__(self, settings=None, clocks=None):
        """clocks: {stream: StreamClockSettings} replacing the defaults (e.g. a tighter IMU max_jump, a lag limit)."""
        self.settings = s = settings or InputGuardSettings()
        clock = StreamClockSettings(max_jump=s.max_stamp_jump)
        self.clocks = {k: StreamClock(clock) for k in STREAMS}
        receiver = StreamClockSettings(max_jump=s.max_stamp_jump, max_lead=s.gnss_max_lead, vouch=True)
        self.clocks["gnss"], self.clocks["vel"] = StreamClock(receiver), StreamClock(receiver)
        self.clocks.update({k: StreamClock(c) for k, c in (clocks or {}).items()})
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
        if stream == "imu":  # one flat list of floats: cheaper to check than arrays, and the stuck-sensor reading
            values = [x for v in values for x in (v.ravel() if isinstance(v, np.ndarray) else np.ravel(v)).tolist()]
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

    def _stuck(self, reading):
        """True from the stuck_samples-th bit-identical IMU reading (flat list) in a row (real sensors have noise)."""
        self._repeats = self._repeats + 1 if reading == self._last_imu else 0
        self._last_imu = reading
        return self._repeats >= self.settings.stuck_samples - 1

    def fix_covariance(self, cov, default=None):
        """A usable 3x3 fix covariance, or None (counted) when it cannot be believed at all. default: the covariance
        of an all-zero one (not given) while no good covariance of the receiver is known (counted, used)."""
        if default is not None and self._good_fix_cov is None and finite(cov) and not np.any(cov):
            self.count("gnss_zero_covariance")
            return np.array(default, dtype=float)
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

    def velocity_covariance(self, cov, floor_var, default_var):
        """A receiver velocity's 3x3 covariance: all zero (not given) -> default_var I, counted; NaN/negative/
        indefinite -> None, counted; variances below floor_var raised (counted)."""
        cov = np.asarray(cov, dtype=float).reshape(3, 3)
        if finite(cov) and not cov.any():
            self.count("vel_zero_covariance")
            return np.eye(3) * default_var
        checked, problem = covariance(cov, floor_var)
        if problem:
            self.count(f"vel_{problem}")
        return checked


class Overdue:
    """A periodic stream that is late: its period is learnt from the epochs of its messages (a running mean; a longer
    step counts as at most twice the period), and it is overdue once `periods` periods have passed since the last
    one arrived, on the caller's time base (e.g. the IMU time)."""

    def __init__(self, periods=1.5):
        self.periods = periods
        self.period = None
        self.last = None            # (epoch, arrival time) of the latest message
        self.overdue = False

    def arrived(self, epoch, now=None):
        """A message of epoch `epoch` arrived at time `now` (default: its epoch)."""
        now = epoch if now is None else max(now, epoch)
        if self.last is not None and epoch > self.last[0]:
            step = epoch - self.last[0]
            self.period = step if self.period is None else \
                self.period + 0.1 * (min(step, 2 * self.period) - self.period)
        self.last = (epoch, now)
        self.overdue = False

    def check(self, now):
        """True once per outage: when `now` is more than `periods` periods after the last arrival."""
        if self.period and not self.overdue and now - self.last[1] > self.periods * self.period:
            self.overdue = True
            return True
        return False


class Urgent:
    """Rate limit of diagnostics published at once on input problems: due(now) is True at most every `period` s
    (node time; a clock that went backwards, e.g. a restarted replay, re-arms it)."""

    def __init__(self, period=0.25):
        self.period = period
        self.last = -float("inf")

    def due(self, now):
        if now - self.last >= self.period or now < self.last:
            self.last = now
            return True
        return False
