"""Engage state and fail-safe of the autosteer: disengage on stale (no message, or an old stamp), NaN, invalid
covariance, uncertain, slow or panic-braking odometry; engage only on an explicit request; never re-engage by
itself.

Gates per receiver class (the last /gnss/status fix type), as commercial autosteer activates on the correction
class it is set up for (AutoTrac: "can be activated when SF1/SF2 is confirmed; accuracy may continue to increase"):
RTK fixed or unknown -> the top-level gates; DGPS and RTK float -> `dgps`, sized for an honest decimetre-class
covariance (NMEA: HDOP x 1 m) and the heading σ a crabbing DGPS tractor reaches. The line following needs the
relative accuracy, which the absolute σ of DGPS does not describe; stale, NaN, invalid or divergent covariance
(beyond the class' max) still disengages."""
import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from agnav_common.input_guard import covariance, finite

POSE_BLOCK = (0, 1, 5)  # x, y, yaw rows/columns of the 6x6 pose covariance the watchdog uses
FIX_DGPS, FIX_RTK_FLOAT = 2, 3  # agnav_msgs/GnssStatus fix types that select the `dgps` gates


@dataclass
class ReceiverGates:
    """Gates of a decimetre-class receiver (DGPS / SBAS / RTK float)."""

    engage_position_std: float = 1.0  # m, engage gate on the position std
    engage_yaw_std: float = 0.035      # rad, engage gate on the yaw std (2 deg: a 1.5 deg crab is not yet observed)
    max_position_std: float = 1.5      # m, fail-safe: a larger position std disengages


@dataclass
class WatchdogSettings:
    stale_timeout: float = 0.15      # s without odometry -> disengage (neutral by 0.2 s with the timer)
    max_position_std: float = 0.3    # m, sqrt of the larger horizontal position variance
    max_yaw_std: float = 0.1         # rad, sqrt of the yaw variance
    min_speed: float = 0.2           # m/s, slower odometry disengages (no steering at standstill)
    panic_deceleration: float = 3.0  # m/s^2 over decel_window
    decel_window: float = 0.3        # s over which the deceleration is measured
    engage_position_std: float = 0.05  # m, stricter gates for an engage request: the fusion has converged
    engage_yaw_std: float = 0.01       # rad, stricter yaw gate for an engage request
    max_stamp_age: float = 0.3         # s the last odometry stamp may lie behind the reference time (the node
    # clock: sim time under use_sim_time); checked on every message, timer tick and engage request
    dgps: ReceiverGates = field(default_factory=ReceiverGates)  # gates while /gnss/status says DGPS or RTK float


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
    stamp: float | None = None  # s, measurement epoch; None: the stamp age is not checked
    lateral_speed: float = 0.0  # m/s, base_link twist linear.y (side slip: crab = atan(lateral / speed))


def odometry_sample(x, y, yaw, speed, pose_cov, twist_cov, stamp=None, lateral_speed=0.0):
    """(OdometrySample, None) from nav_msgs/Odometry fields (36-element covariances), or (None, reason) when the
    covariance used (pose x, y, yaw block; twist vx variance) has NaN/Inf, negative variances or is indefinite."""
    pose, problem = covariance(np.asarray(pose_cov, dtype=float).reshape(6, 6)[np.ix_(POSE_BLOCK, POSE_BLOCK)])
    if pose is None:
        return None, f"pose {problem.replace('_', ' ')}"
    twist, problem = covariance([twist_cov[0]])
    if twist is None:
        return None, f"twist {problem.replace('_', ' ')}"
    return OdometrySample(x, y, yaw, speed, float(max(pose[0, 0], pose[1, 1])), float(pose[2, 2]), stamp,
                          lateral_speed), None


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
        self.fix_type = None    # last /gnss/status fix type; None: unknown (top-level gates)

    def gates(self) -> tuple[float, float, float]:
        """(engage position std m, engage yaw std rad, max position std m) of the current receiver class."""
        s = self.settings
        if self.fix_type in (FIX_DGPS, FIX_RTK_FLOAT):
            return s.dgps.engage_position_std, s.dgps.engage_yaw_std, s.dgps.max_position_std
        return s.engage_position_std, s.engage_yaw_std, s.max_position_std

    def odometry(self, now: float, sample: OdometrySample, ref: float | None = None) -> str | None:
        """Record a message received at `now` (s), its stamp judged against the reference time `ref` (s, None:
        unknown); returns the fault it shows, or None when healthy."""
        if not finite(sample.x, sample.y, sample.yaw, sample.speed, sample.position_var, sample.yaw_var,
                      sample.lateral_speed):
            return self.reject(now, "non-finite odometry")
        health = self._assess(now, sample)
        self._last_sample, self._last_time = sample, now
        self.fault = self._age_fault(ref) or health
        self._disengage_on_fault(now)
        return self.fault

    def reject(self, now: float, reason: str) -> str:
        """An invalid odometry message: a fault that does not refresh the stream (a stream of them goes stale)."""
        self._speeds.clear()
        self.fault = reason
        self._disengage_on_fault(now)
        return reason

    def check(self, now: float, ref: float | None = None) -> str | None:
        """Timer tick: detect odometry that stopped (receive time `now`) or whose stamp grew old (time `ref`)."""
        if self._last_time is None:
            self.fault = "no odometry yet"
        elif now - self._last_time > self.settings.stale_timeout:
            self.fault = f"odometry stale for {now - self._last_time:.3f} s"
        else:
            self.fault = self._age_fault(ref) or self.fault
        self._disengage_on_fault(now)
        return self.fault

    def stamp_age(self, ref: float | None) -> float | None:
        """Age (s) of the last odometry stamp at reference time `ref`; None when either is unknown."""
        stamp = self._last_sample.stamp if self._last_sample is not None else None
        return None if stamp is None or ref is None else ref - stamp

    def request_engage(self, now: float, ref: float | None = None) -> tuple[bool, str]:
        """Explicit engage request: accepted only while healthy."""
        self.check(now, ref)
        if self.fault is not None:
            return False, f"refused: {self.fault}"
        m = self._last_sample
        position_std, yaw_std, _ = self.gates()
        if not self.engaged and (m.position_var > position_std**2 or m.yaw_var > yaw_std**2):
            return False, (f"refused: not converged (position std {math.sqrt(m.position_var):.3f} m, "
                           f"yaw std {math.sqrt(m.yaw_var):.4f} rad)")
        if not self.engaged:
            self._set(now, True, "engage requested")
        return True, "engaged"

    def disengage(self, now: float, reason: str = "disengage requested"):
        if self.engaged:
            self._set(now, False, reason)

    def _age_fault(self, ref: float | None) -> str | None:
        if self._last_sample is None or self._last_sample.stamp is None:
            return None
        age = self.stamp_age(ref)
        if age is None:
            return "no clock to check the odometry stamp age against"
        if age > self.settings.max_stamp_age:
            return f"odometry stamp {age:.3f} s old (max {self.settings.max_stamp_age} s)"
        return None

    def _assess(self, now: float, m: OdometrySample) -> str | None:
        s = self.settings
        self._speeds.append((now, m.speed))
        while now - self._speeds[0][0] > s.decel_window:
            self._speeds.popleft()
        t0, v0 = self._speeds[0]
        if now - t0 > 0.5 * s.decel_window and (v0 - m.speed) / (now - t0) > s.panic_deceleration:
            return f"panic deceleration {(v0 - m.speed) / (now - t0):.1f} m/s^2"
        max_position_std = self.gates()[2]
        if m.position_var > max_position_std**2 or m.position_var < 0.0:
            return f"position std {math.sqrt(abs(m.position_var)):.3f} m above {max_position_std} m"
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
