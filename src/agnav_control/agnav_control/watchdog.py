"""Engage state and fail-safe of the autosteer: disengage on stale, NaN, uncertain, slow or panic-braking
odometry; engage only on an explicit request; never re-engage by itself."""
import math
from collections import deque
from dataclasses import dataclass


@dataclass
class WatchdogSettings:
    stale_timeout: float = 0.15      # s without odometry -> disengage (neutral by 0.2 s with the timer)
    max_position_std: float = 0.3    # m, sqrt of the larger horizontal position variance
    max_yaw_std: float = 0.1         # rad
    min_speed: float = 0.2           # m/s
    panic_deceleration: float = 3.0  # m/s^2 over decel_window
    decel_window: float = 0.3        # s
    engage_position_std: float = 0.05  # m, stricter gates for an engage request: the fusion has converged
    engage_yaw_std: float = 0.01       # rad


@dataclass(frozen=True)
class Transition:
    time: float
    engaged: bool
    reason: str


@dataclass(frozen=True)
class OdometrySample:
    x: float
    y: float
    yaw: float
    speed: float
    position_var: float  # m^2, larger of the x/y variances
    yaw_var: float       # rad^2


class Watchdog:
    """Feed every odometry message to `odometry()` and call `check()` periodically (timer);
    `engaged` is the only state; each change is appended to `transitions` and passed to `on_transition`."""

    def __init__(self, settings: WatchdogSettings | None = None, on_transition=None):
        self.settings = settings or WatchdogSettings()
        self.on_transition = on_transition
        self.engaged = False
        self.fault = "no odometry yet"
        self.transitions: list[Transition] = []
        self._last_time = None
        self._last_sample = None
        self._speeds = deque()  # (t, speed) over decel_window

    def odometry(self, now: float, sample: OdometrySample) -> str | None:
        """Record a message received at `now` (s); returns the fault it shows, or None when healthy."""
        self.fault = self._assess(now, sample)
        self._last_sample = sample
        if self.fault is None or not self.fault.startswith("non-finite"):
            self._last_time = now
        self._disengage_on_fault(now)
        return self.fault

    def check(self, now: float) -> str | None:
        """Timer tick: detect stale odometry without new messages."""
        if self._last_time is None:
            self.fault = "no odometry yet"
        elif now - self._last_time > self.settings.stale_timeout:
            self.fault = f"odometry stale for {now - self._last_time:.3f} s"
        self._disengage_on_fault(now)
        return self.fault

    def request_engage(self, now: float) -> tuple[bool, str]:
        """Explicit engage request: accepted only while healthy."""
        self.check(now)
        if self.fault is not None:
            return False, f"refused: {self.fault}"
        s, m = self.settings, self._last_sample
        if not self.engaged and (m.position_var > s.engage_position_std**2 or m.yaw_var > s.engage_yaw_std**2):
            return False, (f"refused: not converged (position std {math.sqrt(m.position_var):.3f} m, "
                           f"yaw std {math.sqrt(m.yaw_var):.4f} rad)")
        if not self.engaged:
            self._set(now, True, "engage requested")
        return True, "engaged"

    def disengage(self, now: float, reason: str = "disengage requested"):
        if self.engaged:
            self._set(now, False, reason)

    def _assess(self, now: float, m: OdometrySample) -> str | None:
        s = self.settings
        values = (m.x, m.y, m.yaw, m.speed, m.position_var, m.yaw_var)
        if not all(math.isfinite(v) for v in values):
            self._speeds.clear()
            return "non-finite odometry"
        self._speeds.append((now, m.speed))
        while now - self._speeds[0][0] > s.decel_window:
            self._speeds.popleft()
        t0, v0 = self._speeds[0]
        if now - t0 > 0.5 * s.decel_window and (v0 - m.speed) / (now - t0) > s.panic_deceleration:
            return f"panic deceleration {(v0 - m.speed) / (now - t0):.1f} m/s^2"
        if m.position_var > s.max_position_std**2 or m.position_var < 0.0:
            return f"position std {math.sqrt(abs(m.position_var)):.3f} m above {s.max_position_std} m"
        if m.yaw_var > s.max_yaw_std**2 or m.yaw_var < 0.0:
            return f"yaw std {math.sqrt(abs(m.yaw_var)):.3f} rad above {s.max_yaw_std} rad"
        if abs(m.speed) < s.min_speed:
            return f"speed {abs(m.speed):.2f} m/s below {s.min_speed} m/s"
        return None

    def _disengage_on_fault(self, now: float):
        if self.engaged and self.fault is not None:
            self._set(now, False, self.fault)

    def _set(self, now: float, engaged: bool, reason: str):
        self.engaged = engaged
        transition = Transition(now, engaged, reason)
        self.transitions.append(transition)
        if self.on_transition is not None:
            self.on_transition(transition)
