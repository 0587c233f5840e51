"""Pure pursuit on a straight line with speed-scheduled look-ahead L = clip(L0 + k*v, Lmin, Lmax)."""
import math
from dataclasses import dataclass, field

from .guidance_line import TrackingError
from .limits import SteeringLimiter, SteeringLimits


@dataclass
class PurePursuitSettings:
    lookahead_base: float = 2.0       # m, L0 of the lookahead L = L0 + k v
    lookahead_per_speed: float = 1.5  # s, k of the lookahead L = L0 + k v
    lookahead_min: float = 2.0        # m, shortest lookahead
    lookahead_max: float = 15.0       # m, longest lookahead
    wheelbase: float = 2.9            # m, rear to front axle
    limits: SteeringLimits = field(default_factory=SteeringLimits)


class PurePursuit:
    """Goal point on the line L ahead of the rear axle; steer = atan(2 W sin(a) / L), a its bearing."""

    def __init__(self, settings: PurePursuitSettings | None = None):
        self.settings = settings or PurePursuitSettings()
        self.limiter = SteeringLimiter(self.settings.limits)

    def reset(self):
        self.limiter.reset()

    def lookahead(self, speed: float) -> float:
        s = self.settings
        return min(max(s.lookahead_base + s.lookahead_per_speed * abs(speed), s.lookahead_min), s.lookahead_max)

    def update(self, err: TrackingError, dt: float) -> float:
        s = self.settings
        lookahead = max(self.lookahead(err.speed), abs(err.cross_track) + 1e-3)
        ahead = math.sqrt(lookahead**2 - err.cross_track**2)
        bearing = math.atan2(-err.cross_track, ahead) - err.course_error  # goal point seen along the course
        return self.limiter(math.atan(2.0 * s.wheelbase * math.sin(bearing) / lookahead), dt)
