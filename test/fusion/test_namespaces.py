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
