"""Fast construction of ROS messages on hot output paths.

A generated rclpy message's __init__ imports its field types and builds every sub-message through property setters
on each call (~30 us for nav_msgs/Odometry). new_message(cls) returns a fresh default-valued instance (no shared
mutable parts) copied from a per-type prototype slot by slot: same value as cls(), about 4x cheaper. Field checks
stay as cls() sets them (off unless ROS_PYTHON_CHECK_FIELDS=1).
"""
import itertools

import numpy as np

_copiers = {}


def _copier(proto):
    """A function returning a deep copy of the message `proto` (immutable fields shared, arrays copied), compiled to
    straight-line slot assignments with the nested messages inlined (no call per sub-message)."""
    env, lines, count = {"new": object.__new__}, [], itertools.count()

    def build(value, var):
        cls = type(value)
        env[f"c{var}"] = cls
        lines.append(f"{var} = new(c{var})")
        for slot in cls.__slots__:
            field, name = getattr(value, slot), f"v{next(count)}"
            if hasattr(type(field), "_fields_and_field_types"):
                build(field, name)
                lines.append(f"{var}.{slot} = {name}")
                continue
            env[name] = field
            copy = ".copy()" if isinstance(field, (np.ndarray, list)) else ""  # default sequences are empty
            lines.append(f"{var}.{slot} = {name}{copy}")  # else bool, number, str, bytes: immutable

    build(proto, "d")
    exec("def copy():\n    " + "\n    ".join(lines) + "\n    return d", env)  # noqa: S102
    return env["copy"]


def new_message(cls):
    """A fresh default instance of the message class `cls` (as cls())."""
    copy = _copiers.get(cls)
    if copy is None:
        copy = _copiers[cls] = _copier(cls())
    return copy()
