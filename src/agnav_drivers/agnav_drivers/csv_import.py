"""`agnav_csv_import CSV OUT`: a VectorNav-style IMU + GPS CSV log -> rosbag2 (mcap) on the INTERFACES topics.

Input columns (one row per sample; IMU rows leave the GPS columns empty and vice versa): timestamp_sec_gps,
timestamp_nanosec_gps, timestamp_sec_imu, timestamp_nanosec_imu, latitude, longitude, altitude,
angular_velocity_{x,y,z} (rad/s), linear_acceleration_{x,y,z} (m/s^2), magnetic_field_{x,y,z} (T), in the sensor's
z-down body frame (FRD). Output: /imu/data_raw and /imu/mag in FLU (x, -y, -z; frame imu_link), /gnss/fix
(SBAS-less GPS, covariance from --gps-sigma), /tf_static with base_link->imu_link and ->gnss_link (identity, the
log gives no mounts). Messages are written at their stamps; --gps-time-offset shifts the GPS stamps onto the IMU
clock when the log's two clocks differ (nuance_car_circles: +4.8 s, the lag that best aligns the integrated gyro
yaw with the GPS course over ground).
"""
import argparse
import csv
import shutil
import sys
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode, StoragePlugin

from agnav_common.bagio import typestore
from agnav_common.qos import bag_profiles

FRD_TO_FLU = np.array([1.0, -1.0, -1.0])
TYPES = {"/imu/data_raw": "sensor_msgs/msg/Imu", "/imu/mag": "sensor_msgs/msg/MagneticField",
         "/gnss/fix": "sensor_msgs/msg/NavSatFix", "/tf_static": "tf2_msgs/msg/TFMessage"}


def _stamp(row, kind, offset_ns=0):
    sec, nsec = row[f"timestamp_sec_{kind}"], row[f"timestamp_nanosec_{kind}"]
    return int(float(sec)) * 1_000_000_000 + int(float(nsec)) + offset_ns if sec else None


def _vec3(row, prefix):
    return np.array([float(row[f"{prefix}_{a}"]) for a in "xyz"]) * FRD_TO_FLU


def convert(csv_path, out_dir, gps_sigma=2.5, gps_time_offset=0.0, overwrite=False):
    """Write the bag; returns {topic: count}."""
    ts = typestore()
    T = ts.types
    out = Path(out_dir)
    if out.exists():
        if not overwrite:
            raise FileExistsError(f"{out} exists (use --overwrite)")
        shutil.rmtree(out)

    def header(ns, frame):
        time = T["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
        return T["std_msgs/msg/Header"](stamp=time, frame_id=frame)

    def vector(v):
        return T["geometry_msgs/msg/Vector3"](x=float(v[0]), y=float(v[1]), z=float(v[2]))

    unit_quat = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
    unknown = np.zeros(9)
    rows = []
    with open(csv_path, newline="") as f:
        for row in csv.DictReader(f):
            if (ns := _stamp(row, "imu")) is not None:
                rows.append((ns, "/imu/data_raw", T["sensor_msgs/msg/Imu"](
                    header=header(ns, "imu_link"), orientation=unit_quat,
                    orientation_covariance=np.array([-1.0] + [0.0] * 8),
                    angular_velocity=vector(_vec3(row, "angular_velocity")), angular_velocity_covariance=unknown,
                    linear_acceleration=vector(_vec3(row, "linear_acceleration")),
                    linear_acceleration_covariance=unknown)))
                rows.append((ns, "/imu/mag", T["sensor_msgs/msg/MagneticField"](
                    header=header(ns, "imu_link"), magnetic_field=vector(_vec3(row, "magnetic_field")),
                    magnetic_field_covariance=unknown)))
            if (ns := _stamp(row, "gps", int(round(gps_time_offset * 1e9)))) is not None and row["latitude"]:
                status = T["sensor_msgs/msg/NavSatStatus"](status=0, service=1)  # STATUS_FIX, GPS
                rows.append((ns, "/gnss/fix", T["sensor_msgs/msg/NavSatFix"](
                    header=header(ns, "gnss_link"), status=status, latitude=float(row["latitude"]),
                    longitude=float(row["longitude"]), altitude=float(row["altitude"]),
                    position_covariance=np.diag([gps_sigma ** 2, gps_sigma ** 2, (2 * gps_sigma) ** 2]).ravel(),
                    position_covariance_type=1)))  # COVARIANCE_TYPE_APPROXIMATED
    rows.sort(key=lambda r: r[0])
    t0 = rows[0][0]
    mounts = [T["geometry_msgs/msg/TransformStamped"](
        header=header(t0, "base_link"), child_frame_id=child,
        transform=T["geometry_msgs/msg/Transform"](translation=vector((0, 0, 0)), rotation=unit_quat))
        for child in ("imu_link", "gnss_link")]
    rows.insert(0, (t0, "/tf_static", T["tf2_msgs/msg/TFMessage"](transforms=mounts)))
    counts = {}
    writer = Writer(out, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    with writer:
        conns = {topic: writer.add_connection(topic, msgtype, typestore=ts,
                                              offered_qos_profiles=bag_profiles(topic, None))
                 for topic, msgtype in TYPES.items()}
        for ns, topic, msg in rows:
            writer.write(conns[topic], ns, ts.serialize_cdr(msg, TYPES[topic]))
            counts[topic] = counts.get(topic, 0) + 1
    return counts


def main(argv=None):
    ap = argparse.ArgumentParser(prog="agnav_csv_import", description=__doc__.splitlines()[0])
    ap.add_argument("csv", help="input CSV log")
    ap.add_argument("out", help="output rosbag2 folder")
    ap.add_argument("--gps-sigma", type=float, default=2.5, help="GPS horizontal 1-sigma in m (default 2.5)")
    ap.add_argument("--gps-time-offset", type=float, default=0.0, help="s added to the GPS stamps (default 0)")
    ap.add_argument("--overwrite", action="store_true")
    args = ap.parse_args(sys.argv[1:] if argv is None else argv)
    counts = convert(args.csv, args.out, args.gps_sigma, args.gps_time_offset, args.overwrite)
    print(", ".join(f"{topic}: {n}" for topic, n in counts.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
