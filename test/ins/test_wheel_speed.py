"""Wheel or radar speed in the GNSS/INS (issue 15 item 3: every sensor present): the speed reads base_link's forward
velocity times (1 + scale); the scale (rolling radius, mean slip) is learnt while the fixes arrive and then holds the
speed through an outage."""
import math

import numpy as np
import pytest

from agnav_fusion.ins import error_model as em
from agnav_fusion.ins.constraints import WHEEL, WheelSettings, WheelSpeed
from agnav_fusion.ins.ekf import InsEkf, InsEkfSettings
from agnav_sim_eval.sim import ins_synthetic as sy
from constraint_check import LEVER_BASE, assert_rows_match_feedback

LEVER = (-1.67, 0.0, -3.23)    # IMU -> antenna, FRD [m]
SLIP = 0.08                    # the wheels turn 8 % faster than the ground passes


def test_wheel_jacobian_matches_the_feedback_correction():
    model = WheelSpeed(WheelSettings(), LEVER_BASE)
    assert_rows_match_feedback(lambda c, v, w, x: model.linearize(c, v, w, 0.05 - x[WHEEL], 2.0, 0.0, em.N_INS),
                               [(WHEEL, 1e-4)])


def test_speed_variance_floor_and_slip():
    s = WheelSettings(speed_sigma=0.05, slip_sigma=0.03)
    assert s.variance(2.0, None) == pytest.approx(0.05 ** 2 + 0.06 ** 2)
    assert s.variance(2.0, 0.01) == pytest.approx(0.01 + 0.06 ** 2)      # the message's own, when larger
    assert s.variance(0.0, -1.0) == pytest.approx(0.05 ** 2)


def _wheel_speeds(traj, rng, every=10):
    """10 Hz wheel speeds: body forward speed x (1 + SLIP) + 2 cm/s noise."""
    forward = np.einsum("nij,ni->nj", traj.c_b_ned, traj.v_ned)[:, 0]
    return [(traj.t[k], (1.0 + SLIP) * forward[k] + rng.normal(0.0, 0.02), 0.0)
            for k in range(1, len(traj.t), every)]


@pytest.fixture(scope="module")
def runs():
    """A 30 s outage at 0.8 m/s on passes with U-turns, with and without the wheel speed."""
    traj = sy.field_drive(duration=100.0, speed=0.8, leg=20.0, heading0=1.0)
    gyro, accel = sy.ideal_imu(traj)
    out = {}
    for wheel in (True, False):
        rng = np.random.default_rng(21)
        g, a, _, _ = sy.MemsGrade().corrupt(gyro, accel, 0.01, rng)
        gnss = sy.gnss_samples(traj, gyro, LEVER, sy.RTK_5HZ, rng)
        ekf = InsEkf(InsEkfSettings(lever_gnss_frd=LEVER))
        scale = {}
        orig = ekf.add_gnss

        def add_gnss(sample, ekf=ekf, orig=orig, scale=scale):   # the scale as the outage begins
            if sample.t >= 60.0 and "outage" not in scale:
                scale["outage"] = (ekf.wheel_scale, math.sqrt(ekf.p[WHEEL, WHEEL]))
            return orig(sample)
        ekf.add_gnss = add_gnss
        err = sy.run_ins(ekf, traj, g, a, gnss, outages=[(60.0, 90.0)],
                         wheel=_wheel_speeds(traj, rng) if wheel else ())
        out[wheel] = (ekf, err, scale.get("outage"))
    return out


def test_scale_learnt_before_the_outage(runs):
    _, _, (scale, sigma) = runs[True]
    assert abs(scale - SLIP) <= 3.0 * sigma and sigma < 0.5 * WheelSettings().scale_sigma, (scale, sigma)


def test_wheel_holds_the_speed_through_an_outage(runs):
    drift = {}
    for wheel, (_, err, _) in runs.items():
        inside = (err.t > 60.2) & (err.t < 90.0)
        e = np.linalg.norm(err.pos[inside, :2], axis=1)
        assert np.all(e < 3.0 * err.pos_sigma[inside]), wheel            # honest while coasting
        drift[wheel] = e.max()
    assert drift[True] < 0.3 and drift[True] < 0.5 * drift[False], drift
