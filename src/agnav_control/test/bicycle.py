"""Minimal kinematic bicycle with a first-order steering actuator, for controller tests only."""
import math


class Bicycle:
    def __init__(self, x=0.0, y=0.0, yaw=0.0, speed=1.0, wheelbase=2.9, steer_tau=0.15, crab=0.0):
        self.x, self.y, self.yaw, self.speed, self.crab = x, y, yaw, speed, crab  # crab: course - yaw (rad)
        self.wheelbase, self.steer_tau, self.steer = wheelbase, steer_tau, 0.0

    def step(self, command, dt):
        self.steer += (command - self.steer) * min(1.0, dt / self.steer_tau)
        self.x += self.speed * math.cos(self.yaw + self.crab) * dt
        self.y += self.speed * math.sin(self.yaw + self.crab) * dt
        self.yaw += self.speed / self.wheelbase * math.tan(self.steer) * dt


def drive(controller, line, vehicle, duration, dt=0.05, crab_known=False):
    """Close the loop on true pose (and the true crab if crab_known); returns the cross-track history (m)."""
    history = []
    for _ in range(int(round(duration / dt))):
        err = line.error(vehicle.x, vehicle.y, vehicle.yaw, vehicle.speed, crab=vehicle.crab if crab_known else 0.0)
        history.append(err.cross_track)
        vehicle.step(controller.update(err, dt), dt)
    return history
