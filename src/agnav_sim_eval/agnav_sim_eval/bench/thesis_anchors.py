"""Open AHRS anchors and the offline RTS lower bound for `agnav bench thesis` (same simulated runs).

Anchors run on the module's own sensors: the gyros, and the two inclinometers (zero-corrected like the module's)
turned into the specific force a level-referenced accelerometer would read, g (-sin θ, sin φ cos θ, cos φ cos θ):
ahrs.filters.EKF and Madgwick (gyro + accelerometer; without a magnetometer their heading is relative: initialised
with the true first attitude), imufusion.Ahrs (xio Fusion;
absolute heading from the GNSS course over ground through update_external_heading while faster than 0.3 m/s,
gyro offset from its own stationary Bias estimator). The smoother replays the agnav module with GNSS fed at its
epoch (offline: no latency) and runs kalman.smooth_log over the attitude KFs and the navigation EKF.
"""
import math
import time

import numpy as np

from agnav_common.frames import euler_from_quaternion, quaternion_from_euler
from agnav_fusion import kalman
from agnav_fusion.nav_ekf import IPHI

GRAVITY = 9.80665
COURSE_SPEED = 0.3  # m/s, slower GNSS velocities give no course to imufusion


def _wxyz(roll, pitch, yaw):
    x, y, z, w = quaternion_from_euler(roll, pitch, yaw)
    return np.array([w, x, y, z])


def _euler(q_wxyz):
    w, x, y, z = q_wxyz
    return euler_from_quaternion(x, y, z, w)


def _base_imu(run, zero):
    """Gyro (rad/s) rotated into base_link and the inclinometer specific force (m/s^2), zero-corrected."""
    from agnav_sim_eval.bench.thesis import mount_rotation

    _, r = mount_rotation(run, "imu_link")
    roll, pitch = run.incl.roll - zero[0], run.incl.pitch - zero[1]
    force = GRAVITY * np.column_stack([-np.sin(pitch), np.sin(roll) * np.cos(pitch), np.cos(roll) * np.cos(pitch)])
    return run.imu.gyro @ r.T, force


def _ahrs_filter(run, zero, name):
    from ahrs.filters import EKF, Madgwick

    gyro, acc = _base_imu(run, zero)
    rate = run.imu_rate_hz
    tr = run.truth
    q = _wxyz(tr.roll[0], tr.pitch[0], tr.yaw[0])
    if name == "ahrs EKF":  # its ENU measurement model expects the gravity vector, i.e. minus the specific force
        f = EKF(frequency=rate, frame="ENU")
        step, acc = f.update, -acc
    else:
        f = Madgwick(frequency=rate)
        step = f.updateIMU
    out = np.empty((len(gyro), 3))
    start = time.perf_counter()
    for i in range(len(gyro)):
        q = step(q, gyro[i], acc[i])
        out[i] = _euler(q)
    us = (time.perf_counter() - start) / len(gyro) * 1e6
    return dict(roll=out[:, 0], pitch=out[:, 1], yaw=out[:, 2], us=us)


def _imufusion(run, zero):
    import imufusion

    gyro, acc = _base_imu(run, zero)
    rate = run.imu_rate_hz
    settings = imufusion.AhrsSettings()
    settings.convention = imufusion.CONVENTION_ENU
    settings.sample_rate = rate
    settings.acceleration_rejection = 10.0
    settings.rejection_timeout = int(5 * rate)
    ahrs = imufusion.Ahrs()
    ahrs.set_settings(settings)
    ahrs.set_sample_period(1.0 / rate)
    bias = imufusion.Bias()
    bias.set_settings(imufusion.BiasSettings(sample_rate=rate, stationary_threshold=3.0, stationary_period=3.0))
    g = run.gnss
    order = np.argsort(g.t_arrival)
    course, gi = None, 0
    out = np.empty((len(gyro), 3))
    start = time.perf_counter()
    for i, t in enumerate(run.imu.t):
        while gi < len(order) and g.t_arrival[order[gi]] <= t:
            v = g.vel[order[gi]]
            course = math.degrees(math.atan2(v[1], v[0])) if math.hypot(v[0], v[1]) > COURSE_SPEED else course
            gi += 1
        w = bias.update(np.degrees(gyro[i]))
        a = acc[i] / GRAVITY
        if course is None:
            ahrs.update_no_magnetometer(w, a)
        else:  # Fusion's ENU heading is the yaw minus 90 deg
            ahrs.update_external_heading(w, a, course - 90.0)
        out[i] = _euler(ahrs.get_quaternion())
    us = (time.perf_counter() - start) / len(gyro) * 1e6
    return dict(roll=out[:, 0], pitch=out[:, 1], yaw=out[:, 2], us=us)


def anchors(run, zero):
    """{name: estimate dict (roll, pitch, yaw REP-103 rad at IMU epochs, us per sample)}; zero: inclinometer
    (roll, pitch) zeros in rad."""
    return {"ahrs EKF": _ahrs_filter(run, zero, "ahrs EKF"), "ahrs Madgwick": _ahrs_filter(run, zero, "ahrs Madgwick"),
            "imufusion": _imufusion(run, zero)}


def _tail(filtered, smoothed, where=None):
    """The filter output with its last len(smoothed) samples (those the filter logged) replaced where `where`."""
    out = np.array(filtered, dtype=float)
    n = len(smoothed)
    if n:
        keep = slice(None) if where is None else where[-n:]
        out[-n:][keep] = np.asarray(smoothed)[keep]
    return out


def smoother(run, **overrides):
    """RTS lower bound: the agnav module replayed offline (GNSS at its epoch), then smoothed; estimate dict."""
    from agnav_sim_eval.bench.module_runs import run_module

    def enable_logs(nsm):
        e = nsm.estimator
        e.roll_filter.log, e.pitch_filter.log, e.ekf.log = [], [], []

    est = run_module(run, "agnav", latency=False, prepare=enable_logs, **overrides)
    nsm = est["module"].estimator
    # a run without tilt sensor logs no attitude filter step: its output stands
    roll, pitch = (kalman.smooth_log(f.log)[0][:, 0] if f.log else np.empty(0)
                   for f in (nsm.roll_filter, nsm.pitch_filter))
    nav = kalman.smooth_log(nsm.ekf.log, angles=(IPHI,))[0]
    yaw = np.remainder(math.pi / 2 - nav[:, IPHI] + math.pi, 2 * math.pi) - math.pi
    known = est["valid"]  # before the heading is initialised (its variance reset per fix) the filter output stands
    return dict(roll=_tail(est["roll"], roll), pitch=_tail(est["pitch"], -pitch), yaw=_tail(est["yaw"], yaw, known),
                x=_tail(est["x"], nav[:, 0], known), y=_tail(est["y"], nav[:, 1], known), valid=known)
