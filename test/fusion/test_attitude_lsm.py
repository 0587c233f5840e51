"""Attitude LSM (SPEC eq 5.1-5.11), the drift LSM it builds on, and the agnav attitude KF on synthetic signals."""
import math

import numpy as np

from agnav_fusion.attitude_kf import AttitudeKF
from agnav_fusion.attitude_lsm import AttitudeLSM, AttitudeLSMSettings
from agnav_fusion.drift_lsm import WindowDriftLSM

DT = 0.01
DEG = math.pi / 180.0


def synthetic(seed=3, seconds=120.0, bias=0.1 * DEG, tau=1.1):
    """Roll: standstill 10 s then undulation; gyro = rate + constant bias + noise; inclinometer = lag + noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, DT)
    truth = np.where(t < 10, 0.02, 0.02 + 3 * DEG * np.sin(0.4 * (t - 10)) * (1 - np.exp(-(t - 10).clip(0))))
    rate = np.gradient(truth, DT)
    gyro = rate + bias + rng.normal(0, 0.2 * DEG, t.size)
    lagged = np.empty_like(truth)
    lagged[0] = truth[0]
    for k in range(1, t.size):
        lagged[k] = lagged[k - 1] + DT / tau * (truth[k - 1] - lagged[k - 1])
    incl = lagged + rng.normal(0, 0.3 * DEG, t.size)
    return t, truth, gyro, incl


def test_drift_lsm_recovers_constant_bias_exactly():
    lsm = WindowDriftLSM(window=270, delay=0)
    angle = 0.0
    for k in range(1000):
        rate = 0.3 * math.cos(0.01 * k)
        angle += rate * DT
        d = lsm.update(rate + 0.002, angle, DT)  # gyro reads rate + bias; ref is the true angle
    assert abs(d + 0.002) < 1e-12


def test_drift_lsm_with_reference_delay():
    delay = 50
    lsm = WindowDriftLSM(window=200, delay=delay)
    angles = [0.0]
    for k in range(1000):
        rate = 0.2 * math.sin(0.02 * k)
        angles.append(angles[-1] + rate * DT)
        ref = angles[max(0, len(angles) - 1 - delay)]  # reference lags by `delay` samples
        d = lsm.update(rate - 0.003, ref, DT)
    assert abs(d - 0.003) < 1e-9


def test_drift_lsm_circular_reference():
    lsm = WindowDriftLSM(window=20, circular=True)
    heading = 3.0
    for _ in range(200):
        heading += 0.1
        d = lsm.update(10.0 + 0.05, math.remainder(heading, 2 * math.pi), 0.01)  # gyro 10 rad/s + 0.05 bias
    assert abs(d + 0.05) < 1e-9


def rms(a):
    return float(np.sqrt(np.mean(np.square(a))))


def test_attitude_lsm_beats_raw_sensors():
    t, truth, gyro, incl = synthetic()
    lsm = AttitudeLSM(AttitudeLSMSettings(window=270, delay=110))
    est, drift = np.array([(lsm.update(g, z, DT), lsm.drift) for g, z in zip(gyro, incl)]).T
    raw_gyro = truth[0] + np.cumsum(gyro) * DT
    late = t > 20
    err = rms(est[late] - truth[late])
    assert err < 0.5 * rms(incl[late] - truth[late])
    assert err < 0.2 * rms(raw_gyro[late] - truth[late])
    assert abs(np.mean(drift[late]) + 0.1 * DEG) < 0.02 * DEG  # d is the additive correction: -bias


def test_attitude_kf_estimates_bias_and_angle():
    t, truth, gyro, incl = synthetic()
    kf = AttitudeKF()
    est = np.array([kf.update(g, z, DT) for g, z in zip(gyro, incl)])
    late = t > 20
    assert rms(est[late] - truth[late]) < 0.25 * rms(incl[late] - truth[late])
    assert abs(kf.bias - 0.1 * DEG) < 0.03 * DEG
    assert 0 < kf.variance < (1 * DEG) ** 2


def test_attitude_kf_runs_on_gyro_alone_with_growing_variance():
    t, truth, gyro, incl = synthetic(seconds=40)
    kf = AttitudeKF()
    for g, z in zip(gyro[:2000], incl[:2000]):
        kf.update(g, z, DT)
    v0 = kf.variance
    for g in gyro[2000:]:
        kf.update(g, None, DT)
    assert kf.variance > v0
