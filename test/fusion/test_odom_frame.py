"""REP-105 odom: continuous under GNSS corrections; map->odom o odom->base_link is the map pose."""
import math

import numpy as np
from scipy.spatial.transform import Rotation

from agnav_fusion.odom_frame import OdomFrame


def test_odom_is_continuous_and_composes_to_the_map_pose():
    odom, dt, speed, rate = OdomFrame(), 0.01, 1.0, 0.05
    steps, t = [], 0.0
    last = None
    for k in range(3000):
        t = k * dt
        yaw = 0.3 + rate * t
        position = np.array([0.0, 0.0, 1.0]) + (0.2 if k >= 1500 else 0.0)  # a 0.2 m correction at 15 s
        position[:2] += [math.cos(yaw) * t, math.sin(yaw) * t]  # (shape only: the map pose is not integrated)
        rpy = (0.02, -0.01, yaw)
        xyz, quat, map_xyz, map_quat = odom.update(t, position, rpy, speed, rate)
        if last is not None:
            steps.append(np.linalg.norm(np.subtract(xyz, last)))
        last = xyz
        base_in_map = Rotation.from_quat(map_quat).apply(xyz) + map_xyz
        assert np.allclose(base_in_map, position, atol=1e-9)
        rot = Rotation.from_quat(map_quat) * Rotation.from_quat(quat)
        assert np.allclose(rot.as_euler("xyz"), rpy, atol=1e-9)
    assert max(steps) <= speed * dt + 1e-9  # the jump went into map->odom
