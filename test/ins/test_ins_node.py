"""rclpy test of ins_node (nav_sensor_module_node with the `ins` backend): the first 40 s of bags/mems_field (MEMS
IMU + RTK, unknown start heading) published in-process -> finite /odometry/filtered close to the truth, /imu/data,
/map_datum; bad inputs counted."""
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
    guard = node.backend.guard
    assert guard.totals.get("imu_backwards_stamp") == 1      # the repeated sample
    assert guard.totals.get("imu_bad_value") == 1 and not node.backend.ekf.stats["rejected"]   # never reaches the EKF
    h = node.check_state()[2]
    assert h["mode"] == "gnss_aided" and h["gnss_epochs"] > 100
    node.destroy_node()
    src.destroy_node()


def test_ins_node_reports_missing_accelerometers(ros):
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import Imu

    from agnav_common.diagnostics import ERROR
    from agnav_common.stamps import to_stamp
    from agnav_fusion.ins_node import InsNode
    from agnav_fusion.nav_sensor_module_node import NavSensorModuleNode

    for node in (InsNode(), NavSensorModuleNode(parameter_overrides=[Parameter("estimator", value="ins")])):
        msg = Imu()
        msg.header.stamp = to_stamp(100.0)
        msg.linear_acceleration_covariance[0] = -1.0
        node.on_imu(msg)
        level, text, values = node.check_inputs()
        assert level == ERROR and "accelerometer" in text and values["imu_no_accel"] == 1
        node.destroy_node()


def test_ins_node_checks_gnss_stamps_values_and_covariances(ros):
    """The front end's rules (InputGuard): NaN / negative / indefinite covariances are rejected, an all-zero one is
    the default until the receiver gave a good one and then that one, tiny ones too; NO_FIX fixes never used (not
    even as the datum), a lone fix far ahead of the IMU time rejected without shutting out the next ones; a velocity
    with a bad covariance dropped (its fix used alone), an all-zero one the default, small variances raised; the
    inputs diagnostic shows each problem and forgets it after its window (IMU time)."""
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

    fused = []                                      # the GNSS epochs that reach the filter
    add_gnss = node.backend.ekf.add_gnss
    node.backend.ekf.add_gnss = lambda g: (fused.append(g), add_gnss(g))[1]
    good = np.eye(3) * 1e-4
    guard = node.backend.guard
    rejected = {"gnss_no_fix": fix(98.30, good, status=-1, lat=0.0, lon=0.0),
                "gnss_nan_covariance": fix(98.31, np.full((3, 3), math.nan)),
                "gnss_negative_covariance": fix(98.32, -good),
                "gnss_indefinite_covariance": fix(98.33, [[1e-4, 1e-3, 0], [1e-3, 1e-4, 0], [0, 0, 1e-4]]),
                "gnss_stamp_off_reference": fix(1100.0, good)}
    for name, msg in rejected.items():
        node.pipeline.on_fix(msg)
        assert not fused, name
        assert guard.totals.get(name) == 1, name
        if name == "gnss_no_fix":
            assert node.pipeline.plane is None      # the NO_FIX fix did not become the datum
    node.pipeline.on_fix(fix(98.35, np.zeros((3, 3))))      # all zero: not given -> the default
    assert np.allclose(fused[-1].pos_cov_enu, np.eye(3) * node.backend.settings.default_fix_sigma ** 2)
    node.pipeline.on_fix(fix(98.40, good * 2))               # a good one, then all zero and tiny ones: that one
    for t, cov in ((98.45, np.zeros((3, 3))), (98.50, np.diag([1e-9, 1e-4, 1e-4]))):
        node.pipeline.on_fix(fix(t, cov))
        assert np.allclose(fused[-1].pos_cov_enu, good * 2)
    assert guard.totals.get("gnss_zero_covariance") == 1 and guard.totals["gnss_floored_covariance"] == 2

    settings = node.backend.settings                # velocities go to the filter with the fix of their epoch
    for t, name, cov in ((98.8, "vel_nan_covariance", np.full((3, 3), math.nan)),
                         (99.0, "vel_negative_covariance", -good)):
        node.pipeline.on_velocity(vel(t, cov))
        node.pipeline.on_fix(fix(t, good))
        assert fused[-1].t == t and fused[-1].vel_enu is None, name
        assert guard.totals.get(name) == 1, name
    for t, cov in ((99.2, np.zeros((3, 3))), (99.4, np.diag([1e-4, 0.0, 1e-4]))):
        node.pipeline.on_velocity(vel(t, cov))
        node.pipeline.on_fix(fix(t, good))
    assert np.allclose(fused[-2].vel_cov_enu, np.eye(3) * settings.default_vel_sigma ** 2)
    assert np.allclose(np.diag(fused[-1].vel_cov_enu), [1e-4, settings.min_vel_sigma ** 2, 1e-4])

    level, message, values = node.check_inputs()
    assert level == WARN and "1 gnss_nan_covariance" in message and values["recent_gnss_no_fix"] == 1
    clock.set_ros_time_override(Time(seconds=106))  # the window has passed (IMU time): the old problems are gone
    for k in range(4):                              # (a step of 6 s is believed after 3 more stamps)
        imu.header.stamp = to_stamp(106.0 + 0.01 * k)
        imu.angular_velocity.x = 1e-3 * k
        node.on_imu(imu)
    level, message, values = node.check_inputs()   # what is left: no fix for 6 s, overdue
    problems = [k for k in values if k.startswith("recent_") and k not in ("recent_imu", "recent_gnss")]
    assert values["gnss_no_fix"] == 1 and problems == ["recent_gnss_overdue"], values
    assert level == WARN and "1 gnss_overdue" in message
    node.destroy_node()
