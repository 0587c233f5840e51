"""In-motion alignment from a standing start (issue 15): a start's acceleration neither tilts the initial level
(the standing level carried by the gyros) nor lags the initial velocity (fix-difference means carried to the fix)."""
import math
from types import SimpleNamespace

import numpy as np

from agnav_sim_eval.sim import ins_synthetic as sy
from agnav_fusion.ins import earth
from agnav_fusion.ins.alignment import FixTrack
from agnav_fusion.ins.ekf import InsEkf, InsEkfSettings

LAT = math.radians(43.0)
LEVER = (-1.67, 0.0, -3.23)    # IMU -> antenna, FRD [m]


def test_fix_difference_velocity_carried_to_the_fix():
    """0.5 m/s^2 from standing, 1 Hz fixes: each mean over the 2 m baseline lags by half its span (0.25 m/s and
    more); carried by the last two means' acceleration it is the speed at the fix, within its covariance."""
    track, rm = FixTrack(), earth.radii(LAT)[0]
    out = []
    for k in range(12):
        t = float(k)
        north = 0.25 * max(t - 2.0, 0.0) ** 2
        g = SimpleNamespace(t=t, lat=LAT + north / rm, lon=0.1, alt=0.0, pos_cov_enu=np.diag([1e-4, 1e-4, 4e-4]))
        vel = track.velocity(g)
        if vel is not None:
            out.append((0.5 * max(t - 2.0, 0.0), vel))
    assert len(out) >= 6
    for speed, (v, cov) in out:
        assert abs(v[1] - speed) < 0.03 and abs(v[1] - speed) < 3.0 * math.sqrt(cov[1, 1])


def test_fix_difference_velocity_does_not_amplify_fix_noise():
    """10 Hz RTK fixes with 1 cm noise at a steady 1 m/s: the acceleration comes from a mean at least half a span
    back, so the carried velocity stays within a few cm/s (a carry from the previous 0.1 s mean: 0.1-0.2 m/s)."""
    rng = np.random.default_rng(5)
    track, rm = FixTrack(), earth.radii(LAT)[0]
    errors = []
    for k in range(300):
        t = 0.1 * k
        north = 1.0 * t + 0.01 * rng.standard_normal()
        g = SimpleNamespace(t=t, lat=LAT + north / rm, lon=0.1, alt=0.0, pos_cov_enu=np.diag([1e-4, 1e-4, 4e-4]))
        vel = track.velocity(g)
        if vel is not None:
            errors.append(vel[0][1] - 1.0)
    assert len(errors) > 200 and np.std(errors) < 0.03


def test_alignment_during_a_start_keeps_level_and_speed():
    """10 s standing, then 0.5 m/s^2 to 4 m/s with terrain sway; DGPS 1 Hz without Doppler. Before the standing
    level and the carried velocity, the filter started 3 deg off in pitch (the acceleration) and 0.5 m/s slow."""
    sway = lambda t: math.radians(0.5) * min(max(t - 10.0, 0.0), 1.0)       # noqa: E731 (terrain: once moving)
    traj = sy.drive([(10.0, 0.0, 0.0), (8.0, 0.5, 0.0), (30.0, 0.0, 0.0)], heading0=0.4,
                    tilt=lambda t: (sway(t) * math.sin(2.1 * t), sway(t) * math.sin(1.7 * t + 2)))
    gyro, accel = sy.ideal_imu(traj)
    rng = np.random.default_rng(21)
    g, a, _, _ = sy.MemsGrade().corrupt(gyro, accel, 0.01, rng)
    gnss = sy.gnss_samples(traj, gyro, LEVER, sy.DGPS_1HZ, rng)
    for _, sample in gnss:
        sample.vel_enu = None
    err = sy.run_ins(InsEkf(InsEkfSettings(lever_gnss_frd=LEVER)), traj, g, a, gnss)
    assert 10.0 < err.t[0] < 18.0                           # aligning while accelerating
    assert math.degrees(abs(err.att[0, 1])) < 1.0 and np.linalg.norm(err.vel[0, :2]) < 0.15    # was 2.8 deg, 0.5 m/s
    aligned = err.t[np.argmax(err.heading_sigma < math.radians(1.0))]
    published = (err.t >= aligned) & (err.t < aligned + 10.0)
    assert np.linalg.norm(err.vel[published, :2], axis=1).max() < 0.1                         # was 0.22 m/s
