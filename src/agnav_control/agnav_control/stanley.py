"""Stanley lateral controller (Hoffmann et al. 2007) on the front-axle cross-track error."""
import math
from dataclasses import dataclass, field

from .guidance_line import TrackingError
from .limits import SteeringLimiter, SteeringLimits


@dataclass
class StanleySettings:
    gain: float = 1.0        # 1/s, k in atan(k e / v)
    soft_speed: float = 0.5  # m/s added to v so the law stays bounded at low speed
    heading_gain: float = 1.0  # rad/rad on the heading error
    wheelbase: float = 2.9   # m, base_link (rear axle) to front axle
    limits: SteeringLimits = field(default_factory=SteeringLimits)


class Stanley:
    """steer = -(kh*h + atan(k*e_f / (v_soft + v))), e_f = e + wheelbase*sin(h) at the front axle."""

    def __init__(self, settings: StanleySettings | None = None):
        self.settings = settings or StanleySettings()
        self.limiter = SteeringLimiter(self.settings.limits)

    def reset(self):
        self.limiter.reset()

    def update(self, err: TrackingError, dt: float) -> float:
        s = self.settings
        h = err.course_error
        e_front = err.cross_track + s.wheelbase * math.sin(h)
        desired = -(s.heading_gain * h + math.atan2(s.gain * e_front, s.soft_speed + abs(err.speed)))
        return self.limiter(desired, dt)
