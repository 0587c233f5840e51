"""Thesis straight-line steering law psi = alpha*dphi + beta*eps (SPEC §3.4, eq 2.6-2.7), signs converted at the edge (SPEC §2.3)."""
import math
from dataclasses import dataclass, field

from .guidance_line import TrackingError
from .limits import SteeringLimiter, SteeringLimits


@dataclass
class ThesisPISettings:
    alpha: float = 1.0   # rad/rad, steer per heading deviation
    beta: float = 0.18   # rad/m, steer per lateral deviation
    cross_track: str = "measured"  # 'measured' (position fix) or 'dead_reckoning' (2.7: eps = sum v dt sin dphi)
    fixed_speed: float = 0.0       # m/s used in (2.7) when > 0 (thesis VWA runs: 0.5)
    limits: SteeringLimits = field(default_factory=SteeringLimits)


class ThesisPI:
    """(2.6) psi(k) = alpha*dphi(k) + beta*eps(k); the thesis calls it PI since eps (2.7) integrates dphi.
    Thesis dphi (clockwise +) = -heading_error and eps (right +) = -cross_track, so + psi = left turn."""

    def __init__(self, settings: ThesisPISettings | None = None):
        self.settings = settings or ThesisPISettings()
        if self.settings.cross_track not in ("measured", "dead_reckoning"):
            raise ValueError(f"cross_track must be 'measured' or 'dead_reckoning', not {self.settings.cross_track!r}")
        self.limiter = SteeringLimiter(self.settings.limits)
        self.eps = 0.0

    def reset(self):
        self.eps = 0.0
        self.limiter.reset()

    def update(self, err: TrackingError, dt: float) -> float:
        s = self.settings
        dphi = -err.course_error
        if s.cross_track == "measured":
            self.eps = -err.cross_track
        else:
            v = s.fixed_speed if s.fixed_speed > 0.0 else err.speed
            self.eps += v * dt * math.sin(dphi)  # (2.7)
        return self.limiter(s.alpha * dphi + s.beta * self.eps, dt)
