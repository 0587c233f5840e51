"""PID steering on cross-track and heading error, as with RTK-GPS + FOG in thesis ch. IV (SPEC §5.3, 5 Hz)."""
import math
from dataclasses import dataclass, field

from .guidance_line import TrackingError
from .limits import Integrator, SpeedSchedule, SteeringLimiter, SteeringLimits


@dataclass
class PIDSettings:
    kp: float = 0.35       # rad/m on cross-track
    ki: float = 0.02       # rad/(m s) on integrated cross-track
    kd: float = 0.0        # rad/(m/s) on the cross-track rate v*sin(heading_error)
    kh: float = 2.0        # rad/rad on heading error (damping ~0.85 at 4.3 m/s on the MX240)
    integral_limit: float = 10.0  # m s, clamp of the cross-track integral (ki x 10 = 0.2 rad: a crab of 5 deg unseen
    # by the feed-forward costs kh x 5 deg = 0.17 rad that the integral must hold)
    integral_band: float = 0.25  # m, integrate only this close to the line (no wind-up while converging)
    schedule: SpeedSchedule = field(default_factory=lambda: SpeedSchedule(ref_speed=1.0, exponent=0.5))
    limits: SteeringLimits = field(default_factory=SteeringLimits)


class PID:
    """steer = -g(v) * (kp e + ki int(e) + kd v sin(h) + kh h); g(v) the speed schedule, clamped anti-windup."""

    def __init__(self, settings: PIDSettings | None = None):
        self.settings = settings or PIDSettings()
        self.limiter = SteeringLimiter(self.settings.limits)
        self.integral = Integrator(self.settings.integral_limit)

    def reset(self):
        self.integral.reset()
        self.limiter.reset()

    def update(self, err: TrackingError, dt: float) -> float:
        s = self.settings
        e, h = err.cross_track, err.course_error
        g = s.schedule.scale(err.speed)
        self.integral.step(e if abs(e) < s.integral_band else 0.0, dt)
        desired = -g * (s.kp * e + s.ki * self.integral.value + s.kd * err.speed * math.sin(h) + s.kh * h)
        out = self.limiter(desired, dt)
        # a positive e integrand drives the command negative: it pushes further when clipped from below
        self.integral.unwind_if(self.limiter.saturated, (out - desired) * e * s.ki > 0.0)
        return out
