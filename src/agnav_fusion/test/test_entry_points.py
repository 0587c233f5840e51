"""Every console script of the installed agnav_fusion (checkout, venv or colcon install) loads to a callable."""
from importlib.metadata import distribution


def test_console_scripts_load():
    scripts = [e for e in distribution("agnav_fusion").entry_points if e.group == "console_scripts"]
    assert {e.name for e in scripts} >= {"nav_sensor_module_node", "ins_node", "heading_node"}
    for e in scripts:
        assert callable(e.load()), e.name
