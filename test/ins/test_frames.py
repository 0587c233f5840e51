"""REP-103 edge of the INS: mounts from TF into the FRD body, base_link pose/twist from the IMU-point solution."""
import math

import numpy as np

from agnav_common.frames import rotation_matrix
from agnav_common.geodesy import LocalTangentPlane
from agnav_sim_eval.sim import ins_synthetic as sy
from agnav_fusion.ins.ekf import NavSolution
from agnav_fusion.ins.frames import Mounts, base_link_state

DATUM = (43.0, 141.0, 50.0)


def test_mounts_from_tf_rotated_imu():
    m = Mounts.from_tf((0.8, 0.0, 1.0), rotation_matrix(0.0, 0.0, math.pi / 2), (0.2, 0.0, 2.8))
    np.testing.assert_allclose(m.imu_to_frd @ [1.0, 0.0, 0.0], [0.0, -1.0, 0.0], atol=1e-12)  # IMU x = base left
    np.testing.assert_allclose(m.lever_imu_frd, [0.8, 0.0, -1.0])
    np.testing.assert_allclose(m.lever_gnss_frd, [-0.6, 0.0, -1.8])


def test_base_link_state_moves_the_imu_solution_and_converts_angles():
    roll, pitch, heading = 0.03, 0.05, math.radians(30.0)          # FRD: pitch nose up, heading cw from north
    c = sy.dcm_from_euler(roll, pitch, heading)
    omega = np.array([0.0, 0.0, 0.2])                               # turning right (FRD z down)
    v_ned = c @ np.array([2.0, 0.0, 0.0])
    sol = NavSolution(5.0, math.radians(DATUM[0]), math.radians(DATUM[1]), DATUM[2], v_ned, roll, pitch, heading,
                      omega, c, np.eye(3) * 1e-4, np.eye(3) * 1e-4, np.array([1e-5, 1e-5, 1e-4]), np.full(3, 1e-8))
    m = Mounts.from_tf((0.8, 0.0, 1.0), np.eye(3), (0.0, 0.0, 2.0))
    s = base_link_state(sol, m, LocalTangentPlane(*DATUM))
    np.testing.assert_allclose(s.rpy, [roll, -pitch, math.radians(60.0)], atol=1e-12)
    r = rotation_matrix(*s.rpy)
    np.testing.assert_allclose(s.position, -r @ [0.8, 0.0, 1.0], atol=1e-6)  # IMU at the datum
    # body velocity at base_link: forward 2 m/s minus ω x (base - IMU) (yaw rate 0.2 rad/s, 0.8 m behind)
    np.testing.assert_allclose(s.velocity, [2.0, 0.8 * 0.2, 0.0], atol=1e-9)
    np.testing.assert_allclose(s.rates, [0.0, 0.0, -0.2])
    assert s.finite() and s.pose_cov[5, 5] == 1e-4
