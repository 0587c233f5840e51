"""Parameters declared once: every nav_sensor_module_node parameter has a description (and a unit where its comment
starts with one), is read-only and range-checked; the generated params file is up to date and round-trips through
--params-file."""
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

pytest.importorskip("rclpy")

REPO = Path(__file__).resolve().parents[2]
PARAMS = REPO / "src" / "agnav_fusion" / "config" / "nav_sensor_module.yaml"


def test_generated_params_file_is_up_to_date():
    proc = subprocess.run([sys.executable, str(REPO / "tools" / "gen_params.py"), "--check"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout


def test_params_file_round_trips_and_every_parameter_is_described(ros):
    from rclpy.context import Context
    from rclpy.parameter import Parameter

    from agnav_fusion.nav_sensor_module_node import NavSensorModuleNode, parameter_entries

    values = yaml.safe_load(PARAMS.read_text())["nav_sensor_module_node"]["ros__parameters"]
    values.update({"gate_chi2": 9.21, "roll_kf.tau": 0.7, "estimator": "thesis"})  # changed values survive too
    path = REPO / "build" / "nav_params_roundtrip.yaml"
    path.parent.mkdir(exist_ok=True)
    path.write_text(yaml.safe_dump({"nav_sensor_module_node": {"ros__parameters": values}}))
    context = Context()
    ros.init(args=["--ros-args", "--params-file", str(path)], context=context)
    try:
        node = NavSensorModuleNode(context=context)
        entries = parameter_entries()
        assert {name for name, _, _ in entries} == set(values)
        for name, _, _ in entries:
            got = node.get_parameter(name).value
            assert (got if isinstance(got, (str, bool, int, float)) else list(got)) == values[name], name
        described = node.describe_parameters([name for name, _, _ in entries])
        assert all(d.description and d.read_only for d in described)
        assert node.describe_parameters(["roll_kf.tau"])[0].additional_constraints == "unit: s"
        assert node.nsm.settings.gate_chi2 == 9.21 and node.nsm.settings.roll_kf.tau == 0.7
        assert not node.set_parameters([Parameter("gate_chi2", value=5.0)])[0].successful  # read-only
        node.destroy_node()
    finally:
        ros.try_shutdown(context=context)


@pytest.mark.parametrize("name, value", [("gate_chi2", -1.0), ("roll_kf.tau", -1.0), ("tilt_source", "bogus"),
                                         ("estimator", "kalman")])
def test_bad_values_are_refused_at_start(ros, name, value):
    from rclpy.parameter import Parameter

    from agnav_fusion.nav_sensor_module_node import NavSensorModuleNode
    with pytest.raises(Exception, match=name if "." not in name else "roll_kf.tau|tau"):
        NavSensorModuleNode(parameter_overrides=[Parameter(name, value=value)])
