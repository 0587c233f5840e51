"""Continuous odom (REP-105) for any estimator, ROS-free: base_link in `odom` is dead-reckoned from the estimate's
own speed and yaw rate and never corrected, so it never jumps; the corrections that GNSS fixes make to the map pose
go into map->odom. At the start (and when time goes backwards: a new replay) odom coincides with map."""
import math

from agnav_common.frames import quaternion_from_euler


class OdomFrame:
    """update(t, position, rpy, speed, yaw_rate) -> (odom->base xyz, xyzw, map->odom xyz, xyzw), tuples (no arrays
    per sample: the transforms take floats)."""

    def __init__(self):
        self.t = None
        self.xyz = None  # (x, y, z) floats: Python arithmetic on scalars, the same bits as numpy's
        self.yaw = 0.0

    def update(self, t, position, rpy, speed, yaw_rate):
        roll, pitch, yaw = (float(v) for v in rpy)
        if self.t is None or t < self.t:
            self.xyz, self.yaw = tuple(float(v) for v in position), yaw
        else:
            dt = t - self.t
            self.yaw = math.remainder(self.yaw + yaw_rate * dt, 2 * math.pi)
            cp, step = math.cos(pitch), float(speed * dt)  # REP-103: positive pitch is nose down
            x, y, z = self.xyz
            self.xyz = (x + step * (math.cos(self.yaw) * cp), y + step * (math.sin(self.yaw) * cp),
                        z + step * -math.sin(pitch))
        self.t = t
        # same roll and pitch in both frames (Rz Ry Rx): map <- odom is the yaw difference alone
        d = yaw - self.yaw
        c, s = math.cos(d), math.sin(d)
        x, y, z = self.xyz
        trans = (position[0] - (c * x - s * y), position[1] - (s * x + c * y), position[2] - z)
        return self.xyz, quaternion_from_euler(roll, pitch, self.yaw), trans, (0.0, 0.0, math.sin(d / 2),
                                                                              math.cos(d / 2))
