"""The generated launch files (src/agnav_bringup/launch/*.launch.py) start what `agnav run` starts for each bundled
graph config. launch/launch_ros are not on PyPI: each file runs against stub modules that record the actions."""
import importlib.util
import sys
import types
from importlib.metadata import entry_points
from pathlib import Path

import pytest

from agnav_bringup.graph_config import load_config

REPO = Path(__file__).resolve().parents[2]
BRINGUP = REPO / "src" / "agnav_bringup"
CONFIGS = sorted(p.stem for p in (BRINGUP / "config").glob("*.yaml"))


class Recorded:
    """Stands for any launch action or substitution: keeps its arguments."""

    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs

    def __eq__(self, other):
        return type(self) is type(other) and (self.args, self.kwargs) == (other.args, other.kwargs)


def stub_modules():
    classes = {name: type(name, (Recorded,), {}) for name in
               ("LaunchDescription", "DeclareLaunchArgument", "LaunchConfiguration", "Node")}
    layout = {"launch": ["LaunchDescription"], "launch.actions": ["DeclareLaunchArgument"],
              "launch.substitutions": ["LaunchConfiguration"], "launch_ros": [], "launch_ros.actions": ["Node"]}
    modules = {}
    for name, members in layout.items():
        modules[name] = types.ModuleType(name)
        for m in members:
            setattr(modules[name], m, classes[m])
    return modules, classes


def load_tool(name):
    spec = importlib.util.spec_from_file_location(name, REPO / "tools" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def launch_description(monkeypatch):
    modules, classes = stub_modules()
    for name, module in modules.items():
        monkeypatch.setitem(sys.modules, name, module)

    def run(config_name):
        path = BRINGUP / "launch" / f"{config_name}.launch.py"
        spec = importlib.util.spec_from_file_location(f"launch_{config_name}", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module.generate_launch_description(), classes
    return run


def test_one_launch_file_per_config_and_up_to_date():
    assert sorted(p.name for p in (BRINGUP / "launch").glob("*.launch.py")) == [f"{c}.launch.py" for c in CONFIGS]
    assert load_tool("gen_launch").main(["--check"]) == 0, "run .venv/bin/python tools/gen_launch.py"


def test_setup_installs_launch_and_config_folders():
    text = (BRINGUP / "setup.py").read_text()
    assert '("share/" + package_name + "/launch", glob("launch/*.launch.py"))' in text
    assert '("share/" + package_name + "/config", glob("config/*.yaml"))' in text


@pytest.mark.parametrize("name", CONFIGS)
def test_launch_file_matches_the_graph_config(name, launch_description):
    config = load_config(BRINGUP / "config" / f"{name}.yaml")
    description, classes = launch_description(name)
    (entities,) = description.args
    use_sim_time = classes["LaunchConfiguration"]("use_sim_time")
    argument, *actions = entities
    assert isinstance(argument, classes["DeclareLaunchArgument"]) and argument.args == ("use_sim_time",)
    assert argument.kwargs["default_value"] == str(config.use_sim_time).lower()
    assert all(isinstance(a, classes["Node"]) for a in actions)
    mounts = [a.kwargs for a in actions if a.kwargs["package"] == "tf2_ros"]
    nodes = [a.kwargs for a in actions if a.kwargs["package"] != "tf2_ros"]

    assert len(mounts) == len(config.static_transforms)
    for kw, t in zip(mounts, config.static_transforms):
        assert kw["executable"] == "static_transform_publisher"
        args = dict(zip(kw["arguments"][::2], kw["arguments"][1::2]))
        assert (args["--frame-id"], args["--child-frame-id"]) == (t["parent"], t["child"])
        pose = [float(args[k]) for k in ("--x", "--y", "--z", "--roll", "--pitch", "--yaw")]
        assert pose == [*t.get("xyz", [0, 0, 0]), *t.get("rpy", [0, 0, 0])]
        assert kw["parameters"] == [{"use_sim_time": use_sim_time}]

    assert len(nodes) == len(config.nodes)
    for kw, spec in zip(nodes, config.nodes):
        (script,) = entry_points(group="console_scripts", name=spec.executable)
        assert (kw["package"], kw["executable"], kw["name"]) == (script.dist.name, spec.executable, spec.label)
        assert kw["parameters"] == [spec.parameters, {"use_sim_time": use_sim_time}]
        assert kw.get("remappings", []) == list(spec.remappings.items())


def test_launch_files_document_the_bag_replay(launch_description):
    text = (BRINGUP / "launch" / "test1.launch.py").read_text()
    assert ("ros2 bag play bags/test1 --clock --remap /imu/data:=/imu/data_raw /fix:=/gnss/fix "
            "/husky_velocity_controller/odom:=/wheel/odometry") in text
    assert "ros2 launch agnav_bringup test1.launch.py use_sim_time:=true" in text


def test_check_reports_a_stale_launch_file(tmp_path, monkeypatch, capsys):
    gen = load_tool("gen_launch")
    monkeypatch.setattr(gen, "LAUNCH_DIR", tmp_path)
    (tmp_path / "nsm.launch.py").write_text((BRINGUP / "launch" / "nsm.launch.py").read_text() + "# edited\n")
    (tmp_path / "gone.launch.py").write_text("")
    assert gen.main(["--check"]) == 1
    err = capsys.readouterr().err
    assert "nsm.launch.py is out of date" in err and "gone.launch.py" in err and "gds.launch.py" in err
    assert gen.main([]) == 0 and gen.main(["--check"]) == 0
    assert not (tmp_path / "gone.launch.py").exists()
