"""NavEKF (agnav extension of SPEC §6.3) and the RTS smoother over its log (kalman.smooth_log)."""
import math

import numpy as np

from agnav_fusion import kalman
from agnav_fusion.nav_ekf import IB, IPHI, NavEKF


def straight_run(seed=3, seconds=60.0, rate=50.0, bias=0.004):
    """1 m/s due north-east with a biased yaw gyro and 3 cm fixes at 1 Hz; returns the filter and the truth."""
    rng = np.random.default_rng(seed)
    ekf = NavEKF()
    heading = math.radians(45.0)
    ekf.initialise([0.0, 0.0], 9e-4 * np.eye(2), heading + 0.02, 1.0)
    ekf.log = []
    truth = []
    dt = 1.0 / rate
    for k in range(1, int(seconds * rate)):
        ekf.predict(bias + rng.normal(0, 0.002), dt)
        p = k * dt * np.array([math.sin(heading), math.cos(heading)])
        truth.append(p)
        if k % int(rate) == 0:
            y, S, _, H = ekf.position_innovation(p + rng.normal(0, 0.03, 2), 9e-4 * np.eye(2))
            ekf.update(y, S, H, 9e-4 * np.eye(2))
    return ekf, np.array(truth), heading


def test_bias_and_heading_converge():
    ekf, _, heading = straight_run()
    assert abs(ekf.x[IB] - 0.004) < 1e-3
    assert abs(math.remainder(ekf.x[IPHI] - heading, 2 * math.pi)) < math.radians(1.0)


def test_zero_rate_update_reads_the_bias():
    ekf = NavEKF()
    ekf.initialise([0.0, 0.0], np.eye(2), 0.0)
    for _ in range(500):
        ekf.predict(0.006, 0.01)
        y, S, H, R = ekf.zero_rate_innovation(0.006, 1e-4)
        ekf.update(y, S, H, R)
    assert abs(ekf.x[IB] - 0.006) < 5e-4


def test_rts_smoother_beats_the_filter():
    ekf, truth, heading = straight_run()
    filtered = np.array([entry[3][:2] for entry in ekf.log])
    smoothed = kalman.smooth_log(ekf.log, angles=(IPHI,))[0][:, :2]
    err_f = np.sqrt(np.mean(np.sum((filtered - truth) ** 2, axis=1)))
    err_s = np.sqrt(np.mean(np.sum((smoothed - truth) ** 2, axis=1)))
    assert err_s < 0.8 * err_f
