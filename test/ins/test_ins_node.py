"""rclpy test of ins_node: the first 40 s of bags/mems_field (MEMS IMU + RTK, unknown start heading) published
in-process -> finite /odometry/filtered close to the truth, /imu/data, /map_datum; bad inputs counted."""
import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rclpy")

BAG = Path(__file__).resolve().parents[2] / "bags" / "mems_field"
TOPICS = ("/tf_static", "/map_datum", "/imu/data_raw", "/gnss/fix", "/gnss/vel", "/gnss/status", "/ground_truth/odometry")


def bag_messages(seconds):
    """[(topic, rclpy message)] of the bag's first `seconds`, in recording (arrival) order."""
    from rclpy.serialization import deserialize_message
    from rosbags.rosbag2 import Reader

    from agnav_drivers.ros_types import message_class

    out = []
    with Reader(BAG) as reader:
        conns = [c for c in reader.connections if c.topic in TOPICS]
        start = None
        for conn, ns, raw in reader.messages(connections=conns):
            start = ns if start is None and conn.topic != "/tf_static" else start
            if start is not None and ns - start > seconds * 1e9:
                break
            out.append((conn.topic, deserialize_message(raw, message_class(conn.msgtype))))
    return out


def spin(ex, n=3):
    for _ in range(n):
        ex.spin_once(timeout_sec=0.001)


def test_ins_node_tracks_the_simulated_run(ros):
    from nav_msgs.msg import Odometry
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import Imu, NavSatFix

    from agnav_common.qos import LATCHED_QOS, SENSOR_QOS
    from agnav_common.stamps import to_sec, to_stamp
    from agnav_fusion.ins_node import InsNode

    msgs = bag_messages(40.0)
    datum = next(m for topic, m in msgs if topic == "/map_datum")     # truth's map plane
    node = InsNode(parameter_overrides=[Parameter("datum", value=[datum.latitude, datum.longitude, datum.altitude])])
    src = ros.create_node("ins_test_source")
    got = {"/odometry/filtered": [], "/imu/data": [], "/map_datum": []}
    for topic, msg_type in (("/odometry/filtered", Odometry), ("/imu/data", Imu), ("/map_datum", NavSatFix)):
        src.create_subscription(msg_type, topic, got[topic].append, LATCHED_QOS if topic == "/map_datum" else SENSOR_QOS)
    types = {topic: type(msg) for topic, msg in msgs if topic not in ("/ground_truth/odometry", "/map_datum")}
    pubs = {topic: src.create_publisher(t, topic, LATCHED_QOS if topic == "/tf_static" else SENSOR_QOS)
            for topic, t in types.items()}
    truth = {}
    ex = SingleThreadedExecutor()
    ex.add_node(src)
    ex.add_node(node)
    spin(ex, 20)
    n_imu = 0
    for topic, msg in msgs:
        if topic == "/ground_truth/odometry":
            truth[round(to_sec(msg.header.stamp), 3)] = msg.pose.pose
        if topic not in pubs:
            continue
        pubs[topic].publish(msg)
        n_imu += topic == "/imu/data_raw"
        if topic == "/imu/data_raw" and n_imu == 2000:  # a poisoned sample 5 ms later, then a repeated one
            bad = Imu()
            bad.header.frame_id = msg.header.frame_id
            bad.header.stamp = to_stamp(to_sec(msg.header.stamp) + 0.005)
            bad.angular_velocity.x = math.nan
            spin(ex)
            pubs[topic].publish(bad)
            spin(ex)
            pubs[topic].publish(msg)
        spin(ex)
    spin(ex, 200)
    ex.shutdown()

    odoms = got["/odometry/filtered"]
    assert len(odoms) > 2000 and got["/imu/data"] and got["/map_datum"]
    assert odoms[-1].header.frame_id == "map" and odoms[-1].child_frame_id == "base_link"
    errors = []
    for o in odoms:
        values = [o.pose.pose.position.x, o.pose.pose.position.y, o.pose.pose.orientation.w, *o.pose.covariance,
                  *o.twist.covariance, o.twist.twist.linear.x]
        assert np.all(np.isfinite(values))
        p = truth[round(to_sec(o.header.stamp), 3)]
        errors.append(math.hypot(o.pose.pose.position.x - p.position.x, o.pose.pose.position.y - p.position.y))
    late = np.array(errors[-1000:])                 # last 10 s, after the in-motion alignment
    assert late.max() < 0.1
    assert node.guard.totals.get("imu_backwards_stamp") == 1      # the repeated sample
    assert node.guard.totals.get("imu_bad_value") == 1 and not node.ekf.stats["rejected"]   # never reaches the EKF
    h = node.check_filter()[2]
    assert h["mode"] == "gnss_aided" and h["gnss_epochs"] > 100
    node.destroy_node()
    src.destroy_node()


def test_ins_node_reports_missing_accelerometers(ros):
    from sensor_msgs.msg import Imu

    from agnav_common.diagnostics import ERROR
    from agnav_common.stamps import to_stamp
    from agnav_fusion.ins_node import InsNode

    node = InsNode()
    msg = Imu()
    msg.header.stamp = to_stamp(100.0)
    msg.linear_acceleration_covariance[0] = -1.0
    node.on_imu(msg)
    level, text, values = node.check_inputs()
    assert level == ERROR and "accelerometers" in text and values["no_accel"] == 1
    node.destroy_node()


def test_ins_node_checks_gnss_stamps_values_and_covariances(ros):
    """The front end's rules (InputGuard): NaN / negative / indefinite covariances are rejected, an all-zero one is
    the default until the receiver gave a good one and then that one, tiny ones too; NO_FIX fixes never used (not
    even as the datum), a lone fix far ahead of the IMU time rejected without shutting out the next ones; the inputs
    diagnostic shows each problem and forgets it after its window (IMU time)."""
    from geometry_msgs.msg import TwistWithCovarianceStamped
    from rclpy.parameter import Parameter
    from rclpy.time import Time
    from sensor_msgs.msg import Imu, NavSatFix
    from tf2_msgs.msg import TFMessage

    from agnav_common.diagnostics import OK, WARN
    from agnav_common.stamps import to_stamp
    from agnav_common.tf import make_transform
    from agnav_fusion.ins_node import InsNode

    node = InsNode(parameter_overrides=[Parameter("use_sim_time", value=True)])
    clock = node.get_clock()
    clock.set_ros_time_override(Time(seconds=100))
    node.tf.add(TFMessage(transforms=[
        make_transform("base_link", "imu_link", to_stamp(1.0), (0.0, 0.0, 0.5), (0.0, 0.0, 0.0, 1.0)),
        make_transform("base_link", "gnss_link", to_stamp(1.0), (0.0, 0.0, 2.0), (0.0, 0.0, 0.0, 1.0))]))
    imu = Imu()
    imu.header.stamp = to_stamp(100.0)
    imu.linear_acceleration.z = 9.8
    node.on_imu(imu)

    def fix(t, cov, status=0, lat=43.0, lon=141.0):
        m = NavSatFix()
        m.header.stamp = to_stamp(t)
        m.status.status = status
        m.latitude, m.longitude, m.altitude = lat, lon, 50.0
        m.position_covariance = [float(v) for v in np.ravel(cov)]
        m.position_covariance_type = NavSatFix.COVARIANCE_TYPE_KNOWN
        return m

    def vel(t, cov):
        m = TwistWithCovarianceStamped()
        m.header.stamp = to_stamp(t)
        c = np.zeros((6, 6))
        c[:3, :3] = cov
        m.twist.covariance = [float(v) for v in c.ravel()]
        return m

    good = np.eye(3) * 1e-4
    rejected = {"gnss_no_fix": fix(99.90, good, status=-1, lat=0.0, lon=0.0),
                "gnss_nan_covariance": fix(99.91, np.full((3, 3), math.nan)),
                "gnss_negative_covariance": fix(99.92, -good),
                "gnss_indefinite_covariance": fix(99.93, [[1e-4, 1e-3, 0], [1e-3, 1e-4, 0], [0, 0, 1e-4]]),
                "gnss_stamp_off_reference": fix(1100.0, good)}
    for name, msg in rejected.items():
        node.on_fix(msg)
        assert node.pending_fix is None, name
        assert node.guard.totals.get(name) == 1, name
    assert node.plane is None                       # the NO_FIX fix did not become the datum
    node.on_fix(fix(99.935, np.zeros((3, 3))))      # all zero: not given -> the default
    assert np.allclose(node.pending_fix.pos_cov_enu, np.eye(3) * node.default_fix_sigma ** 2)
    node.on_fix(fix(99.94, good * 2))               # a good one, then all zero and tiny ones: that one
    for t, cov in ((99.945, np.zeros((3, 3))), (99.95, np.diag([1e-9, 1e-4, 1e-4]))):
        node.on_fix(fix(t, cov))
        assert np.allclose(node.pending_fix.pos_cov_enu, good * 2)
    assert node.guard.totals.get("gnss_zero_covariance") == 1 and node.guard.totals["gnss_floored_covariance"] == 2

    for name, cov in (("vel_nan_covariance", np.full((3, 3), math.nan)), ("vel_negative_covariance", -good)):
        node.on_vel(vel(99.96 + 0.001 * len(node.guard.totals), cov))
        assert not node.velocities, name
        assert node.guard.totals.get(name) == 1, name
    node.on_vel(vel(99.98, np.zeros((3, 3))))
    node.on_vel(vel(99.99, np.diag([1e-4, 0.0, 1e-4])))
    assert np.allclose(node.velocities[0][2], np.eye(3) * node.default_vel_sigma ** 2)
    assert np.allclose(np.diag(node.velocities[1][2]), [1e-4, node.min_vel_sigma ** 2, 1e-4])

    level, message, values = node.check_inputs()
    assert level == WARN and "gnss_nan_covariance 1" in message and values["recent_gnss_no_fix"] == 1
    clock.set_ros_time_override(Time(seconds=106))  # the window has passed (IMU time): the old problems are gone
    for k in range(4):                              # (a step of 6 s is believed after 3 more stamps)
        imu.header.stamp = to_stamp(106.0 + 0.01 * k)
        imu.angular_velocity.x = 1e-3 * k
        node.on_imu(imu)
    level, message, values = node.check_inputs()   # what is left: no fix for 6 s, overdue
    assert values["total_gnss_no_fix"] == 1 and [k for k in values if k.startswith("recent_")] == \
        ["recent_gnss_overdue"] and level == WARN and "gnss_overdue 1" in message
    node.destroy_node()
