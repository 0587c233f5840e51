"""Sensor inputs follow the standard QoS overriding parameters: a node told qos_overrides.<topic>.subscription.
reliability=best_effort hears a driver that publishes best effort (SensorDataQoS); by default it stays reliable."""
import time

import pytest

pytest.importorskip("rclpy")


@pytest.mark.parametrize("override", [False, True])
def test_best_effort_imu_reaches_the_navigation_node_with_the_override(ros, override):
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from rclpy.qos import ReliabilityPolicy, qos_profile_sensor_data
    from sensor_msgs.msg import Imu

    from agnav_common.stamps import to_stamp
    from agnav_fusion.nav_sensor_module_node import NavSensorModuleNode

    params = [Parameter("qos_overrides./imu/data_raw.subscription.reliability", value="best_effort")] \
        if override else []
    node = NavSensorModuleNode(parameter_overrides=params)
    sub = next(s for s in node.subscriptions if s.topic_name == "/imu/data_raw")
    expected = ReliabilityPolicy.BEST_EFFORT if override else ReliabilityPolicy.RELIABLE
    assert sub.qos_profile.reliability == expected
    driver = ros.create_node("best_effort_driver")
    pub = driver.create_publisher(Imu, "/imu/data_raw", qos_profile_sensor_data)
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    ex.add_node(driver)
    deadline = time.monotonic() + 5.0
    k = 0
    while time.monotonic() < deadline and node.last_imu_arrival is None:
        k += 1
        msg = Imu()
        msg.header.stamp = to_stamp(100.0 + 0.01 * k)
        pub.publish(msg)
        ex.spin_once(timeout_sec=0.02)
    assert (node.last_imu_arrival is not None) == override
    ex.shutdown()
    driver.destroy_node()
    node.destroy_node()
