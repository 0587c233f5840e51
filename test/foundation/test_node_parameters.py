"""Parameters declared once, for every node with a generated params file: each node runs as its own process with
its file (`--ros-args --params-file`, drivers on a pseudo-terminal), every parameter of the file reads back with the
file's value over the node's parameter services, `describe_parameters` gives each a description (and the unit its
comment starts with) and marks it read-only, and a change at run time is refused. The files are up to date."""
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

pytest.importorskip("rclpy")

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tools"))
import gen_params  # noqa: E402

NODES = {node: (path, module) for path, (node, module) in gen_params.NODES.items()
         if node not in ("nav_sensor_module_node", "ins_node")}   # those two: test/fusion, test/ins
DRIVERS = ("adc_sensor", "nmea_gnss", "ubx_gnss")


def test_generated_params_files_are_up_to_date():
    proc = subprocess.run([sys.executable, str(REPO / "tools" / "gen_params.py"), "--check"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout
    assert {path.name for path, (node, _) in gen_params.NODES.items() if node in NODES} == {
        "steering_node.yaml", "heading_node.yaml", "gnss_correction_node.yaml", "attitude_node.yaml",
        "adc_sensor.yaml", "nmea_gnss.yaml", "ubx_gnss.yaml", "bag_player.yaml", "bag_recorder.yaml",
        "tractor_sim.yaml", "rtcm_base.yaml"}


def _required(node_name, tmp_path):
    """{name: value} a node needs beyond its file's defaults: a bag to play (a second message 100 s after the first
    keeps the player running), a folder to record to."""
    if node_name == "bag_player":
        from std_msgs.msg import String

        from test.foundation.bagmaker import write_bag
        t0 = 1_700_000_000_000_000_000
        bag = write_bag(tmp_path / "in", [("/param_test", "std_msgs/msg/String", t0 + k * 100_000_000_000,
                                           String(data=str(k))) for k in range(2)])
        return {"bag": str(bag)}
    return {"output": str(tmp_path / "rec")} if node_name == "bag_recorder" else {}


def _python(value):
    return list(value) if isinstance(value, (list, tuple)) or type(value).__name__ == "array" else value


@pytest.mark.parametrize("node_name", sorted(NODES))
def test_params_file_round_trips_and_every_parameter_is_described(ros, node_name, tmp_path):
    import importlib

    from rclpy.parameter import Parameter, parameter_value_to_python
    from rclpy.parameter_client import AsyncParameterClient

    from agnav_common.parameters import unit
    from agnav_drivers.pty_device import PtyDevice

    path, module = NODES[node_name]
    values = yaml.safe_load(path.read_text())[node_name]["ros__parameters"]
    docs = {name: doc for name, _, doc in importlib.import_module(module).parameter_entries()}
    assert set(docs) == set(values)
    args = ["--ros-args", "--params-file", str(path)]
    device, given = None, _required(node_name, tmp_path)
    if node_name in DRIVERS:  # a real port to open: a pty standing in for the USB device
        device = PtyDevice(str(tmp_path / "ttyUSB0"))
        given["port"] = device.path
    for name, value in given.items():
        args += ["-p", f"{name}:={value}"]
    values.update(given)
    code = f"import sys; from {module} import main; sys.exit(main())"
    proc = subprocess.Popen([sys.executable, "-c", code, *args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, env=dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"))
    probe = ros.create_node(f"param_probe_{node_name}")
    try:
        client = AsyncParameterClient(probe, node_name)
        end = time.monotonic() + 60.0
        while not client.services_are_ready() and proc.poll() is None and time.monotonic() < end:
            ros.spin_once(probe, timeout_sec=0.1)
        assert proc.poll() is None and client.services_are_ready(), proc.communicate(timeout=5)[0] \
            if proc.poll() is not None else "parameter services not up"

        def call(future):
            ros.spin_until_future_complete(probe, future, timeout_sec=20.0)
            assert future.done(), "no answer from the parameter service"
            return future.result()

        names = sorted(values)
        got = call(client.get_parameters(names)).values
        assert {n: _python(parameter_value_to_python(v)) for n, v in zip(names, got)} == values
        for name, d in zip(names, call(client.describe_parameters(names)).descriptors):
            assert d.description == docs[name] and d.description, name
            assert d.read_only, name
            if unit(docs[name]):
                assert d.additional_constraints == f"unit: {unit(docs[name])}", name
        first = Parameter(names[0], value=values[names[0]])
        assert not call(client.set_parameters([first])).results[0].successful  # read-only: refused
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        probe.destroy_node()
        if device is not None:
            device.close()


@pytest.mark.parametrize("module, cls, name, value", [
    ("agnav_control.steering_node", "SteeringNode", "watchdog.rate", 0.0),
    ("agnav_control.steering_node", "SteeringNode", "watchdog.min_speed", -1.0),
    ("agnav_control.steering_node", "SteeringNode", "teach.heading_source", "bogus"),
    ("agnav_fusion.heading_node", "HeadingNode", "tilt_source", "bogus"),
    ("agnav_fusion.heading_node", "HeadingNode", "vwa.window", -1.0),
    ("agnav_fusion.gnss_correction_node", "GnssCorrectionNode", "max_attitude_age", -0.5),
    ("agnav_drivers.nmea_gnss_node", "NmeaGnssNode", "stamp_source", "gps"),
    ("agnav_drivers.adc_sensor_node", "AdcSensorNode", "frame_mode", "hex"),
    ("agnav_drivers.bag_player_node", "BagPlayerNode", "window", -1),
    ("agnav_drivers.bag_recorder_node", "BagRecorderNode", "flush_period", 0.01),
    ("agnav_sim_eval.sim_node", "TractorSimNode", "scenario", "bogus"),
    ("agnav_sim_eval.sim_node", "TractorSimNode", "real_time_factor", -1.0)])
def test_bad_values_are_refused_at_start(ros, module, cls, name, value):
    import importlib

    from rclpy.parameter import Parameter
    node_class = getattr(importlib.import_module(module), cls)
    with pytest.raises(Exception, match=name.split(".")[-1] + "|" + str(value)):
        node_class(parameter_overrides=[Parameter(name, value=value)])
