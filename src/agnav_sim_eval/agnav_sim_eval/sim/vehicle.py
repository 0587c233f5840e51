"""Kinematic bicycle model with a first-order, rate-limited steering actuator (SPEC §11.9 [IMPL])."""
import math
from dataclasses import dataclass


@dataclass(frozen=True)
class VehicleParams:
    """Tractor geometry and actuator limits; base_link is the rear-axle centre on the ground."""

    wheelbase_m: float = 1.8
    track_m: float = 1.4
    max_steer_rad: float = math.radians(35.0)
    steer_rate_rad_s: float = math.radians(30.0)
    steer_tau_s: float = 0.2
    max_accel_mps2: float = 0.4


@dataclass
class BicycleState:
    """Planar state: position (m, map ENU), yaw (rad, ENU), speed (m/s), front-wheel angle (rad, + left)."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    speed: float = 0.0
    steer: float = 0.0


class BicycleModel:
    """Rear-axle kinematic bicycle: x' = v cos ψ, y' = v sin ψ, ψ' = v tan δ / L."""

    def __init__(self, params: VehicleParams, state: BicycleState):
        self.params = params
        self.state = state

    def step(self, dt, steer_cmd, speed_cmd, crab=0.0):
        """Advance dt seconds toward the commanded front-wheel angle (rad) and speed (m/s); crab: side-slip angle
        (rad, + left) between the velocity and the heading."""
        p, s = self.params, self.state
        target = max(-p.max_steer_rad, min(p.max_steer_rad, steer_cmd))
        rate = (target - s.steer) / max(p.steer_tau_s, dt)
        rate = max(-p.steer_rate_rad_s, min(p.steer_rate_rad_s, rate))
        s.steer += rate * dt
        dv = max(-p.max_accel_mps2 * dt, min(p.max_accel_mps2 * dt, speed_cmd - s.speed))
        v0, s.speed = s.speed, max(0.0, s.speed + dv)
        v = 0.5 * (v0 + s.speed)
        yaw_rate = v * math.tan(s.steer) / p.wheelbase_m
        mid_yaw = s.yaw + 0.5 * yaw_rate * dt
        s.x += v * math.cos(mid_yaw + crab) * dt
        s.y += v * math.sin(mid_yaw + crab) * dt
        s.yaw = math.remainder(s.yaw + yaw_rate * dt, 2.0 * math.pi)
        return v * dt
