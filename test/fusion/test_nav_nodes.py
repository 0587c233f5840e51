"""rclpy test of the navigation nodes: synthetic sensors in, finite Odometry / Imu / corrected fix out."""
import math

import numpy as np
import pytest

pytest.importorskip("rclpy")

from agnav_common.geodesy import LocalTangentPlane  # noqa: E402
from agnav_common.stamps import to_stamp  # noqa: E402
from agnav_common.tf import StaticTransformPublisher, make_transform  # noqa: E402

DATUM = (43.0, 141.0, 50.0)


def feed(ros, node, extra_topics, seconds=12.0):
    """Publish TF mounts, 50 Hz IMU/inclinometer and 1 Hz fixes of a straight 1 m/s drive north-east."""
    from agnav_msgs.msg import Inclination
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import Imu, NavSatFix, NavSatStatus

    from agnav_common.qos import SENSOR_QOS

    src = ros.create_node("nav_test_source")
    got = {topic: [] for topic in extra_topics}
    for topic, msg_type in extra_topics.items():
        src.create_subscription(msg_type, topic, got[topic].append, SENSOR_QOS)
    StaticTransformPublisher(src).send([
        make_transform("base_link", "imu_link", to_stamp(1.0), (0.3, 0.0, 1.0), (0.0, 0.0, 0.0, 1.0)),
        make_transform("base_link", "gnss_link", to_stamp(1.0), (0.0, 0.0, 2.0), (0.0, 0.0, 0.0, 1.0))])
    imu_pub = src.create_publisher(Imu, "/imu/data_raw", SENSOR_QOS)
    incl_pub = src.create_publisher(Inclination, "/inclinometer", SENSOR_QOS)
    fix_pub = src.create_publisher(NavSatFix, "/gnss/fix", SENSOR_QOS)
    ex = SingleThreadedExecutor()
    ex.add_node(src)
    ex.add_node(node)
    for _ in range(20):
        ex.spin_once(timeout_sec=0.05)
    plane = LocalTangentPlane(*DATUM)
    yaw = math.pi / 4
    for k in range(1, int(seconds * 50)):
        t = 100.0 + k / 50.0
        if k % 50 == 0:
            lat, lon, alt = plane.to_geodetic(t - 100.0, t - 100.0, 2.0)
            fix = NavSatFix(latitude=float(lat), longitude=float(lon), altitude=float(alt))
            fix.header.stamp = to_stamp(t)
            fix.status.status = NavSatStatus.STATUS_SBAS_FIX
            fix.position_covariance = [4e-4, 0, 0, 0, 4e-4, 0, 0, 0, 1e-3]
            fix.position_covariance_type = NavSatFix.COVARIANCE_TYPE_KNOWN
            fix_pub.publish(fix)
        imu = Imu()
        imu.header.stamp = to_stamp(t)
        # a sensor's noise (a bit-identical repeated reading is a stuck IMU), and one poisoned sample
        imu.angular_velocity.z = 0.001 + 1e-5 * math.sin(k) if k != 300 else math.nan
        imu_pub.publish(imu)
        incl = Inclination(roll=0.0, pitch=0.0)
        incl.header.stamp = to_stamp(t)
        incl_pub.publish(incl)
        for _ in range(8):  # deliver everything: keep-last queues would drop a burst
            ex.spin_once(timeout_sec=0.001)
    for _ in range(50):
        ex.spin_once(timeout_sec=0.01)
    ex.shutdown()
    src.destroy_node()
    return got, yaw


def test_nav_sensor_module_node_publishes_finite_odometry(ros):
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import NavSatFix

    from agnav_fusion.nav_sensor_module_node import NavSensorModuleNode

    node = NavSensorModuleNode()
    got, _ = feed(ros, node, {"/odometry/filtered": Odometry, "/map_datum": NavSatFix})
    odoms = got["/odometry/filtered"]
    assert len(odoms) > 200 and got["/map_datum"]
    last = odoms[-1]
    assert last.header.frame_id == "map" and last.child_frame_id == "base_link"
    values = [last.pose.pose.position.x, last.pose.pose.position.y, *last.pose.covariance, *last.twist.covariance]
    assert np.all(np.isfinite(values))
    assert node.backend.counters["imu_bad_value"] == 1
    node.destroy_node()


def test_attitude_node_publishes_level_orientation(ros):
    from sensor_msgs.msg import Imu

    from agnav_fusion.attitude_node import AttitudeNode

    node = AttitudeNode()
    got, _ = feed(ros, node, {"/imu/data": Imu}, seconds=6.0)
    msgs = got["/imu/data"]
    assert len(msgs) > 200
    q = msgs[-1].orientation
    assert abs(q.x) < 0.01 and abs(q.y) < 0.01
    assert 0 < msgs[-1].orientation_covariance[0] < 1e-3
    node.destroy_node()


def test_accelerometer_tilt_recovers_a_known_attitude():
    from agnav_common.frames import rotation_matrix

    from agnav_fusion.pipeline import accelerometer_tilt

    for roll, pitch in ((0.1, -0.2), (-0.3, 0.05), (0.0, 0.0)):
        f = rotation_matrix(roll, pitch, 1.0).T @ np.array([0.0, 0.0, 9.81])  # specific force at rest, FLU
        assert np.allclose(accelerometer_tilt(f), (roll, pitch), atol=1e-12)
