"""NavSensorModule (SPEC §6.3) on a synthetic drive: accuracy, GNSS latency, guarding, outage and re-convergence."""
import math

import numpy as np
import pytest

from agnav_fusion.nav_ekf import IB, IV
from agnav_fusion.nav_sensor_module import NavSensorModule, NavSensorModuleSettings

RATE = 50.0
LEVER = (0.0, 0.0, 2.0)


def truth(t):
    """Gentle S-curve at 1 m/s with a slow roll; returns (x, y, yaw, roll, yaw rate, roll rate)."""
    yaw = 0.3 + 0.3 * math.sin(0.05 * t)
    roll = 0.05 * math.sin(0.2 * t)
    return yaw, roll, 0.015 * math.cos(0.05 * t), 0.01 * math.cos(0.2 * t)


def drive(settings=None, seconds=80.0, outage=(), jump_at=(), seed=2, latency=0.1, velocity=True,
          speed=lambda t: 1.0, wheel=False, mutate=lambda kind, args: args, on_start=None):
    """Simulate and feed the module in arrival order (wheel: a 10 Hz wheel speed reading 1 % fast); returns
    per-sample (t, state, true x, true y, true yaw). mutate(kind, args) may edit ("imu": (t, gyro), "gnss": (t,
    antenna, cov, vel)) or drop (None) an input."""
    rng = np.random.default_rng(seed)
    nsm = NavSensorModule(settings or NavSensorModuleSettings(lever_flu=LEVER))
    if on_start:
        on_start(nsm)
    x = y = 0.0
    dt = 1.0 / RATE
    pending, out = [], []
    for k in range(1, int(seconds * RATE)):
        t = 10.0 + k * dt
        yaw, roll, dyaw, droll = truth(t)
        v = speed(t)
        x += v * math.cos(yaw) * dt
        y += v * math.sin(yaw) * dt
        if k % int(RATE) == 0 and not any(a <= t < b for a, b in outage):
            ant = np.array([x, y, 2.0]) + 2.0 * np.array([math.sin(yaw) * math.sin(roll),
                                                         -math.cos(yaw) * math.sin(roll), 0.0])
            ant[:2] += rng.normal(0, 0.02, 2) + (5.0 if any(abs(t - j) < 1e-9 for j in jump_at) else 0.0)
            vel = v * np.array([math.cos(yaw), math.sin(yaw), 0.0]) + rng.normal(0, 0.03, 3)
            pending.append((t + latency, t, ant, np.diag([4e-4, 4e-4, 1e-3]), vel if velocity else None))
        for item in [p for p in pending if p[0] <= t]:
            args = mutate("gnss", item[1:])
            if args is not None:
                nsm.gnss(*args)
            pending.remove(item)
        if wheel and k % 5 == 0:
            nsm.wheel_speed(t, 1.01 * v + rng.normal(0, 0.02))
        nsm.inclinometer(t, roll + rng.normal(0, 0.002), 0.0)
        args = mutate("imu", (t, np.array([droll, 0.0, dyaw + 0.003]) + rng.normal(0, 0.002, 3)))
        s = nsm.imu(*args) if args is not None else None
        out.append((t, s or nsm.state(), x, y, yaw))
    return nsm, out


def errors(out, t0=30.0, t1=math.inf):
    """RMS position (m) and heading (rad) errors over [t0, t1)."""
    sel = [(s, x, y, yaw) for t, s, x, y, yaw in out if t0 <= t < t1]
    pos = [math.hypot(s.position[0] - x, s.position[1] - y) for s, x, y, _ in sel]
    hdg = [abs(math.remainder(s.rpy[2] - yaw, 2 * math.pi)) for s, _, _, yaw in sel]
    return float(np.sqrt(np.mean(np.square(pos)))), float(np.sqrt(np.mean(np.square(hdg))))


@pytest.fixture(scope="module")
def nominal():
    return drive()


@pytest.mark.parametrize("estimator", ["agnav", "thesis"])
def test_tracks_position_and_heading(estimator, nominal):
    if estimator == "agnav":
        nsm, out = nominal
    else:
        nsm, out = drive(NavSensorModuleSettings(estimator="thesis", lever_flu=LEVER), seconds=60.0)
    pos, hdg = errors(out)
    assert pos < 0.08
    assert hdg < math.radians(1.5 if estimator == "agnav" else 3.0)  # the thesis' 1 Hz LSM is noisier
    final = out[-1][1]
    assert final.heading_valid and final.position_valid
    assert np.all(np.isfinite(final.pose_cov)) and np.all(np.linalg.eigvalsh(final.pose_cov) > 0)


def test_bad_inputs_are_rejected_and_counted(nominal):
    nsm, out = nominal
    t = out[-1][0]
    assert nsm.imu(t + 0.02, [math.nan, 0.0, 0.0]) is None
    assert nsm.imu(t - 1.0, [0.0, 0.0, 0.0]) is None          # backwards
    assert nsm.imu(0.0, [0.0, 0.0, 0.0]) is None              # zero stamp
    assert not nsm.gnss(t, [math.inf, 0.0, 0.0], np.eye(3))
    assert not nsm.gnss(t - 50.0, [0.0, 0.0, 0.0], np.eye(3))  # before the latest fix
    assert not nsm.inclinometer(t, math.nan, 0.0)
    c = nsm.counters
    assert c["imu_bad_value"] == 1 and c["imu_backwards_stamp"] == 1 and c["imu_bad_stamp"] == 1
    assert c["gnss_bad_value"] == 1 and c["incl_bad_value"] == 1
    assert c["gnss_backwards_stamp"] == 1
    s = nsm.imu(t + 0.02, [0.0, 0.0, 0.0])
    assert s is not None and np.all(np.isfinite(s.position)) and np.all(np.isfinite(s.pose_cov))


def test_gnss_jump_is_gated():
    nsm, out = drive(seconds=60.0, jump_at=(50.0,))
    assert nsm.counters["gnss_gated"] == 1
    pos, _ = errors(out, 49.0, 53.0)
    assert pos < 0.15  # an accepted 5 m jump would put metres here


def test_30s_outage_dead_reckons_with_growing_covariance_and_reconverges():
    nsm, out = drive(seconds=110.0, outage=((40.0, 70.0),))
    during = [(t, s) for t, s, *_ in out if 41.0 <= t < 70.0]
    var = [s.pose_cov[0, 0] + s.pose_cov[1, 1] for _, s in during]
    assert all(np.all(np.isfinite(s.position)) for _, s in during)
    assert var[-1] > 10 * var[0]
    assert during[-1][1].dead_reckoning
    pos_out, _ = errors(out, 41.0, 70.0)
    assert pos_out < 3.0
    pos_after, hdg_after = errors(out, 85.0)
    assert pos_after < 0.08 and hdg_after < math.radians(1.5)
    assert not out[-1][1].dead_reckoning


def test_coasting_starts_once_a_fix_is_overdue():
    """1 Hz fixes, 0.1 s latency: the speed model coasts (no acceleration extrapolated) from one fix period plus
    coast_margin after the last fix epoch, not only at gnss_timeout, and never while fixes arrive on time."""
    coasting_at, now = [], [0.0]

    def spy(nsm):
        imu, predict = nsm.imu, nsm.estimator.ekf.predict

        def timed_imu(t, gyro):
            now[0] = t
            return imu(t, gyro)

        def watched_predict(rate, dt, accel=None, roll=0.0, coasting=False):
            if coasting:
                coasting_at.append(now[0])
            return predict(rate, dt, accel, roll, coasting)
        nsm.imu, nsm.estimator.ekf.predict = timed_imu, watched_predict

    nsm, _ = drive(seconds=60.0, outage=((45.0, 55.0),), on_start=spy)
    assert 1.0 + nsm.settings.coast_margin < nsm.settings.gnss_timeout
    # the last fix before the outage has epoch 44 s
    assert min(coasting_at) == pytest.approx(44.0 + 1.0 + nsm.settings.coast_margin, abs=0.03)
    assert 55.0 < max(coasting_at) < 60.0  # the fixes back (once the module takes them again)


def test_wheel_speed_carries_a_speed_change_through_an_outage():
    """Accelerating from 1 to 2 m/s without fixes: the GNSS-only module keeps the old speed, a wheel speed (1 %
    scale error) keeps the dead reckoning within a metre over ~75 m."""
    def speed(t):
        return 1.0 + min(max((t - 45.0) / 10.0, 0.0), 1.0)

    ends = {}
    for wheel in (False, True):
        _, out = drive(seconds=80.0, outage=((40.0, 70.0),), speed=speed, wheel=wheel)
        ends[wheel], _ = errors(out, 69.0, 70.0)
    assert ends[True] < 1.0 and ends[False] > 10.0


def test_bad_wheel_speeds_are_rejected_and_counted():
    nsm, t = NavSensorModule(), 10.0
    assert not nsm.wheel_speed(t + 0.01, math.nan)
    assert not nsm.wheel_speed(t + 0.01, 1.0, math.inf)
    assert nsm.wheel_speed(t + 0.02, 1.0)
    assert not nsm.wheel_speed(t + 0.02, 1.0)  # same stamp again
    assert nsm.counters["wheel_bad_value"] == 2 and nsm.counters["wheel_backwards_stamp"] == 1


def test_heading_from_the_fix_chord_without_gnss_velocity():
    """A receiver without /gnss/vel: the heading starts from the chord between moving fixes."""
    _, out = drive(seconds=60.0, velocity=False)
    pos, hdg = errors(out)
    assert pos < 0.08 and hdg < math.radians(1.5)
    assert out[-1][1].heading_valid


def test_standstill_learns_the_yaw_gyro_offset():
    """Fixes at rest mark the vehicle still: the yaw gyro reads its own bias (zero-rate update), beyond the prior."""
    rng = np.random.default_rng(4)
    nsm = NavSensorModule(NavSensorModuleSettings(lever_flu=LEVER))
    offset = 0.008  # rad/s (0.46 deg/s, the ENV-05F zero error), CCW
    for k in range(1, 20 * int(RATE)):
        t = 10.0 + k / RATE
        if k % int(RATE) == 0:
            nsm.gnss(t, rng.normal(0, 0.02, 3), np.diag([4e-4, 4e-4, 1e-3]), np.zeros(3))
        nsm.inclinometer(t, 0.0, 0.0)
        nsm.imu(t, np.array([0.0, 0.0, offset]) + rng.normal(0, 0.004, 3))
    # the EKF bias is of the clockwise rate (thesis convention): -offset
    assert nsm.estimator.ekf.x[IB] == pytest.approx(-offset, abs=1e-3)
    assert nsm.state().rates[2] == pytest.approx(0.0, abs=0.01)


def test_speed_is_fused_before_the_heading_is_known():
    """From the first fixes the module dead-reckons at the GNSS speed, before the chord gives the heading."""
    nsm, out = drive(seconds=20.0)
    early = [s for t, s, *_ in out if 12.0 <= t < 13.0]
    assert not early[0].heading_valid
    assert nsm.estimator.ekf.x is not None and abs(nsm.estimator.ekf.x[IV] - 1.0) < 0.1


def test_standing_still_does_not_creep():
    """Fixes at rest: the zero-speed update holds the position between fixes."""
    rng = np.random.default_rng(5)
    nsm = NavSensorModule(NavSensorModuleSettings(lever_flu=LEVER))
    track = []
    for k in range(1, 20 * int(RATE)):
        t = 10.0 + k / RATE
        if k % int(RATE) == 0:
            nsm.gnss(t, rng.normal(0, 0.02, 3), np.diag([4e-4, 4e-4, 1e-3]), rng.normal(0, 0.03, 3))
        nsm.inclinometer(t, 0.0, 0.0)
        track.append(nsm.imu(t, rng.normal(0, 0.004, 3)).position[:2].copy())
    steps = np.linalg.norm(np.diff(np.array(track[-5 * int(RATE):]), axis=0), axis=1)
    assert np.median(steps) * RATE < 0.005  # under 5 mm/s of creep between fixes (the speed's noise: 3 cm/s)
