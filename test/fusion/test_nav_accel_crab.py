"""agnav estimator (issue 15): accelerometer-driven speed, fix-differenced velocities, crab state, honest heading
start and dead reckoning. A small synthetic drive straight north-east at 1 Hz DGPS-like fixes, noisy sensors."""
import math

import numpy as np
import pytest

from agnav_fusion.nav_sensor_module import NavSensorModule, NavSensorModuleSettings

G = 9.80665
RATE = 100.0
YAW = math.radians(40.0)   # REP-103 yaw of the drive (ENU, from east)


def drive(seconds=60.0, speed=lambda t: 1.0, crab=lambda t: 0.0, pitch=lambda t: 0.0, accel=True, doppler=True,
          outage=(), accel_bias=0.05, vibration=0.3, seed=4, settings=None):
    """Feed a NavSensorModule; -> (module, [(t, state, true x, true y, true speed)]). crab: REP-103 rad, course over
    ground = yaw - crab; pitch: REP-103 (nose down +)."""
    rng = np.random.default_rng(seed)
    nsm = NavSensorModule(settings or NavSensorModuleSettings(lever_flu=(0.0, 0.0, 2.0)))
    x = y = 0.0
    dt = 1.0 / RATE
    out, last_fix = [], None
    for k in range(1, int(seconds * RATE)):
        t = 5.0 + k * dt
        v, a = speed(t), (speed(t + dt) - speed(t - dt)) / (2 * dt)
        course = YAW - crab(t)
        x += v * math.cos(course) * dt
        y += v * math.sin(course) * dt
        th = pitch(t)
        dth = (pitch(t + dt) - pitch(t - dt)) / (2 * dt)
        if k % int(RATE) == 0 and not any(t0 <= t < t1 for t0, t1 in outage):
            ant = np.array([x, y, 2.0]) + 2.0 * math.sin(-th) * np.array([math.cos(YAW), math.sin(YAW), 0.0])
            ant[:2] += rng.normal(0, 0.02, 2)
            vel = None
            if doppler:
                vel = v * np.array([math.cos(course), math.sin(course), 0.0]) + rng.normal(0, 0.03, 3)
                vel[:2] += 2.0 * dth * math.cos(th) * np.array([math.cos(YAW), math.sin(YAW)]) * -1.0
            elif last_fix is not None:  # what the front end sends without /gnss/vel: the fix difference
                vel = (ant - last_fix[1]) / (t - last_fix[0])
            nsm.gnss(t, ant, np.diag([4e-4, 4e-4, 1e-3]), vel, None if doppler else 8e-4)
            last_fix = (t, ant)
        nsm.inclinometer(t, rng.normal(0, 0.002), th + rng.normal(0, 0.002))
        gyro = np.array([0.0, dth, 0.0]) + rng.normal(0, 0.002, 3)
        force = np.array([a - G * math.sin(th), 0.0, G * math.cos(th)]) + accel_bias + rng.normal(0, vibration, 3)
        s = nsm.imu(t, gyro, force if accel else None)
        out.append((t, s, x, y, v))
    return nsm, out


def published(out, t0=0.0):
    return [(t, s, x, y, v) for t, s, x, y, v in out if t >= t0 and s is not None and s.heading_valid]


def test_zero_or_nan_specific_force_means_no_accelerometer():
    nsm, _ = drive(seconds=3.0, accel=False)
    assert not nsm.estimator.ekf.accel_mode
    for bad in (np.zeros(3), np.array([math.nan, 0.0, G])):
        nsm.imu(nsm.history[-1].t + 0.01, np.zeros(3), bad)
        assert not nsm.estimator.ekf.accel_mode
    nsm.imu(nsm.history[-1].t + 0.01, np.zeros(3), np.array([0.0, 0.0, G]))
    assert nsm.estimator.ekf.accel_mode


def test_the_thesis_estimator_ignores_the_accelerometer():
    nsm, out = drive(seconds=20.0, settings=NavSensorModuleSettings(lever_flu=(0.0, 0.0, 2.0), estimator="thesis"))
    assert out[-1][1].position_valid


def speed_errors(out, t0):
    return np.array([s.speed - v for t, s, x, y, v in published(out, t0)])


@pytest.mark.xfail(strict=True, reason="issue 15 open: without /gnss/vel the accelerometer bias and the pitch are "
                   "learnt from fix differences too slowly (0.3 m/s error)")
def test_the_accelerometer_carries_the_speed_between_fixes():
    """Speed steps 1 -> 2 -> 1 m/s at 0.5 m/s^2 with no receiver velocity (fix differences only): with the biased,
    vibrating accelerometer the speed follows within 0.1 m/s; without it, it lags by more than 0.25 m/s."""
    def speed(t):
        return 1.0 + float(np.clip((t - 30.0) * 0.5, 0, 1)) - float(np.clip((t - 45.0) * 0.5, 0, 1))
    _, with_acc = drive(speed=speed, doppler=False)
    _, without = drive(speed=speed, doppler=False, accel=False)
    assert np.abs(speed_errors(with_acc, 25.0)).max() < 0.1
    assert np.abs(speed_errors(without, 25.0)).max() > 0.25


def test_fix_differenced_velocity_is_recognised_and_not_fused_as_doppler():
    nsm, out = drive(seconds=30.0, doppler=False, accel=False)
    t0, p0 = nsm._antenna_fixes[-2]
    t1, p1 = nsm._antenna_fixes[-1]
    assert nsm._differenced(t1 + 1.0, p1 + (p1 - p0), (p1 - p0) / (t1 - t0))
    assert not nsm._differenced(t1 + 1.0, p1 + (p1 - p0), (p1 - p0) / (t1 - t0) + 0.01)
    assert nsm.counters["velocity_gated"] == 0
    assert np.abs(speed_errors(out, 15.0)).max() < 0.2


@pytest.mark.xfail(strict=True, reason="issue 15 open: a crab on level ground (no roll to explain it) is told from "
                   "the heading only by its prior (crab_sigma): yaw follows the course")
def test_crab_is_estimated_and_yaw_keeps_the_heading():
    """A 1.5 deg crab (sliding right) builds up after 25 s: yaw stays on the vehicle's heading (the gyro saw no
    turn), the crab state takes the course change, and the heading stays within 3 sigma."""
    beta = math.radians(1.5)
    nsm, out = drive(seconds=90.0, crab=lambda t: beta * float(np.clip((t - 25.0) / 5.0, 0, 1)))
    late = published(out, 70.0)
    yaw_err = np.array([math.remainder(s.rpy[2] - YAW, 2 * math.pi) for _, s, *_ in late])
    crab = np.array([s.crab for _, s, *_ in late])
    assert np.abs(yaw_err).max() < math.radians(0.5)
    assert np.abs(crab - beta).max() < math.radians(0.5)
    assert all(abs(e) <= 3 * math.sqrt(s.pose_cov[5, 5]) for e, (_, s, *_) in zip(yaw_err, late))
    assert all(np.isfinite(s.crab_var) and s.crab_var > 0 for _, s, *_ in late)


def test_the_first_published_heading_is_within_its_covariance():
    nsm, out = drive(seconds=20.0)
    first = published(out)[0][1]
    sigma = math.sqrt(first.pose_cov[5, 5])
    assert sigma <= nsm.settings.heading_valid_sigma
    assert abs(math.remainder(first.rpy[2] - YAW, 2 * math.pi)) <= 3 * sigma


@pytest.mark.parametrize("accel", [pytest.param(True, marks=pytest.mark.xfail(
    strict=True, reason="issue 15 open: accelerometer bias drift gives 3 m in 30 s")), pytest.param(False, marks=(
        pytest.mark.xfail(strict=True, reason="issue 15 open: drift and 3 sigma met, but the speed model's variance "
                          "(a stop during the outage stays within 3 sigma) gives a position sigma of 16 m in 30 s")))])
def test_a_30_s_outage_drifts_little_and_honestly(accel):
    """0.8 m/s, fixes lost for 30 s: <= 1.5 m drift, error <= 3 sigma throughout, and the position is back within
    10 cm 10 s after the fixes return; sigma stays of the drift's size (not tens of metres)."""
    outage = (40.0, 70.0)
    _, out = drive(seconds=90.0, speed=lambda t: 0.8, outage=[outage], accel=accel)
    rows = published(out, 20.0)
    err = np.array([math.hypot(s.position[0] - x, s.position[1] - y) for t, s, x, y, v in rows])
    sig = np.array([math.sqrt(s.pose_cov[0, 0] + s.pose_cov[1, 1]) for t, s, *_ in rows])
    t = np.array([r[0] for r in rows])
    during = (t >= outage[0]) & (t < outage[1] + 1.0)
    assert err[during].max() <= 1.5
    assert np.all(err <= 3 * sig)
    assert sig[during].max() < 15.0
    assert err[(t >= outage[1] + 10.0)].max() < 0.1


def slope_drive(gain=0.3, slope=math.radians(5.0), speed=1.5, seed=7, seconds=110.0):
    """Across a slope falling to the right (roll +slope heading north), a 180 deg U-turn at 50-60 s, back south;
    the vehicle slides downhill: crab = gain * sin(roll) (REP-103: course = yaw - crab). Gyro-only package (no
    accelerometer), 1 Hz fixes with receiver velocity. -> (module, [(t, state, true yaw, true crab)])."""
    from agnav_fusion.tilt_correction import antenna_offset
    rng = np.random.default_rng(seed)
    nsm = NavSensorModule(NavSensorModuleSettings(lever_flu=(0.0, 0.0, 2.0)))
    dt, x, y, out = 1.0 / RATE, 0.0, 0.0, []
    yaw_rate = math.pi / 10.0

    def yaw_at(t):
        return math.pi / 2 + yaw_rate * float(np.clip(t - 50.0, 0.0, 10.0))
    for k in range(1, int(seconds * RATE)):
        t = 5.0 + k * dt
        yaw, wz = yaw_at(t), yaw_rate if 50.0 <= t < 60.0 else 0.0
        roll = slope * math.sin(yaw)   # right side down heading north (the slope falls to the east)
        droll = slope * math.cos(yaw) * wz
        crab = gain * math.sin(roll)
        x += speed * math.cos(yaw - crab) * dt
        y += speed * math.sin(yaw - crab) * dt
        if k % int(RATE) == 0:
            ant = np.array([x, y, 2.0]) + antenna_offset((0.0, 0.0, 2.0), math.pi / 2 - yaw, 0.0, roll) * [1, 1, 0]
            vel = speed * np.array([math.cos(yaw - crab), math.sin(yaw - crab), 0.0]) + rng.normal(0, 0.03, 3)
            nsm.gnss(t, ant + np.r_[rng.normal(0, 0.02, 2), 0.0], np.diag([4e-4, 4e-4, 1e-3]), vel)
        nsm.inclinometer(t, roll + speed * wz / G + rng.normal(0, 0.002), rng.normal(0, 0.002))
        gyro = np.array([droll, wz * math.sin(roll), wz * math.cos(roll)]) + rng.normal(0, 0.002, 3)
        out.append((t, nsm.imu(t, gyro), yaw, crab))
    return nsm, out


def test_crab_on_a_slope_is_told_from_the_heading_by_turning():
    """1.5 deg downhill crab on a 5 deg cross slope: before the turn the split between heading and crab is unknown
    (heading within 3 sigma, sigma about the crab); after the U-turn the crab flipped sign while the gyro saw 180 deg,
    which tells the crab's gain: yaw within 0.3 deg RMS of the heading, crab within 0.3 deg."""
    nsm, out = slope_drive()
    rows = [(t, s, yaw, crab) for t, s, yaw, crab in out if s is not None and s.heading_valid and t >= 20.0]
    err = np.array([math.remainder(s.rpy[2] - yaw, 2 * math.pi) for t, s, yaw, crab in rows])
    sig = np.array([math.sqrt(s.pose_cov[5, 5]) for t, s, *_ in rows])
    assert np.all(np.abs(err) <= 3 * sig)
    late = np.array([t >= 80.0 for t, *_ in rows])
    assert math.sqrt(np.mean(err[late] ** 2)) < math.radians(0.3)
    crab_err = np.array([s.crab - crab for t, s, yaw, crab in rows])
    assert np.abs(crab_err[late]).max() < math.radians(0.3)
