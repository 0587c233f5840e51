"""NavEKF (agnav extension of SPEC §6.3) and the RTS smoother over its log (kalman.smooth_log)."""
import math

import numpy as np

from agnav_fusion import kalman
from agnav_fusion.nav_ekf import IA, IB, IC, IK, IPHI, IR, IV, NavEKF, NavEKFSettings
from agnav_fusion.tilt_correction import lever_from_flu, offset_heading_jacobian


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


def test_receiver_bias_states_keep_the_position_covariance_honest():
    """Fixes with a slow receiver error (0.5 m offset) + 1.5 cm white: with bias states the position variance stays
    at the slow error's (the truth is 0.5 m off) while the heading comes from the track."""
    def run(settings):
        rng = np.random.default_rng(6)
        ekf = NavEKF(settings)
        heading, rate, cov = math.radians(30.0), 50, np.diag([0.25, 0.25])
        offset = np.array([0.5, 0.0])
        R, bias_var = ekf.split_fix_covariance(cov)
        ekf.initialise(offset, R, heading + 0.05, 0.5)
        for k in range(1, 120 * rate):
            ekf.predict(rng.normal(0, 0.002), 1.0 / rate)
            if k % rate == 0:
                p = 0.5 * k / rate * np.array([math.sin(heading), math.cos(heading)])
                R, bias_var = ekf.split_fix_covariance(cov)
                y, S, _, H = ekf.position_innovation(p + offset + rng.normal(0, 0.015, 2), R)
                ekf.update(y, S, H, R)
        return ekf, bias_var, abs(math.remainder(ekf.x[IPHI] - heading, 2 * math.pi))

    ekf, bias_var, heading_error = run(NavEKFSettings(gnss_bias_tau=300.0, gnss_white_sigma=0.015))
    assert bias_var == 0.25 - 0.015 ** 2
    assert math.sqrt(ekf.P[0, 0]) > 0.45 and heading_error < math.radians(0.2)


def test_receiver_error_class_rise_restarts_the_bias():
    """RTK fixed (1.2 cm) for 30 s, then float: the fixes jump by 20 cm and report 26 cm. The slow error is a new one
    (bias_changed, as on the drop back to fixed): the position keeps what it knew and its variance stays honest. Left
    at the fixed class's tiny bias variance, the first float fixes would pull the position 20 cm at a few cm sigma."""
    def run(restart):
        rng = np.random.default_rng(4)
        ekf = NavEKF(NavEKFSettings(gnss_bias_tau=40.0, gnss_white_sigma=0.01))
        heading, rate = math.radians(30.0), 50
        fixed, floating, jump = np.diag([1.2e-2 ** 2] * 2), np.diag([0.26 ** 2] * 2), np.array([0.2, 0.0])
        R, _ = ekf.split_fix_covariance(fixed)
        ekf.initialise([0.0, 0.0], R, heading, 1.0)
        worst = 0.0
        for k in range(1, 45 * rate):
            ekf.predict(rng.normal(0, 0.002), 1.0 / rate)
            if k % (rate // 5) == 0:
                t = k / rate
                p = t * np.array([math.sin(heading), math.cos(heading)])
                float_now = t >= 30.0
                R, _ = ekf.split_fix_covariance(floating if float_now else fixed)
                if ekf.bias_changed and restart:
                    ekf.restart_bias()
                y, S, _, H = ekf.position_innovation(p + (jump if float_now else 0.0) + rng.normal(0, 0.01, 2), R)
                ekf.update(y, S, H, R)
                if float_now:
                    worst = max(worst, abs(ekf.x[0] - p[0]) / math.sqrt(ekf.P[0, 0]))
        return worst

    assert run(restart=True) < 3.0 < run(restart=False)


def test_an_overdue_fix_forgets_the_acceleration_the_fixes_gave():
    """forget_acceleration: A back to its prior (0, stationary variance, uncorrelated); V keeps what it knew. In
    accelerometer mode A is the accelerometer's bias, which the IMU keeps measuring: left alone."""
    ekf = NavEKF()
    ekf.initialise([0.0, 0.0], 1e-4 * np.eye(2), 0.0, 1.0)
    ekf.x[IA], ekf.P[IA, IV] = 0.04, 1e-3
    ekf.P[IV, IA] = 1e-3
    speed, speed_var = ekf.x[IV], ekf.P[IV, IV]
    ekf.forget_acceleration()
    s = ekf.settings
    assert ekf.x[IA] == 0.0 and ekf.P[IA, IA] == s.jerk_noise ** 2 * s.accel_tau / 2.0
    assert not np.any(np.delete(ekf.P[IA], IA)) and not np.any(np.delete(ekf.P[:, IA], IA))
    assert ekf.x[IV] == speed and ekf.P[IV, IV] == speed_var
    ekf.set_accel_mode(True)
    ekf.x[IA] = 0.02
    ekf.forget_acceleration()
    assert ekf.x[IA] == 0.02


def test_coasting_does_not_extrapolate_an_unconfirmed_acceleration():
    """Fixes stop while the speed model holds a small acceleration (fix noise): coasting, it decays with
    coast_accel_tau, so the speed stays near its last value; A keeps its stationary variance, and V's 3 sigma after
    30 s still covers a stop from the speed held (1 m/s)."""
    speed, variance = {}, {}
    for coasting in (False, True):
        ekf = NavEKF()
        ekf.initialise([0.0, 0.0], 1e-4 * np.eye(2), 0.0, 1.0)
        ekf.x[IA] = 0.04
        for _ in range(3000):                      # 30 s at 100 Hz
            ekf.predict(0.0, 0.01, coasting=coasting)
        speed[coasting], variance[coasting] = ekf.x[IV] - 1.0, ekf.P[IV, IV]
    s = NavEKFSettings()
    assert speed[False] > 0.9 * 0.04 * s.accel_tau and speed[True] < 1.1 * 0.04 * s.coast_accel_tau, speed
    assert 3.0 * math.sqrt(variance[True]) > 1.0, variance


def test_braking_ends_at_rest_and_only_a_measurement_reverses():
    """The speed model's deceleration stops at zero speed (a braking tractor does not drive on backwards until the
    next fix), where the acceleration ends too; a speed already negative (a fix said reversing) is propagated as
    before, and so is any speed in accelerometer mode (the accelerometer reads the stop)."""
    ekf = NavEKF()
    ekf.initialise([0.0, 0.0], 1e-4 * np.eye(2), 0.0, 0.3)
    ekf.x[IA] = -0.5
    for _ in range(100):  # 1 s at 100 Hz: 0.3 m/s at -0.5 m/s^2 would end at -0.2 m/s
        ekf.predict(0.0, 0.01)
    assert ekf.x[IV] == 0.0 and ekf.x[IA] == 0.0
    stop = ekf.x[1]
    assert 0.09 < stop < 0.1  # the braking's distance (A decays with accel_tau: a little over 0.3^2 / (2 x 0.5))
    for _ in range(100):
        ekf.predict(0.0, 0.01)
    assert ekf.x[1] == stop and ekf.x[IV] == 0.0
    ekf.x[IV], ekf.x[IA] = -0.1, -0.2
    ekf.predict(0.0, 0.01)
    assert ekf.x[IV] < -0.1
    ekf.set_accel_mode(True)
    ekf.x[IV], ekf.x[IA] = 0.001, 0.0
    ekf.predict(0.0, 0.01, accel=-0.5)
    assert ekf.x[IV] < 0.0


def test_a_position_reset_keeps_the_antenna_lever_tied_to_the_heading():
    """A fix moved to base_link with the estimated heading carries that heading's error through the antenna lever.
    Reset there with the lever's heading Jacobian, the position shares it: the antenna is uncorrelated with the
    heading and crab, so a later fix (whatever its innovation) does not move the heading, which it does not observe
    on its own. Without the Jacobian the same fix turned the heading (the steer bench's dgps_slope_crab start)."""
    jac = offset_heading_jacobian(lever_from_flu((-1.67, 0.0, 3.23)), 0.3, 0.0, math.radians(5.0))
    moved = {}
    for with_jacobian in (True, False):
        ekf = NavEKF(NavEKFSettings(crab_roll_gain=0.2))
        ekf.initialise([0.0, 0.0], 4e-4 * np.eye(2), 0.3, 1.5)
        ekf.x[IR] = math.radians(5.0)  # terrain roll: the crab model k sin(roll) is live
        ekf.P[IPHI, IPHI] = math.radians(0.5) ** 2
        # the course is known, the heading = course - crab (as the chord start sets it)
        ekf.P[IPHI, IK] = ekf.P[IK, IPHI] = -ekf.P[IK, IK] * math.sin(ekf.x[IR])
        R = 4e-4 * np.eye(2)
        ekf.reset_position([0.0, 0.0], R, jac if with_jacobian else None)
        P = ekf.P
        antenna_heading = P[:2, IPHI] + jac * P[IPHI, IPHI]  # Cov(position + jac heading, heading)
        if with_jacobian:
            np.testing.assert_allclose(antenna_heading, 0.0, atol=1e-15)
        before = ekf.x[[IPHI, IC, IK]].copy()
        y, S, _, H = ekf.position_innovation([0.05, -0.12], R, jac)
        ekf.update(y, S, H, R)
        moved[with_jacobian] = np.abs(ekf.x[[IPHI, IC, IK]] - before)
    assert np.all(moved[True] < 1e-12)
    assert moved[False][0] > math.radians(0.2) and moved[False][2] > 0.05
