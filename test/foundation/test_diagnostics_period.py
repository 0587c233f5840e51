"""Every node publishing /diagnostics has diagnostic_updater's `diagnostic_updater.period` parameter (default
1.0 s, described, read-only) and publishes at that period."""
import statistics
import time

import pytest
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.experimental import EventsExecutor
from rclpy.parameter import Parameter

from agnav_common.diagnostics import Diagnostics

PERIOD = Diagnostics.PERIOD


def node_classes():
    from agnav_control.steering_node import SteeringNode
    from agnav_drivers.bag_recorder_node import BagRecorderNode
    from agnav_fusion.gnss_correction_node import GnssCorrectionNode
    from agnav_fusion.nav_sensor_module_node import NavSensorModuleNode
    return {"bag_recorder": BagRecorderNode, "steering": SteeringNode, "gnss_correction": GnssCorrectionNode,
            "nav_sensor_module": NavSensorModuleNode}


def make(name, tmp_path, *overrides):
    params = [Parameter("output", value=str(tmp_path / "rec"))] if name == "bag_recorder" else []
    return node_classes()[name](parameter_overrides=params + list(overrides))


@pytest.mark.parametrize("name", ["bag_recorder", "steering", "gnss_correction", "nav_sensor_module"])
def test_node_publishes_diagnostics_at_the_configured_period(ros, tmp_path, name):
    node = make(name, tmp_path, Parameter(PERIOD, value=0.2))
    listener = ros.create_node("diag_listener")
    arrivals = []
    prefix = f"{node.get_name()}: "
    listener.create_subscription(DiagnosticArray, "/diagnostics", lambda m: arrivals.append(time.monotonic())
                                 if any(s.name.startswith(prefix) for s in m.status) else None, 50)
    executor = EventsExecutor()
    executor.add_node(node)
    executor.add_node(listener)
    end = time.monotonic() + 3.0
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.02)
    node.destroy_node()
    listener.destroy_node()
    intervals = [b - a for a, b in zip(arrivals, arrivals[1:])]
    assert len(arrivals) >= 8, arrivals  # ~14 at 5 Hz over 3 s (the first after discovery), 2 at the default 1 Hz
    assert 0.17 < statistics.median(intervals) < 0.25, intervals


def test_period_parameter_is_described_read_only_default_one_second(ros, tmp_path):
    node = make("steering", tmp_path)
    try:
        assert node.get_parameter(PERIOD).value == 1.0
        descriptor = node.describe_parameters([PERIOD])[0]
        assert descriptor.read_only and descriptor.description
        assert descriptor.floating_point_range[0].from_value > 0.0
        assert not node.set_parameters([Parameter(PERIOD, value=0.5)])[0].successful
    finally:
        node.destroy_node()
    with pytest.raises(Exception, match=PERIOD):  # out of range: refused at start
        make("steering", tmp_path, Parameter(PERIOD, value=0.0))
