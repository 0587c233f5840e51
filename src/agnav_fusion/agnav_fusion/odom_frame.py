"""Continuous odom (REP-105) for any estimator, ROS-free: base_link in `odom` is dead-reckoned from the estimate's
own speed and yaw rate and never corrected, so it never jumps; the corrections that GNSS fixes make to the map pose
go into map->odom. At the start (and when time goes backwards: a new replay) odom coincides with map."""
import math

import numpy as np

from agnav_common.frames import quaternion_from_euler


class OdomFrame:
    """update(t, position, rpy, speed, yaw_rate) -> (odom->base xyz, xyzw, map->odom xyz, xyzw)."""

    def __init__(self):
        self.t = None
        self.xyz = None
        self.yaw = 0.0

    def update(self, t, position, rpy, speed, yaw_rate):
        roll, pitch, yaw = (float(v) for v in rpy)
        if self.t is None or t < self.t:
            self.xyz, self.yaw = np.array(position, dtype=float), yaw
        else:
            dt = t - self.t
            self.yaw = math.remainder(self.yaw + yaw_rate * dt, 2 * math.pi)
            cp = math.cos(pitch)  # REP-103: positive pitch is nose down
            self.xyz = self.xyz + speed * dt * np.array([math.cos(self.yaw) * cp, math.sin(self.yaw) * cp,
                                                         -math.sin(pitch)])
        self.t = t
        # same roll and pitch in both frames (Rz Ry Rx): map <- odom is the yaw difference alone
        d = yaw - self.yaw
        c, s = math.cos(d), math.sin(d)
        trans = np.array([position[0] - (c * self.xyz[0] - s * self.xyz[1]),
                          position[1] - (s * self.xyz[0] + c * self.xyz[1]), position[2] - self.xyz[2]])
        return self.xyz, quaternion_from_euler(roll, pitch, self.yaw), trans, (0.0, 0.0, math.sin(d / 2),
                                                                              math.cos(d / 2))
