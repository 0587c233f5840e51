"""Input guards every estimator and node applies once: measurement-time rules, value and covariance rules, and
windowed rejection counters for diagnostics that describe the present. Plain Python, no ROS.

Time rules (one `StreamClock` per input stream):
- a stamp that is not finite or not positive, or not after the stream's last accepted stamp, is rejected;
- a stamp more than `max_jump` s after the last accepted one is held as a candidate and rejected: it becomes the
  stream's time only when `confirm` further stamps follow it consistently (a sensor back after a real gap or a
  restarted clock); a lone future outlier is thus rejected and never moves the clock;
- optionally a stamp is checked against a reference time (e.g. the IMU clock for a GNSS fix): it may lag by up to
  `max_lag` s and lead by up to `max_lead` s; with `vouch` and a finite `max_lead` a stamp that passes this check is
  taken at once after a jump too (the reference vouches for it: a receiver back after an outage loses no fixes).
Covariance rules (`covariance`): NaN/Inf or negative variances, or a matrix that is not positive semi-definite
after symmetrisation, are rejected; variances below a floor (zero) are raised to it and reported as floored.
"""
import math
from collections import Counter, deque
from dataclasses import dataclass
from operator import itemgetter

import numpy as np


def finite(*values):
    """True when every value (scalars or arrays) is finite."""
    for v in values:
        if isinstance(v, (float, int)):
            if not math.isfinite(v):
                return False
        elif np.ndim(v) == 1 and len(v) <= 9:  # small vectors: per element beats a numpy round trip
            if not all(map(math.isfinite, v)):
                return False
        elif not np.all(np.isfinite(np.asarray(v, dtype=float))):
            return False
    return True


@dataclass
class StreamClockSettings:
    max_jump: float = 5.0     # s, a larger step forward is held until `confirm` stamps follow it
    confirm: int = 3          # consistent stamps after a jump that make it the stream's new time
    max_lag: float = math.inf   # s a stamp may lie behind the reference time
    max_lead: float = math.inf  # s a stamp may lie ahead of the reference time
    vouch: bool = False       # a jump within max_lead of the reference is taken at once (no confirmation)


class StreamClock:
    """Measurement-time guard of one stream; `check(t, ref=None)` returns None (accepted) or the reason."""

    def __init__(self, settings=None):
        self.settings = settings or StreamClockSettings()
        self.last = None
        self._candidate = []  # stamps after a jump, waiting for confirmation

    def check(self, t, ref=None):
        s = self.settings
        if not math.isfinite(t) or t <= 0.0:
            return "bad_stamp"
        if ref is not None and not (ref - s.max_lag <= t <= ref + s.max_lead):
            return "stamp_off_reference"
        if self.last is not None and t <= self.last:
            return "backwards_stamp"
        if self.last is None or t - self.last <= s.max_jump or (s.vouch and ref is not None and s.max_lead < math.inf):
            self.last = t
            self._candidate.clear()
            return None
        if self._candidate and not (self._candidate[-1] < t <= self._candidate[-1] + s.max_jump):
            self._candidate.clear()
        self._candidate.append(t)
        if len(self._candidate) > s.confirm:
            self.last = t
            self._candidate.clear()
            return None
        return "future_stamp"


def covariance(cov, floor_var=0.0):
    """(covariance, problem): a symmetric PSD copy of `cov` with every variance at least `floor_var`, and None,
    "floored" when a variance was raised; or (None, reason) for NaN/Inf, negative variances or an indefinite
    matrix."""
    c = np.array(cov, dtype=float)
    if c.shape == (3, 3):  # a fix or velocity covariance, once per GNSS epoch: on floats when plainly fine
        checked = _clearly_fine3(c.tolist(), floor_var)
        if checked is not None:
            return np.array(checked), None
    if not np.all(np.isfinite(c)):
        return None, "nan_covariance"
    c = (c + c.T) / 2 if c.ndim == 2 else np.diag(c)
    d = np.diag(c)
    if np.any(d < 0):
        return None, "negative_covariance"
    problem = None
    low = d < floor_var
    if np.any(low):
        c[np.diag_indices_from(c)] = np.maximum(d, floor_var)
        problem = "floored_covariance"
    if np.linalg.eigvalsh(c)[0] < -1e-9 * max(float(np.max(np.diag(c))), 1e-12):
        return None, "indefinite_covariance"
    return c, problem


def _clearly_fine3(c, floor_var):
    """(c + c^T) / 2 of 3x3 rows (numpy's arithmetic) when it is finite, no variance is below floor_var and it is
    positive definite by Sylvester's criterion with each minor above 1e-9 of its terms' magnitude (far beyond
    rounding, so covariance()'s eigenvalue test passes too); else None (covariance() decides)."""
    (a, b, d), (b2, e, f), (d2, f2, g) = c
    a, e, g, b, d, f = (a + a) / 2, (e + e) / 2, (g + g) / 2, (b + b2) / 2, (d + d2) / 2, (f + f2) / 2
    if not (math.isfinite(a + b + d + e + f + g) and min(a, e, g) >= floor_var and a > 0):
        return None
    m2 = a * e - b * b
    m3 = a * (e * g - f * f) - b * (b * g - f * d) + d * (b * f - e * d)
    size3 = a * (e * g + f * f) + abs(b) * (abs(b * g) + abs(f * d)) + abs(d) * (abs(b * f) + abs(e * d))
    if m2 > 1e-9 * (a * e + b * b) and m3 > 1e-9 * size3:
        return (a, b, d), (b, e, f), (d, f, g)
    return None


class EventWindow:
    """Counts of named events: totals, and those of the last `window` seconds of a caller-given time base."""

    def __init__(self, window=10.0):
        self.window = window
        self.totals = {}
        self._recent = deque()  # (time, name)

    def add(self, name, now):
        self.totals[name] = self.totals.get(name, 0) + 1
        self._recent.append((now, name))
        self._expire(now)

    def recent(self, now):
        """{name: count} of the events in (now - window, now]."""
        self._expire(now)
        return dict(Counter(map(itemgetter(1), self._recent)))  # counted in C; keys in order of first occurrence

    def _expire(self, now):
        while self._recent and (self._recent[0][0] <= now - self.window or self._recent[0][0] > now + self.window):
            self._recent.popleft()
