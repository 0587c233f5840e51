"""Relative topic names: a node started in a namespace (e.g. `-r __ns:=/tractor1`, or two tractors on one domain)
moves every topic but the global ones (/diagnostics, /tf, /tf_static, /clock, /rosout, /parameter_events)."""
import pytest

pytest.importorskip("rclpy")

GLOBAL = ("/diagnostics", "/tf", "/tf_static", "/clock", "/rosout", "/parameter_events")


def _node_classes():
    from agnav_control.steering_node import SteeringNode
    from agnav_drivers.adc_sensor_node import AdcSensorNode
    from agnav_fusion.attitude_node import AttitudeNode
    from agnav_fusion.gnss_correction_node import GnssCorrectionNode
    from agnav_fusion.heading_node import HeadingNode
    from agnav_fusion.nav_sensor_module_node import NavSensorModuleNode
    return [NavSensorModuleNode, AttitudeNode, GnssCorrectionNode, HeadingNode, SteeringNode, AdcSensorNode]


@pytest.mark.parametrize("index", range(6))
def test_every_topic_follows_the_namespace(ros, index):
    from rclpy.parameter import Parameter
    node_class = _node_classes()[index]
    overrides = [Parameter("port", value="")] if node_class.__name__ == "AdcSensorNode" else []
    node = node_class(namespace="tractor1", parameter_overrides=overrides)
    try:
        topics = [p.topic_name for p in node.publishers] + [s.topic_name for s in node.subscriptions]
        own = [t for t in topics if t not in GLOBAL]
        assert own and all(t.startswith("/tractor1/") for t in own), topics
    finally:
        node.destroy_node()


def test_two_tractors_on_one_domain_do_not_cross_talk(ros):
    """Two navigation nodes in namespaces with frame prefixes: tractor1's IMU and mounts reach tractor1 only."""
    import time

    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import Imu

    from agnav_common.qos import SENSOR_QOS
    from agnav_common.stamps import to_stamp
    from agnav_common.tf import StaticTransformPublisher, make_transform
    from agnav_fusion.nav_sensor_module_node import NavSensorModuleNode

    nodes = [NavSensorModuleNode(namespace=ns, parameter_overrides=[Parameter("frame_prefix", value=ns + "/")])
             for ns in ("tractor1", "tractor2")]
    src = ros.create_node("tractor1_driver")
    level = (0.0, 0.0, 0.0, 1.0)
    StaticTransformPublisher(src).send([make_transform("tractor1/base_link", f"tractor1/{child}", to_stamp(1.0), xyz,
                                                       level)
                                        for child, xyz in (("imu_link", (0.3, 0.0, 1.0)),
                                                           ("gnss_link", (0.0, 0.0, 2.0)))])
    imu_pub = src.create_publisher(Imu, "/tractor1/imu/data_raw", SENSOR_QOS)
    ex = SingleThreadedExecutor()
    for n in (*nodes, src):
        ex.add_node(n)
    deadline, k = time.monotonic() + 5.0, 0
    while time.monotonic() < deadline and nodes[0].pipeline.imu_rotation is None:
        k += 1
        msg = Imu()
        msg.header.stamp = to_stamp(100.0 + 0.01 * k)
        msg.angular_velocity.z = 1e-4 * (k % 7)
        imu_pub.publish(msg)
        ex.spin_once(timeout_sec=0.02)
    assert nodes[0].pipeline.imu_rotation is not None and nodes[0].last_imu_arrival is not None
    assert nodes[1].pipeline.imu_rotation is None and nodes[1].last_imu_arrival is None
    assert nodes[0].frames["base"] == "tractor1/base_link" and nodes[0].frames["map"] == "map"
    ex.shutdown()
    for n in (*nodes, src):
        n.destroy_node()
