"""Parameters declared once: every nav_sensor_module_node parameter (each estimator's backend settings; ins_node: the
`ins` backend) has a description (and a unit where its comment starts with one), is read-only and range-checked; the
generated params files are up to date and round-trip through --params-file."""
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

pytest.importorskip("rclpy")

REPO = Path(__file__).resolve().parents[2]
CONFIG = REPO / "src" / "agnav_fusion" / "config"


def test_generated_params_file_is_up_to_date():
    proc = subprocess.run([sys.executable, str(REPO / "tools" / "gen_params.py"), "--check"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout


# (node, params file, changed values, (parameter, its unit), backend settings check)
NODES = [("nav_sensor_module_node", "nav_sensor_module.yaml", {"gate_chi2": 9.21, "roll_kf.tau": 0.7,
                                                             "estimator": "thesis"},
          ("roll_kf.tau", "s"), lambda s: s.gate_chi2 == 9.21 and s.roll_kf.tau == 0.7),
         ("ins_node", "ins_node.yaml", {"gnss_timeout": 3.0, "ekf.gate_probability": 0.999, "ekf.error.gyro_arw": 1e-3},
          ("gnss_timeout", "s"), lambda s: s.gnss_timeout == 3.0 and s.ekf.gate_probability == 0.999
          and s.ekf.error.gyro_arw == 1e-3)]


@pytest.mark.parametrize("name, params, changed, unit, check", NODES, ids=[n[0] for n in NODES])
def test_params_file_round_trips_and_every_parameter_is_described(ros, name, params, changed, unit, check):
    import importlib

    from rclpy.context import Context
    from rclpy.parameter import Parameter

    module = importlib.import_module(f"agnav_fusion.{name}")
    values = yaml.safe_load((CONFIG / params).read_text())[name]["ros__parameters"]
    values.update(changed)  # changed values survive too
    path = REPO / "build" / f"{name}_params_roundtrip.yaml"
    path.parent.mkdir(exist_ok=True)
    path.write_text(yaml.safe_dump({name: {"ros__parameters": values}}))
    context = Context()
    ros.init(args=["--ros-args", "--params-file", str(path)], context=context)
    try:
        node = module.main.node_class(context=context)
        entries = module.parameter_entries()
        assert {name for name, _, _ in entries} == set(values)
        for name, _, _ in entries:
            got = node.get_parameter(name).value
            assert (got if isinstance(got, (str, bool, int, float)) else list(got)) == values[name], name
        described = node.describe_parameters([name for name, _, _ in entries])
        assert all(d.description and d.read_only for d in described)
        assert node.describe_parameters([unit[0]])[0].additional_constraints == f"unit: {unit[1]}"
        assert check(node.backend.settings)
        assert not node.set_parameters([Parameter(unit[0], value=5.0)])[0].successful  # read-only
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
