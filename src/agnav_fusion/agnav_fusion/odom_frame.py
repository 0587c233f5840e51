"""Continuous odom (REP-105) for any estimator, ROS-free: base_link in `odom` is dead-reckoned from the estimate's
own speed and yaw rate and never corrected, so it never jumps; the corrections that GNSS fixes make to the map pose
go into map->odom. At the start (and when time goes backwards: a new replay) odom coincides with map."""
import math

import numpy as np
from scipy.spatial.transform import Rotation


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
        odom_rot = Rotation.from_euler("xyz", (roll, pitch, self.yaw))
        map_rot = Rotation.from_euler("xyz", (roll, pitch, yaw))
        rot = map_rot * odom_rot.inv()   # map <- odom
        trans = np.asarray(position, dtype=float) - rot.apply(self.xyz)
        return self.xyz, odom_rot.as_quat(), trans, rot.as_quat()
