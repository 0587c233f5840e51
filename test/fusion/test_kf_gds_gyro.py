"""GDS + gyro Kalman filter (SPEC §3.5) on a synthetic constant gyro drift with a noisy GDS."""
import math

import numpy as np

from agnav_fusion.gds_gyro_kf import GdsGyroKalmanFilter, KfSettings
from synthetic_heading import rms_deg, straight_run


def _run(run, settings=None, speed=0.5):
    kf = GdsGyroKalmanFilter(settings)
    est, lateral = [], []
    for k in range(run.t.size):
        if kf.x is not None:
            est.append(kf.heading)
            lateral.append(kf.x[0])
        kf.update(run.gds[k], run.gyro[k], run.gyro_rate[k], speed * run.dt, run.dt)
    return kf, np.array(est), np.array(lateral)


def test_kf_beats_both_sensors_under_constant_drift():
    run = straight_run(seed=2, duration=80.0, dt=0.1, bias_deg_s=0.2 / 80, offset_deg=0.3)
    kf, est, _ = _run(run)
    err_kf = rms_deg(est - run.true[1:])
    assert err_kf < 0.5 * rms_deg(run.gds - run.true)
    assert err_kf < 0.5 * rms_deg(run.gyro - run.true)
    # μ = sin δ with δ = true − gyro: the offset plus the accumulated drift
    delta_end = run.true[-1] - run.gyro[-1]
    assert abs(math.asin(kf.x[2]) - delta_end) < math.radians(0.15)


def test_kf_lateral_state_follows_dead_reckoned_truth():
    run = straight_run(seed=4, duration=80.0, dt=0.1, bias_deg_s=0.005)
    _, est, lateral = _run(run)
    target = run.gds[0]
    true_lateral = np.cumsum(0.5 * run.dt * np.sin(run.true - target))[:-1]
    gyro_lateral = np.cumsum(0.5 * run.dt * np.sin(run.gyro - target))[:-1]
    assert np.sqrt(np.mean((lateral - true_lateral) ** 2)) < 0.5 * np.sqrt(np.mean((gyro_lateral - true_lateral) ** 2))


def test_kf_retargets_after_a_turn_and_keeps_tracking():
    run = straight_run(seed=5, duration=60.0, dt=0.1, bias_deg_s=0.01)
    turn = np.clip((run.t - 20.0) / 10.0, 0.0, 1.0) * math.radians(90.0)   # 90° right turn at 20–30 s
    run.true, run.gds, run.gyro = run.true + turn, run.gds + turn, run.gyro + turn
    run.gyro_rate = run.gyro_rate + np.gradient(turn, run.dt)
    kf, est, _ = _run(run, KfSettings(drift_noise=1e-7))    # growing drift: the [IMPL] μ random walk
    assert abs(kf.target - run.true[0]) > math.radians(60)
    assert rms_deg(est[-100:] - run.true[-100:]) < 0.3
    assert np.all(np.isfinite(est))
