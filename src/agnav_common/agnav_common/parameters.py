"""Settings dataclasses as ROS parameters, declared once: every (nested) field becomes a parameter named by its path
(`roll_kf.tau`), with a ParameterDescriptor whose description is the field's own source comment (the text after `#`
on its line; a leading unit such as "s," or "m/s" is the unit), a range (numbers are never negative), and read-only
(the estimators do not support changes at run time: `set_parameters` is refused). `params_yaml` writes the same
parameters as a commented `--params-file` YAML (`node: {ros__parameters: ...}`). ROS-free except `declare`.
"""
import dataclasses
import inspect
import math
import re

import yaml

_FIELD = re.compile(r"^\s+(\w+)\s*:[^=#]+=[^#]*#\s*(.+)$")
_UNIT = re.compile(r"^((?:m|s|rad|deg|Hz|m/s|rad/s|m/s\^2|m\^2|rad\^2|m/sqrt\(s\)|rad/sqrt\(s\)|rad/s/sqrt\(s\)|"
                   r"rad/s/sqrt\(Hz\)|m/s\^3/sqrt\(Hz\)|uT|T))(?=[,\s])")
INT_MAX = 2 ** 31 - 1


def field_docs(cls):
    """{field name: comment} from the source of dataclass `cls` (continuation comment lines are appended)."""
    docs, last = {}, None
    try:
        lines = inspect.getsource(cls).splitlines()
    except (OSError, TypeError):
        return docs
    for line in lines:
        m = _FIELD.match(line)
        if m:
            last = m.group(1)
            docs[last] = m.group(2).strip()
        elif last and re.match(r"^\s+#", line):
            docs[last] += " " + line.strip().lstrip("#").strip()
        else:
            last = None
    return docs


def leaves(obj, prefix="", skip=()):
    """[(name, value, description)] of every leaf field of the dataclass instance `obj` (tuples as float lists)."""
    out, docs = [], field_docs(type(obj))
    for f in dataclasses.fields(obj):
        name, value = f"{prefix}{f.name}", getattr(obj, f.name)
        if f.name in skip or name in skip:
            continue
        if dataclasses.is_dataclass(value):
            out += leaves(value, name + ".", skip)
        else:
            value = [float(v) for v in value] if isinstance(value, tuple) else value
            out.append((name, value, docs.get(f.name, "")))
    return out


def apply(obj, values, prefix=""):
    """Set the leaf fields of `obj` from {name: value} (missing names keep their default); returns obj."""
    for f in dataclasses.fields(obj):
        name, value = f"{prefix}{f.name}", getattr(obj, f.name)
        if dataclasses.is_dataclass(value):
            apply(value, values, name + ".")
        elif name in values:
            new = values[name]
            setattr(obj, f.name, tuple(float(v) for v in new) if isinstance(value, tuple) else type(value)(new))
    return obj


def descriptor(name, value, description):
    """rcl_interfaces ParameterDescriptor: description, unit, non-negative range for numbers, read-only."""
    from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
    d = ParameterDescriptor(name=name, description=description, read_only=True)
    m = _UNIT.match(description)
    if m:
        d.additional_constraints = f"unit: {m.group(1)}"
    if isinstance(value, bool):
        pass
    elif isinstance(value, float):
        d.floating_point_range = [FloatingPointRange(from_value=0.0, to_value=math.inf, step=0.0)]
    elif isinstance(value, int):
        d.integer_range = [IntegerRange(from_value=0, to_value=INT_MAX, step=0)]
    return d


def declare(node, obj, prefix="", skip=()):
    """Declare every leaf of `obj` on the rclpy `node` with its descriptor; return `obj` holding their values
    (a parameter given out of range raises rclpy's InvalidParameterValueException, naming it)."""
    values = {name: node.declare_parameter(name, value, descriptor(name, value, doc)).value
              for name, value, doc in leaves(obj, prefix, skip)}
    return apply(obj, values, prefix)


def params_yaml(node_name, entries):
    """A commented --params-file YAML of `entries` [(name, value, description)] for `node_name`."""
    lines = [f"{node_name}:", "  ros__parameters:"]
    for name, value, doc in entries:
        text = yaml.safe_dump({name: value}, default_flow_style=True, width=1000).strip().strip("{}")
        lines.append(f"    {text}" + (f"  # {doc}" if doc else ""))
    return "\n".join(lines) + "\n"
