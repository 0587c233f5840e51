"""Steering actuator limits, speed-scheduled gains and an anti-windup integrator shared by every controller."""
import math
from dataclasses import dataclass


@dataclass
class SteeringLimits:
    """Front-wheel angle and slew limits (SPEC §11.9 [IMPL]: first-order actuator of a tractor)."""

    max_angle: float = math.radians(35.0)  # rad, largest front-wheel angle commanded either way
    max_rate: float = math.radians(40.0)   # rad/s, slew limit of the wheel angle; 0 disables it


class SteeringLimiter:
    """Saturates a desired wheel angle to +-max_angle and its change to max_rate*dt; remembers the last output."""

    def __init__(self, limits: SteeringLimits):
        self.limits = limits
        self.angle = 0.0
        self.saturated = False  # last output was clipped by angle or rate

    def reset(self, angle: float = 0.0):
        self.angle = angle
        self.saturated = False

    def __call__(self, desired: float, dt: float) -> float:
        lim = self.limits
        out = min(max(desired, -lim.max_angle), lim.max_angle)
        if lim.max_rate > 0.0 and dt > 0.0:
            step = lim.max_rate * dt
            out = min(max(out, self.angle - step), self.angle + step)
        self.saturated = out != desired
        self.angle = out
        return out


@dataclass
class SpeedSchedule:
    """Gain scale ref_speed/v, clamped for low speeds: keeps the time response of speed-proportional plants."""

    ref_speed: float = 1.0   # m/s at which the nominal gains apply
    min_speed: float = 0.3   # m/s below which the scale stops growing
    exponent: float = 1.0    # scale = (ref/v)^exponent

    def scale(self, speed: float) -> float:
        return (self.ref_speed / max(abs(speed), self.min_speed)) ** self.exponent


class Integrator:
    """Clamped integral with conditional integration (anti-windup): an update is undone while the output
    is saturated and the integrand pushes further into saturation."""

    def __init__(self, limit: float = math.inf):
        self.limit = limit
        self.value = 0.0
        self._previous = 0.0

    def reset(self):
        self.value = self._previous = 0.0

    def step(self, x: float, dt: float) -> float:
        self._previous = self.value
        self.value = min(max(self.value + x * dt, -self.limit), self.limit)
        return self.value

    def unwind_if(self, saturated: bool, pushes_further: bool):
        """Undo the last step when the actuator saturated in the direction the step pushed."""
        if saturated and pushes_further:
            self.value = self._previous
