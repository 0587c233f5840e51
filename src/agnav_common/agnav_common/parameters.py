"""Settings dataclasses as ROS parameters, declared once: every (nested) field becomes a parameter named by its path
(`roll_kf.tau`), with a ParameterDescriptor whose description is the field's own source comment (the text after `#`
on its line; a leading unit such as "s," or "m/s" is the unit), a range (numbers are never negative unless the field's
metadata says otherwise: `field(default=..., metadata=SIGNED)` or `bounded(lo, hi)`), and read-only (the nodes do not
support changes at run time: `set_parameters` is refused). `params_yaml` writes the same parameters as a commented
`--params-file` YAML (`node: {ros__parameters: ...}`). ROS-free except `declare`.
"""
import dataclasses
import inspect
import math
import re
from functools import lru_cache

import yaml

_FIELD = re.compile(r"^\s+(\w+)\s*:[^=#]+=[^#]*#\s*(.+)$")
_UNIT = re.compile(r"^((?:m|s|rad|deg|Hz|m/s|rad/s|m/s\^2|m\^2|rad\^2|m/sqrt\(s\)|rad/sqrt\(s\)|rad/s/sqrt\(s\)|"
                   r"rad/s/sqrt\(Hz\)|m/s\^3/sqrt\(Hz\)|uT|T|deg/s|deg/sqrt\(s\)|deg/s/sqrt\(s\)|V|V/deg|mG|mG/V|"
                   r"\(deg/s\)/V|\(m/s\^2\)/V|bytes/s|bit/s|rad/m|rad/\(m s\)|rad/\(m/s\)|rad/rad|m s|1/s|year))"
                   r"(?=[,;:\s]|$)")
INT_MAX = 2 ** 31 - 1
SIGNED = {"range": None}  # field metadata: a number that may be negative (no range in its descriptor)


def bounded(low, high):
    """Field metadata: the parameter's range is [low, high]."""
    return {"range": (low, high)}


@lru_cache(maxsize=None)
def field_docs(cls):
    """{field name: comment} from the source of dataclass `cls` and its dataclass bases (continuation comment lines
    are appended; a subclass's comment wins). Cached (inspect parses the whole module per class; roll and pitch
    filters share their settings classes): do not modify the dict."""
    docs, last = {}, None
    for base in cls.__mro__[1:]:
        if dataclasses.is_dataclass(base):
            docs = {**field_docs(base), **docs}
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


def _walk(obj, prefix="", skip=()):
    """[(name, value, description, field metadata)] of every leaf field of the dataclass instance `obj`."""
    out, docs = [], field_docs(type(obj))
    for f in dataclasses.fields(obj):
        name, value = f"{prefix}{f.name}", getattr(obj, f.name)
        if f.name in skip or name in skip:
            continue
        if dataclasses.is_dataclass(value):
            out += _walk(value, name + ".", skip)
        else:
            value = [float(v) for v in value] if isinstance(value, tuple) else value
            out.append((name, value, docs.get(f.name, ""), f.metadata))
    return out


def leaves(obj, prefix="", skip=()):
    """[(name, value, description)] of every leaf field of the dataclass instance `obj` (tuples as float lists)."""
    return [entry[:3] for entry in _walk(obj, prefix, skip)]


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


def unit(description):
    """The unit a description starts with ("s, ..." -> "s"), or None."""
    m = _UNIT.match(description)
    return m.group(1) if m else None


def descriptor(name, value, description, metadata=None):
    """rcl_interfaces ParameterDescriptor: description, unit, range for numbers (non-negative unless `metadata` holds
    another "range", None for none), read-only."""
    from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
    d = ParameterDescriptor(name=name, description=description, read_only=True)
    if unit(description):
        d.additional_constraints = f"unit: {unit(description)}"
    low, high = (metadata or {}).get("range", (0, math.inf)) or (None, None)
    if isinstance(value, bool) or low is None:
        pass
    elif isinstance(value, float):
        d.floating_point_range = [FloatingPointRange(from_value=float(low), to_value=float(high), step=0.0)]
    elif isinstance(value, int):
        d.integer_range = [IntegerRange(from_value=int(low), to_value=min(high, INT_MAX), step=0)]
    return d


def declare(node, obj, prefix="", skip=()):
    """Declare every leaf of `obj` on the rclpy `node` with its descriptor; return `obj` holding their values
    (a parameter given out of range raises rclpy's InvalidParameterValueException, naming it)."""
    values = {name: node.declare_parameter(name, value, descriptor(name, value, doc, meta)).value
              for name, value, doc, meta in _walk(obj, prefix, skip)}
    return apply(obj, values, prefix)


def params_yaml(node_name, entries, header=""):
    """A commented --params-file YAML of `entries` [(name, value, description)] for `node_name`, after the comment
    lines of `header` (text)."""
    lines = [f"# {line}".rstrip() for line in header.splitlines()] + [f"{node_name}:", "  ros__parameters:"]
    for name, value, doc in entries:
        text = yaml.safe_dump({name: value}, default_flow_style=True, width=1000).strip().strip("{}")
        lines.append(f"    {text}" + (f"  # {doc}" if doc else ""))
    return "\n".join(lines) + "\n"
