"""GNSS/INS EKF on simulated MEMS + RTK runs: consistency, in-motion alignment, outages, jumps, guards."""
import math

import numpy as np
import pytest

from agnav_sim_eval.sim import ins_synthetic as sy
from agnav_fusion.ins.ekf import ALIGNED, InsEkf, InsEkfSettings

LEVER = (-1.0, 0.0, -2.0)      # IMU -> antenna, FRD [m]


@pytest.fixture(scope="module")
def field():
    """One 100 s field run with U-turns, its ideal IMU and truth (shared by the tests)."""
    traj = sy.field_drive(duration=100.0, speed=2.0, leg=30.0, heading0=2.0)
    return traj, sy.ideal_imu(traj)


def _run(field, seed, heading_guess, outages=(), tamper=None, imu_gaps=(), **kw):
    traj, (gyro, accel) = field
    rng = np.random.default_rng(seed)
    g, a, _, _ = sy.MemsGrade().corrupt(gyro, accel, 0.01, rng)
    gnss = sy.gnss_samples(traj, gyro, LEVER, sy.RTK_5HZ, rng)
    if tamper:
        tamper(gnss)
    ekf = InsEkf(InsEkfSettings(lever_gnss_frd=LEVER, initial_heading=heading_guess, **kw))
    return ekf, sy.run_ins(ekf, traj, g, a, gnss, outages, imu_gaps=imu_gaps)


@pytest.mark.parametrize("offset_deg", [180.0, -179.0, 90.0])
def test_alignment_converges_from_large_heading_error(field, offset_deg):
    ekf, err = _run(field, 1, 2.0 + math.radians(offset_deg), align_from_course=False)   # from the guess
    assert abs(math.degrees(err.att[0, 2])) > 80.0                 # really started far off
    late = err.t > err.t[-1] - 20.0
    assert np.degrees(np.abs(err.att[late, 2])).max() < 2.0
    assert ekf.alignment == ALIGNED
    assert np.sqrt(np.mean(np.sum(err.pos[late, :2] ** 2, axis=1))) < 0.1


def test_position_nees_consistent(field):
    _, err = _run(field, 2, 2.0 + 1.0)
    settled = err.t > 30.0
    # 3-dof NEES mean should be about 3; allow for the time-correlated samples and model approximations
    assert 0.3 < err.pos_nees[settled].mean() < 9.0
    heading_nees = (err.att[settled, 2] / err.heading_sigma[settled]) ** 2
    assert heading_nees.mean() < 4.0


def test_outage_coasts_with_growing_covariance(field):
    ekf, err = _run(field, 3, 2.0 + 0.5, outages=[(60.0, 70.0)])
    inside = (err.t > 60.2) & (err.t < 70.0)
    sigma = err.pos_sigma[inside]
    assert sigma[-1] > 5.0 * sigma[0]                               # INS-only: covariance grows
    drift = np.linalg.norm(err.pos[inside, :2], axis=1)
    assert drift[-1] < 5.0                                          # 10 s of MEMS coasting
    assert drift[-1] < 4.0 * sigma[-1]
    after = err.t > 72.0
    assert np.linalg.norm(err.pos[after, :2], axis=1).max() < 0.2  # recovers after the outage
    assert ekf.health()["gnss_age_s"] < 1.0


def test_jump_is_gated(field):
    def jump(gnss):
        for arrival, sample in gnss:
            if 50.0 <= sample.t < 52.0:
                sample.lat += 20.0 / 6.37e6                        # 20 m north jump for 2 s
    ekf, err = _run(field, 4, 2.5, tamper=jump)
    assert ekf.stats["rejected"].get("position", 0) >= 8
    window = (err.t > 50.0) & (err.t < 53.0)
    assert np.linalg.norm(err.pos[window, :2], axis=1).max() < 0.3


def test_realignment_takes_the_receivers_own_covariance(field):
    """Fixes moved 20 m for good are rejected until reinit_after, then the filter re-aligns on them: the receiver
    bias restarts at its share of the receiver's covariance (not of the white part left after the correction)."""
    from agnav_fusion.ins import error_model as em
    traj, (gyro, accel) = field
    rng = np.random.default_rng(4)
    g, a, _, _ = sy.MemsGrade().corrupt(gyro, accel, 0.01, rng)
    gnss = sy.gnss_samples(traj, gyro, LEVER, sy.RTK_5HZ, rng)
    for _, sample in gnss:
        if sample.t >= 40.0:
            sample.lat += 20.0 / 6.37e6
    ekf = InsEkf(InsEkfSettings(lever_gnss_frd=LEVER, initial_heading=2.5))
    initialize, started = ekf._initialize, []

    def spy(fix, *args):
        done = initialize(fix, *args)
        if done:
            started.append(ekf.p.diagonal()[em.GNSS_BIAS].copy())
        return done
    ekf._initialize = spy
    sy.run_ins(ekf, traj, g, a, gnss)
    assert ekf.stats["rejected"].get("reinitialized", 0) >= 1 and len(started) >= 2
    var_h = sy.RTK_5HZ.sigma_h ** 2 + sy.RTK_5HZ.bias_h ** 2
    np.testing.assert_allclose(started[-1][:2], ekf.s.gnss_bias.fraction * var_h, rtol=1e-9)


def test_bad_input_is_rejected():
    ekf = InsEkf()
    assert ekf.add_imu(1.0, [0, 0, 0], [0, 0, -9.8]) is None
    assert ekf.add_imu(1.0, [0, 0, 0], [0, 0, -9.8]) == "imu_stamp"
    assert ekf.add_imu(1.01, [math.nan, 0, 0], [0, 0, -9.8]) == "imu_nan"
    bad = sy.GnssSample(1.0, math.nan, 0.0, 0.0, np.eye(3))
    assert ekf.add_gnss(bad) == "gnss_nan"
    assert ekf.solution() is None                                   # unknown heading, not moving yet


@pytest.mark.parametrize("start,length", [(55.0, 0.11), (55.0, 1.5), (55.0, 2.0), (63.0, 2.0)])
def test_imu_gap_is_bridged_with_honest_covariance(field, start, length):
    """Missing IMU samples (on a straight pass; 63 s: in a headland turn) are bridged, not skipped: every error
    stays within 3 sigma, GNSS is accepted again at once and the run is back on the gap-free one."""
    gap = [(start, start + length)]
    clean_ekf, clean = _run(field, 5, 2.5)
    ekf, err = _run(field, 5, 2.5, imu_gaps=gap)
    settled = err.t > 30.0
    horizontal = np.linalg.norm(err.pos[settled, :2], axis=1)
    assert np.all(horizontal <= 3.0 * err.pos_sigma[settled])
    heading = np.abs(err.att[settled, 2])
    assert np.all(heading <= 3.0 * err.heading_sigma[settled])
    after = err.t >= start + length + 2.0
    same = np.isin(clean.t, err.t[after])
    assert np.abs(err.pos[after, :2] - clean.pos[same, :2]).max() < 0.1
    first = np.argmax(err.t > start + length)           # the bridged solution itself: sigma covers the error
    assert horizontal[np.argmax(err.t[settled] > start + length)] <= 3.0 * err.pos_sigma[first]
    assert ekf.stats["rejected"].get("position", 0) <= clean_ekf.stats["rejected"].get("position", 0)
    assert ekf.stats["bridged"] == {"imu_gap": 1}


def test_future_gnss_epoch_is_rejected():
    """An epoch far ahead of the IMU time is rejected instead of shutting out every later epoch."""
    ekf = InsEkf()
    for k in range(1, 11):
        ekf.add_imu(10.0 + 0.01 * k, [0, 0, 0], [0, 0, -9.8])
    fix = lambda t: sy.GnssSample(t, 0.7, 2.4, 10.0, np.eye(3) * 1e-4)  # noqa: E731
    assert ekf.add_gnss(fix(1010.0)) == "gnss_future"
    assert ekf.add_gnss(fix(10.05)) is None


def test_slow_receiver_error_at_10hz_stays_within_the_covariance(field):
    """A receiver whose error is mostly slow (0.3 m Gauss-Markov, 60 s) fixing at 10 Hz: with the bias states
    (gnss_bias.tau) the position stays within its covariance; fused as white, the filter averages the slow error
    down as if it were independent and grows overconfident."""
    from agnav_fusion.ins.gnss_bias import GnssBiasSettings
    traj, (gyro, accel) = field
    grade = sy.GnssGrade(rate=10.0, sigma_h=0.02, sigma_v=0.04, bias_h=0.3, bias_tau=60.0, fix_type=5)
    nees = {}
    for tau in (40.0, 0.0):
        rng = np.random.default_rng(7)
        g, a, _, _ = sy.MemsGrade().corrupt(gyro, accel, 0.01, rng)
        gnss = sy.gnss_samples(traj, gyro, LEVER, grade, rng)
        ekf = InsEkf(InsEkfSettings(lever_gnss_frd=LEVER, initial_heading=2.5,
                                    gnss_bias=GnssBiasSettings(tau=tau, fraction=0.95)))
        err = sy.run_ins(ekf, traj, g, a, gnss)
        nees[tau] = err.pos_nees[err.t > 30.0].mean()
    assert nees[40.0] < 6.0 and nees[0.0] > 30.0, nees     # 3-dof NEES: about 3 when honest
