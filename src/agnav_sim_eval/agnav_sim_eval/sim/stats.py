"""Raw-sensor error statistics of a SimRun against its truth (the SPEC §10 baselines), ROS-free."""
import math

import numpy as np

from agnav_common.frames import rotation_matrix

DEG = 180.0 / math.pi


def _rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


def standstill(run):
    """Mask of the initial standstill (before the vehicle first moves)."""
    moving = np.flatnonzero(run.truth.speed > 0.0)
    first = moving[0] if moving.size else run.truth.t.size
    mask = np.zeros(run.truth.t.size, dtype=bool)
    mask[:first] = True
    return mask


def true_sensor_rates(run):
    """True body rates rotated into imu_link (N, 3) rad/s."""
    w = np.stack([run.truth.wx, run.truth.wy, run.truth.wz], axis=1)
    return w @ rotation_matrix(*run.mounts["imu_link"][1])


def integrated_gyro_errors(run):
    """Per-axis (x, y, z) r.m.s. and end error (deg) of the integrated raw gyro, zeroed by the standstill mean
    (V_static of (3.8), SPEC §4.1), against the integrated true rate; the thesis' 'gyro' rows of Table 5.4."""
    dt = 1.0 / run.imu_rate_hz
    still = standstill(run)
    v_static = run.imu.gyro[still].mean(axis=0) if still.any() else np.zeros(3)
    err = np.cumsum(run.imu.gyro - v_static - true_sensor_rates(run), axis=0) * dt * DEG
    return {"rms_deg": [_rms(e) for e in err.T], "end_deg": err[-1].tolist()}


def motion_bias(run):
    """Mean gyro error while moving minus the standstill mean (deg/s), per axis."""
    err = run.imu.gyro - true_sensor_rates(run)
    still = standstill(run)
    return ((err[~still].mean(axis=0) - err[still].mean(axis=0)) * DEG).tolist()


def gyro_noise(run):
    """Per-axis r.m.s. of the gyro error about its mean during the standstill (deg/s)."""
    err = (run.imu.gyro - true_sensor_rates(run))[standstill(run)]
    return (err.std(axis=0) * DEG).tolist()


def inclinometer_errors(run):
    """r.m.s. roll and pitch error (deg) of the raw inclinometer against the true attitude."""
    return {"roll_rms_deg": _rms(run.incl.roll - run.truth.roll) * DEG,
            "pitch_rms_deg": _rms(run.incl.pitch - run.truth.pitch) * DEG}


def gnss_position_errors(run):
    """Raw fix minus the true reference point below the antenna (base_link plus the lever arm turned by heading
    only, i.e. no tilt correction), horizontal: r.m.s., mean, max (cm); the 'GPS' rows of Table 5.4 and R4-6/7."""
    tr = run.truth
    x, y = (np.interp(run.gnss.t, tr.t, a) for a in (tr.x, tr.y))
    yaw = np.interp(run.gnss.t, tr.t, np.unwrap(tr.yaw))
    ax, ay = run.mounts["gnss_link"][0][:2]
    x = x + ax * np.cos(yaw) - ay * np.sin(yaw)
    y = y + ax * np.sin(yaw) + ay * np.cos(yaw)
    e = np.hypot(run.gnss.enu[:, 0] - x, run.gnss.enu[:, 1] - y) * 100
    return {"rms_cm": _rms(e), "mean_cm": float(e.mean()), "max_cm": float(e.max())}


def lever_arm(run):
    """Antenna lever arm recovered from the truth: mean of R^T (antenna - base_link) in base_link (m)."""
    out = []
    for t, p in zip(run.gnss.t, run.gnss.truth_enu):
        i = int(np.searchsorted(run.truth.t, t - 1e-9))
        tr = run.truth
        rot = rotation_matrix(tr.roll[i], tr.pitch[i], tr.yaw[i])
        out.append(rot.T @ (p - np.array([tr.x[i], tr.y[i], tr.z[i]])))
    return np.mean(out, axis=0).tolist()


def gnss_course_errors(run, min_speed=0.2):
    """Course over ground from successive fixes minus true yaw at the mid-epoch: r.m.s. (deg), moving only."""
    d = np.diff(run.gnss.enu[:, :2], axis=0)
    tm = 0.5 * (run.gnss.t[1:] + run.gnss.t[:-1])
    speed = np.interp(tm, run.truth.t, run.truth.speed)
    yaw = np.interp(tm, run.truth.t, np.unwrap(run.truth.yaw))
    err = np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - yaw)))[speed > min_speed]
    return {"rms_deg": _rms(err) * DEG}


def _level_field(run, roll, pitch):
    """Fluxgate field with hard iron and scale/misalignment removed, in the levelled base_link frame."""
    b = np.linalg.solve(run.extras["mag_matrix"], (run.mag.field - run.extras["mag_hard_iron"]).T).T
    b = b @ rotation_matrix(*run.mounts["mag_link"][1]).T
    out = np.empty_like(b)
    for i, (r, p) in enumerate(zip(roll, pitch)):
        out[i] = rotation_matrix(r, p, 0.0) @ b[i]
    return out


def gds_heading_errors(run, use_truth_tilt=False):
    """Tilt-compensated GDS yaw (true, with the WMM declination) minus true yaw: r.m.s., and r.m.s. about the
    mean (the heading-deviation error of R2-11) in deg; tilt from the inclination source unless use_truth_tilt."""
    src = run.truth if use_truth_tilt else run.incl
    roll = np.interp(run.mag.t, src.t, src.roll)
    pitch = np.interp(run.mag.t, src.t, src.pitch)
    b = _level_field(run, roll, pitch)
    decl = math.radians(run.extras["declination_deg"])
    yaw = (math.pi / 2 - decl) - np.arctan2(b[:, 1], b[:, 0])
    err = np.angle(np.exp(1j * (yaw - np.interp(run.mag.t, run.truth.t, np.unwrap(run.truth.yaw))))) * DEG
    return {"rms_deg": _rms(err), "deviation_rms_deg": float(np.std(err))}


def field_angles(run):
    """(declination, inclination) in deg measured from the calibrated, truth-levelled fluxgate field."""
    tr = run.truth
    b = _level_field(run, *(np.interp(run.mag.t, tr.t, a) for a in (tr.roll, tr.pitch)))
    yaw = np.interp(run.mag.t, tr.t, np.unwrap(tr.yaw))
    decl = np.angle(np.exp(1j * (math.pi / 2 - yaw - np.arctan2(b[:, 1], b[:, 0])))) * DEG
    incl = np.degrees(np.arctan2(-b[:, 2], np.hypot(b[:, 0], b[:, 1])))
    return float(np.median(decl)), float(np.median(incl))
