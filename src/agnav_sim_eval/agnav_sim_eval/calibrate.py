"""`agnav calibrate BAG`: two-way tilt-sensor zero calibration from a recorded set-up drive.

Procedure: park for 30 s, drive out, turn round, park for 30 s on the same spot facing the other way, all recorded
(/imu/data_raw, /inclinometer, /gnss/vel, /tf_static). Prints the inclinometer's zeros as the nav_sensor_module
parameter `incl_zero_deg`, and, for an IMU with accelerometers, its level: the imu_link mount of /tf_static turned
by the zero of the accelerometers' tilt (mount tilt beyond the bracket's nominal one and the bias across and along
the vehicle, which a GNSS/INS cannot tell from roll and pitch on straight runs), to paste into the graph config's
static_transforms (--json for the whole result).
"""
import argparse
import json
import math
import sys
from dataclasses import asdict

import numpy as np

from scipy.spatial.transform import Rotation

from agnav_sim_eval.evaluate import read_bag
from agnav_common.bagio import static_transforms
from agnav_common.frames import rotation_matrix
from agnav_fusion.pipeline import accelerometer_tilt
from agnav_fusion.tilt_calibration import TiltCalibration


def mount(path, child):
    """base_link -> child translation and rotation matrix from the bag's /tf_static (zero, identity when absent)."""
    for tf in static_transforms(path):
        if tf["child"] == child:
            return tuple(tf["xyz"]), rotation_matrix(*tf["rpy"])
    return (0.0, 0.0, 0.0), np.eye(3)


def calibrate_bag(path):
    """{"inclinometer": TiltCalibrationResult, "imu": TiltCalibrationResult of the accelerometers' tilt} of a bag
    (a sensor the bag lacks: None; ValueError when neither solves), "imu_link": (xyz, rpy rad) of the levelled
    mount (with "imu")."""
    data = read_bag(path, ["/imu/data_raw", "/inclinometer", "/gnss/vel"])
    incl, acc = TiltCalibration(), TiltCalibration()
    imu = data["/imu/data_raw"]
    frame = imu[0][1].header.frame_id if imu else "imu_link"
    xyz, rot = mount(path, frame)
    accel = bool(imu) and imu[0][1].linear_acceleration_covariance[0] != -1.0     # REP-145: -1 = none
    for t, m in imu:
        w, f = m.angular_velocity, m.linear_acceleration
        for cal in (incl, acc):
            cal.yaw_rate(t, float((rot @ np.array([w.x, w.y, w.z]))[2]))
        if accel:
            acc.tilt(t, *accelerometer_tilt(rot @ np.array([f.x, f.y, f.z])))
    for t, m in data["/inclinometer"]:
        incl.tilt(t, m.roll, m.pitch)
    for t, m in data["/gnss/vel"]:
        for cal in (incl, acc):
            cal.speed(t, math.hypot(m.twist.twist.linear.x, m.twist.twist.linear.y))
    out, errors = {}, []
    for name, cal, present in (("inclinometer", incl, bool(data["/inclinometer"])), ("imu", acc, accel)):
        try:
            out[name] = cal.solve() if present else None
        except ValueError as err:
            out[name] = None
            errors.append(str(err))
    if not any(out.values()):
        raise ValueError(errors[0] if errors else "no /inclinometer and no /imu/data_raw with accelerometers")
    if out["imu"]:      # the zero's tilt taken out of the mount: f_base = R_zero R_mount f_imu
        level = rotation_matrix(out["imu"].roll_zero, out["imu"].pitch_zero, 0.0) @ rot
        out["imu_link"] = (xyz, tuple(Rotation.from_matrix(level).as_euler("xyz")))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(prog="agnav calibrate", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("bag", help="recorded calibration drive (rosbag2 directory or ROS 1 .bag)")
    ap.add_argument("--json", action="store_true", help="print the whole result as JSON")
    args = ap.parse_args(argv)
    try:
        res = calibrate_bag(args.bag)
    except ValueError as err:
        print(f"agnav calibrate: {err}", file=sys.stderr)
        return 1
    if args.json:
        print(json.dumps({k: asdict(v) if k != "imu_link" and v else v for k, v in res.items()}, indent=1))
        return 0
    deg = math.degrees
    for name, r in (("inclinometer", res["inclinometer"]), ("IMU accelerometers", res["imu"])):
        if r:
            print(f"{name}: parkings {r.first.start:.1f}-{r.first.end:.1f} s and {r.second.start:.1f}-"
                  f"{r.second.end:.1f} s, turned {deg(r.turn):.1f}°; ground under the first: roll "
                  f"{deg(r.ground_roll):.2f}°, pitch {deg(r.ground_pitch):.2f}°; zero roll {deg(r.roll_zero):.3f}°, "
                  f"pitch {deg(r.pitch_zero):.3f}°")
    if res["inclinometer"]:
        r = res["inclinometer"]
        print(f"incl_zero_deg: [{deg(r.roll_zero):.3f}, {deg(r.pitch_zero):.3f}]   # nav_sensor_module parameter")
    if res["imu"]:
        xyz, rpy = res["imu_link"]
        print(f"- {{parent: base_link, child: imu_link, xyz: [{', '.join(f'{v:g}' for v in xyz)}], "
              f"rpy: [{', '.join(f'{v:.6f}' for v in rpy)}]}}   # static_transforms: the IMU levelled")
    return 0
