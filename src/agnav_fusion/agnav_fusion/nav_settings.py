"""ROS parameters <-> NavSensorModuleSettings: every (nested) dataclass field becomes a parameter
named by its path (e.g. `roll_kf.tau`, `heading.kise.window`), defaulting to the SPEC value."""
import dataclasses

from agnav_fusion.nav_sensor_module import NavSensorModuleSettings


def _declare(node, obj, prefix):
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        name = f"{prefix}{f.name}"
        if dataclasses.is_dataclass(value):
            _declare(node, value, name + ".")
        elif isinstance(value, tuple):
            setattr(obj, f.name, tuple(node.declare_parameter(name, [float(v) for v in value]).value))
        else:
            setattr(obj, f.name, type(value)(node.declare_parameter(name, value).value))


def declare_settings(node, settings=None):
    """Declare all module parameters on `node` and return the settings they hold."""
    settings = settings or NavSensorModuleSettings()
    _declare(node, settings, "")
    return settings
