"""nav_sensor_module_node with estimator ins_tight: every parameter (the `ins` ones, fix_timeout, jump_window,
max_base_age, tight.*) is described and read-only; the raw GNSS subscriptions exist only for this estimator, with the
QoS their drivers publish with: a base position latched before the node started still reaches its pipeline."""
import time

import pytest

pytest.importorskip("rclpy")

RAW_TOPICS = ("/gnss/status", "/gnss/raw_observations", "/gnss/base/observations", "/gnss/nav_data",
              "/gnss/base/position")


def test_parameters_are_described_and_read_only(ros):
    from rclpy.parameter import Parameter

    from agnav_fusion.nav_sensor_module_node import NavSensorModuleNode, parameter_entries
    node = NavSensorModuleNode(parameter_overrides=[Parameter("estimator", value="ins_tight"),
                                                    Parameter("tight.dd.sigma_code", value=0.7),
                                                    Parameter("max_base_age", value=5.0)])
    names = [name for name, _, _ in parameter_entries("ins_tight")]
    assert {"fix_timeout", "jump_window", "max_base_age", "tight.dd.elevation_mask_deg", "tight.sigma_doppler",
            "tight.ratio_threshold", "ekf.error.gyro_arw"} <= set(names)
    assert all(d.description and d.read_only for d in node.describe_parameters(names))
    s = node.backend.settings
    assert s.tight.dd.sigma_code == 0.7 and s.max_base_age == 5.0
    assert not node.set_parameters([Parameter("fix_timeout", value=3.0)])[0].successful
    node.destroy_node()


def test_raw_inputs_only_for_ins_tight_and_the_latched_base_position_arrives(ros):
    from geometry_msgs.msg import PointStamped
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from rclpy.qos import DurabilityPolicy

    from agnav_common.qos import LATCHED_QOS
    from agnav_fusion.nav_sensor_module_node import NavSensorModuleNode
    plain = NavSensorModuleNode(name="plain")
    assert not {s.topic_name for s in plain.subscriptions} & set(RAW_TOPICS)
    assert plain.pipeline.raw is None
    driver = ros.create_node("rtcm_base_like")
    pub = driver.create_publisher(PointStamped, "/gnss/base/position", LATCHED_QOS)
    point = PointStamped()
    point.header.frame_id = "ecef"
    point.point.x, point.point.y, point.point.z = -3961904.9, 3348993.8, 3698211.7
    pub.publish(point)                                   # before the navigation node exists
    node = NavSensorModuleNode(parameter_overrides=[Parameter("estimator", value="ins_tight")])
    subs = {s.topic_name: s for s in node.subscriptions}
    assert set(RAW_TOPICS) <= set(subs)
    assert subs["/gnss/base/position"].qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
    ex = SingleThreadedExecutor()
    for n in (node, driver):
        ex.add_node(n)
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline and node.pipeline.raw.base_pos is None:
        ex.spin_once(timeout_sec=0.05)
    assert node.pipeline.raw.base_pos.tolist() == [-3961904.9, 3348993.8, 3698211.7]
    ex.shutdown()
