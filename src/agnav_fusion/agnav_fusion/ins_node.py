"""GNSS/INS node (SPEC §7, loosely coupled): nav_sensor_module_node with the `ins` estimator by default (the same
topics, TF, diagnostics and front end; the INS backend is agnav_fusion.nav_ins). Kept as its own executable name."""
from agnav_common.node_main import main_for

from agnav_fusion.nav_sensor_module_node import NavSensorModuleNode, parameter_entries as node_parameter_entries


class InsNode(NavSensorModuleNode):
    estimator = "ins"

    def __init__(self, name="ins_node", **kwargs):
        super().__init__(name, **kwargs)


def parameter_entries():
    """[(name, default, description)] of ins_node's parameters (tools/gen_params.py)."""
    return node_parameter_entries("ins")


main = main_for(InsNode)
