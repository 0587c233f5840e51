"""z gyro scale-factor state of the GNSS/INS (issue 15: heading after headland turns): a 0.5 % scale error leaves
0.9° of heading error after every U-turn unless the filter learns it; it does, within its sigma."""
import math

import numpy as np
import pytest

from agnav_fusion.ins import error_model as em
from agnav_fusion.ins.ekf import InsEkf, InsEkfSettings
from agnav_sim_eval.sim import ins_synthetic as sy

LEVER = (-1.0, 0.0, -2.0)      # IMU -> antenna, FRD [m]
SCALE = 0.005


@pytest.fixture(scope="module")
def field():
    traj = sy.field_drive(duration=150.0, speed=3.0, leg=40.0, heading0=1.0, tilt_deg=1.0)
    gyro, accel = sy.ideal_imu(traj)
    rng = np.random.default_rng(4)
    g, a, _, _ = sy.MemsGrade(gyro_scale=0.0).corrupt(gyro, accel, 0.01, rng)
    g[:, 2] += SCALE * gyro[:, 2]
    return traj, g, a, sy.gnss_samples(traj, gyro, LEVER, sy.RTK_5HZ, rng)


def _run(field, sigma):
    traj, g, a, gnss = field
    s = InsEkfSettings(lever_gnss_frd=LEVER, initial_heading=1.0, initial_heading_sigma=math.radians(5.0),
                       error=em.ErrorModelSettings(gyro_scale_sigma=sigma), mount_yaw_sigma=0.0)   # IMU squared
    ekf = InsEkf(s)
    return ekf, sy.run_ins(ekf, traj, g, a, gnss)


def test_scale_learnt_within_its_sigma(field):
    ekf, _ = _run(field, 0.005)
    err, sigma = ekf.mech.gyro_scale - SCALE, math.sqrt(ekf.p[em.GYRO_SCALE, em.GYRO_SCALE])
    assert abs(err) <= 3.0 * sigma and abs(err) < 0.0015, (ekf.mech.gyro_scale, sigma)
    assert sigma < 0.002                  # the turns made it observable


def test_heading_after_turns_better_with_the_state_and_within_3_sigma(field):
    _, with_state = _run(field, 0.005)
    _, without = _run(field, 0.0)
    late = with_state.t > 60.0
    rms = [math.degrees(math.sqrt(np.mean(e.att[e.t > 60.0, 2] ** 2))) for e in (with_state, without)]
    assert rms[0] < 0.7 * rms[1], rms
    assert np.all(np.abs(with_state.att[late, 2]) <= 3.0 * with_state.heading_sigma[late])
