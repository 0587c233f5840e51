"""`agnav calibrate BAG`: two-way tilt-sensor zero calibration from a recorded set-up drive.

Procedure: park for 30 s, drive out, turn round, park for 30 s on the same spot facing the other way, all recorded
(/imu/data_raw, /inclinometer, /gnss/vel, /tf_static). Prints the zeros as the nav_sensor_module parameter
`incl_zero_deg` to paste into the graph config (--json for the whole result).
"""
import argparse
import json
import math
import sys
from dataclasses import asdict
from pathlib import Path

import numpy as np

from agnav_sim_eval.evaluate import read_bag
from agnav_common.bagio import typestore
from agnav_common.frames import euler_from_quaternion, rotation_matrix
from agnav_fusion.tilt_calibration import TiltCalibration


def mount_rotation(path, child):
    """base_link -> child rotation matrix from the bag's /tf_static (identity when absent)."""
    from rosbags.highlevel import AnyReader

    with AnyReader([Path(path)], default_typestore=typestore()) as reader:
        conns = [c for c in reader.connections if c.topic == "/tf_static"]
        for conn, _, raw in reader.messages(connections=conns):
            for tf in reader.deserialize(raw, conn.msgtype).transforms:
                if tf.child_frame_id == child:
                    q = tf.transform.rotation
                    return rotation_matrix(*euler_from_quaternion(q.x, q.y, q.z, q.w))
    return np.eye(3)


def calibrate_bag(path, calibration=None):
    """Feed a bag's speed, yaw rate and inclinometer into a TiltCalibration and solve it."""
    cal = calibration or TiltCalibration()
    data = read_bag(path, ["/imu/data_raw", "/inclinometer", "/gnss/vel"])
    if data["/imu/data_raw"]:
        rot = mount_rotation(path, data["/imu/data_raw"][0][1].header.frame_id)
        for t, m in data["/imu/data_raw"]:
            w = m.angular_velocity
            cal.yaw_rate(t, float((rot @ np.array([w.x, w.y, w.z]))[2]))
    for t, m in data["/inclinometer"]:
        cal.tilt(t, m.roll, m.pitch)
    for t, m in data["/gnss/vel"]:
        cal.speed(t, math.hypot(m.twist.twist.linear.x, m.twist.twist.linear.y))
    return cal.solve()


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
        print(json.dumps(asdict(res), indent=1))
        return 0
    deg = math.degrees
    print(f"parkings {res.first.start:.1f}-{res.first.end:.1f} s and {res.second.start:.1f}-{res.second.end:.1f} s, "
          f"turned {deg(res.turn):.1f}°; ground under the first: roll {deg(res.ground_roll):.2f}°, "
          f"pitch {deg(res.ground_pitch):.2f}°")
    print(f"incl_zero_deg: [{deg(res.roll_zero):.3f}, {deg(res.pitch_zero):.3f}]   # nav_sensor_module parameter")
    return 0
