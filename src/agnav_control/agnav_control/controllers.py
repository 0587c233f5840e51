"""Registry of the steering controllers: name -> (class, settings dataclass)."""
from dataclasses import fields, replace

from .limits import SteeringLimits
from .pid import PID, PIDSettings
from .pure_pursuit import PurePursuit, PurePursuitSettings
from .stanley import Stanley, StanleySettings
from .thesis_pi import ThesisPI, ThesisPISettings

CONTROLLERS = {
    "thesis_pi": (ThesisPI, ThesisPISettings),
    "pid": (PID, PIDSettings),
    "stanley": (Stanley, StanleySettings),
    "pure_pursuit": (PurePursuit, PurePursuitSettings),
}


def scalar_fields(name: str) -> dict:
    """{field: default} of a controller's scalar settings (for ROS parameters and configs)."""
    settings = CONTROLLERS[name][1]()
    return {f.name: getattr(settings, f.name) for f in fields(settings) if isinstance(getattr(settings, f.name), (int, float, str))}


def make_controller(name: str, limits: SteeringLimits | None = None, **overrides):
    """Controller `name` with scalar setting overrides and optional shared actuator limits."""
    if name not in CONTROLLERS:
        raise ValueError(f"unknown controller {name!r}; choose from {sorted(CONTROLLERS)}")
    cls, settings_cls = CONTROLLERS[name]
    settings = replace(settings_cls(), **overrides)
    if limits is not None:
        settings = replace(settings, limits=limits)
    return cls(settings)
