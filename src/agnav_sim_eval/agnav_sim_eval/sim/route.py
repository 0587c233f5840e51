"""Scenario routes (polylines in map ENU) and the driver that follows them: pure pursuit + speed profile."""
import math
from dataclasses import dataclass

import numpy as np


def straight(length_m, yaw=math.pi / 2, step_m=0.25):
    """Straight polyline from the origin along yaw (default north)."""
    s = np.arange(0.0, length_m + step_m / 2, step_m)
    return np.stack([s * math.cos(yaw), s * math.sin(yaw)], axis=1)


def rounded_loop(length_m, width_m, radius_m, overlap_m=0.0, step_m=0.25):
    """Counter-clockwise rounded rectangle starting at the origin heading east, plus overlap_m of a second lap."""
    a, b, r = length_m - 2 * radius_m, width_m - 2 * radius_m, radius_m
    segments = [("line", a), ("arc", math.pi / 2), ("line", b), ("arc", math.pi / 2),
                ("line", a), ("arc", math.pi / 2), ("line", b), ("arc", math.pi / 2), ("line", overlap_m)]
    pts, p, yaw = [np.zeros(2)], np.zeros(2), 0.0
    for kind, amount in segments:
        n = max(1, int(round((amount if kind == "line" else amount * r) / step_m)))
        for _ in range(n):
            if kind == "line":
                p = p + (amount / n) * np.array([math.cos(yaw), math.sin(yaw)])
            else:
                dyaw = amount / n
                chord = 2 * r * math.sin(dyaw / 2)
                p = p + chord * np.array([math.cos(yaw + dyaw / 2), math.sin(yaw + dyaw / 2)])
                yaw += dyaw
            pts.append(p)
    return np.array(pts)


@dataclass(frozen=True)
class DriverParams:
    """Pure-pursuit driver with speed profile; weave_deg adds a human-like steering wander (OU process)."""

    speed_mps: float = 0.8
    accel_mps2: float = 0.3
    start_standstill_s: float = 10.0
    end_standstill_s: float = 5.0
    lookahead_s: float = 2.5
    min_lookahead_m: float = 2.0
    weave_deg: float = 0.0
    weave_tau_s: float = 3.0


class RouteDriver:
    """Steers along the polyline and sets the speed: standstill, ramp up, cruise, brake to stop at the end."""

    def __init__(self, route, params: DriverParams, wheelbase_m, rng: np.random.Generator):
        self.route = np.asarray(route, dtype=float)
        seg = np.linalg.norm(np.diff(self.route, axis=0), axis=1)
        self.s_route = np.concatenate([[0.0], np.cumsum(seg)])
        self.length = float(self.s_route[-1])
        self.params = params
        self.wheelbase = wheelbase_m
        self._rng = rng
        self._idx = 0
        self._weave = 0.0

    @property
    def initial_yaw(self):
        """Yaw of the first route segment."""
        d = self.route[1] - self.route[0]
        return math.atan2(d[1], d[0])

    def speed_command(self, t, travelled_m):
        """Speed set-point (m/s): trapezoid in time at the start, braking on the remaining distance."""
        p = self.params
        if t < p.start_standstill_s:
            return 0.0
        remaining = max(0.0, self.length - travelled_m)
        v = min(p.speed_mps, p.accel_mps2 * (t - p.start_standstill_s) + 0.05,
                math.sqrt(2 * p.accel_mps2 * remaining))
        return v if remaining > 0.02 else 0.0

    def steering_command(self, x, y, yaw, speed, dt):
        """Front-wheel angle (rad, + left) toward the look-ahead point on the route."""
        p = self.params
        window = slice(self._idx, min(len(self.route), self._idx + 200))
        d = np.linalg.norm(self.route[window] - (x, y), axis=1)
        self._idx += int(np.argmin(d))
        ld = max(p.min_lookahead_m, p.lookahead_s * speed)
        j = int(np.searchsorted(self.s_route, self.s_route[self._idx] + ld))
        if j >= len(self.route):  # extend the last segment beyond the end
            end, prev = self.route[-1], self.route[-2]
            u = (end - prev) / np.linalg.norm(end - prev)
            target = end + u * (self.s_route[self._idx] + ld - self.length)
        else:
            target = self.route[j]
        dx, dy = target[0] - x, target[1] - y
        alpha = math.atan2(dy, dx) - yaw
        steer = math.atan2(2 * self.wheelbase * math.sin(alpha), math.hypot(dx, dy))
        if p.weave_deg:
            a = math.exp(-dt / p.weave_tau_s)
            self._weave = a * self._weave + math.sqrt(1 - a * a) * math.radians(p.weave_deg) * self._rng.normal()
        return steer + self._weave
