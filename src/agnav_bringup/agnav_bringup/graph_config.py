"""Graph configs: YAML with the node list, parameters, remaps, static transforms and the default bag.

```yaml
description: one line
bag: bags/asphalt_loop            # default input for replay (relative to the repository root), optional
record: []                        # topics to record with --record (empty: every topic)
bag_remap: {/imu/data: /imu/data_raw}   # bag topic -> graph topic, as the player publishes it (optional)
use_sim_time: false               # live runs: follow an external simulator's /clock (agnav run --sim-time)
static_transforms:                # base_link -> sensor mounts for live runs (bags carry /tf_static)
  - {parent: base_link, child: gnss_link, xyz: [0.0, 0.0, 1.5], rpy: [0.0, 0.0, 0.0]}
nodes:
  - executable: nav_sensor_module_node   # console script of an agnav package
    name: nav_sensor_module              # node name (optional)
    parameters: {key: value}             # ros__parameters of that node (nested maps become dotted names)
    remappings: {/from: /to}
```
A file that does not follow this raises ConfigError with one line: file, line or key, and what is expected.
"""
import difflib
import os
import sys
from dataclasses import dataclass, field
from functools import lru_cache
from importlib.metadata import entry_points
from pathlib import Path

import yaml
from agnav_common.checkout import checkout_root

REPO_ROOT = checkout_root(Path(__file__))  # bundled bags and docs (a colcon install: $AGNAV_ROOT or the cwd)
# Bundled configs: the source tree, then the install prefixes (colcon / ament layout).
CONFIG_DIRS = [Path(__file__).resolve().parents[1] / "config"] + [
    Path(p) / "share" / "agnav_bringup" / "config"
    for p in [sys.prefix] + os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]


class ConfigError(ValueError):
    """A graph config that cannot be used; the message is one line for the user."""



@lru_cache(maxsize=1)
def _console_scripts():
    """The installed console_scripts entry points, scanned once per process (~10 ms each scan)."""
    return entry_points(group="console_scripts")


@dataclass
class NodeSpec:
    executable: str
    name: str = ""
    parameters: dict = field(default_factory=dict)
    remappings: dict = field(default_factory=dict)

    @property
    def label(self):
        return self.name or self.executable

    def node_class(self):
        """The rclpy Node class behind the console script (exposed by agnav_common.node_main.main_for)."""
        found = _console_scripts().select(name=self.executable)
        if not found:
            raise LookupError(f"no console script '{self.executable}' is installed (run `make setup`)")
        main = next(iter(found)).load()
        if not hasattr(main, "node_class"):
            raise LookupError(f"'{self.executable}' is not an agnav node entry point")
        return main.node_class

    def ros_args(self):
        """--ros-args remapping arguments (node name and topics)."""
        args = ["--ros-args", "-r", f"__node:={self.label}"]
        for src, dst in self.remappings.items():
            args += ["-r", f"{src}:={dst}"]
        return args


@dataclass
class GraphConfig:
    path: Path
    description: str = ""
    bag: str = ""
    record: list = field(default_factory=list)
    bag_remap: dict = field(default_factory=dict)
    use_sim_time: bool = False
    static_transforms: list = field(default_factory=list)
    nodes: list = field(default_factory=list)

    def bag_path(self):
        if not self.bag:
            return None
        p = Path(os.path.expanduser(self.bag))
        return p if p.is_absolute() or p.exists() else REPO_ROOT / p


# Expected shape: key -> (check, what is expected). None values (`bag:` left empty) count as absent.
def _is_str_map(v):
    return isinstance(v, dict) and all(isinstance(a, str) and isinstance(b, str) for a, b in v.items())


def _is_vec3(v):
    return isinstance(v, list) and len(v) == 3 and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                       for x in v)


TOP_KEYS = {
    "description": (lambda v: isinstance(v, str), "a string"),
    "bag": (lambda v: isinstance(v, str), "a bag path (string)"),
    "record": (lambda v: isinstance(v, list) and all(isinstance(t, str) for t in v), "a list of topic names"),
    "bag_remap": (_is_str_map, "a map {bag topic: graph topic}"),
    "use_sim_time": (lambda v: isinstance(v, bool), "true or false"),
    "static_transforms": (lambda v: isinstance(v, list), "a list of {parent, child, xyz, rpy} maps"),
    "nodes": (lambda v: isinstance(v, list), "a list of {executable, name, parameters, remappings} maps"),
}
NODE_KEYS = {
    "executable": (lambda v: isinstance(v, str) and v != "", "a console script name (string)"),
    "name": (lambda v: isinstance(v, str), "a node name (string)"),
    "parameters": (lambda v: isinstance(v, dict), "a map {parameter: value}"),
    "remappings": (_is_str_map, "a map {from topic: to topic}"),
}
TRANSFORM_KEYS = {
    "parent": (lambda v: isinstance(v, str) and v != "", "a frame name"),
    "child": (lambda v: isinstance(v, str) and v != "", "a frame name"),
    "xyz": (_is_vec3, "[x, y, z] in metres"),
    "rpy": (_is_vec3, "[roll, pitch, yaw] in radians"),
}


def _check_map(path, where, raw, schema, required=()):
    """Validated copy of mapping `raw` (keys of `schema` only; None values dropped)."""
    if not isinstance(raw, dict):
        raise ConfigError(f"{path}: {where or 'the file'} must be a map of keys ({', '.join(schema)}), "
                          f"got {type(raw).__name__}")
    for key in raw:
        if key not in schema:
            close = difflib.get_close_matches(str(key), list(schema), n=1)
            hint = f"did you mean '{close[0]}'? " if close else ""
            raise ConfigError(f"{path}: unknown key '{where + '.' if where else ''}{key}'; {hint}"
                              f"expected one of: {', '.join(schema)}")
    for key in required:
        if raw.get(key) is None:
            raise ConfigError(f"{path}: {where}: missing '{key}' ({schema[key][1]})")
    out = {}
    for key, value in raw.items():
        if value is None:
            continue
        check, expected = schema[key]
        if not check(value):
            raise ConfigError(f"{path}: '{where + '.' if where else ''}{key}' must be {expected}, got {value!r}")
        out[key] = value
    return out


def flat_parameters(params, prefix=""):
    """ros__parameters-style nesting {a: {b: 1}} as ROS parameter names {'a.b': 1}."""
    flat = {}
    for key, value in params.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            flat.update(flat_parameters(value, name + "."))
        else:
            flat[name] = value
    return flat


def parse_config(path, raw):
    """GraphConfig from the YAML content `raw` of `path` (ConfigError when malformed)."""
    top = _check_map(path, "", {} if raw is None else raw, TOP_KEYS)
    nodes = []
    for i, item in enumerate(top.get("nodes", [])):
        spec = _check_map(path, f"nodes[{i}]", item, NODE_KEYS, required=("executable",))
        spec["parameters"] = flat_parameters(spec.get("parameters", {}))
        nodes.append(NodeSpec(**spec))
    transforms = [_check_map(path, f"static_transforms[{i}]", t, TRANSFORM_KEYS, required=("parent", "child"))
                  for i, t in enumerate(top.get("static_transforms", []))]
    return GraphConfig(path=path, description=top.get("description", ""), bag=top.get("bag", ""),
                       record=top.get("record", []), bag_remap=top.get("bag_remap", {}),
                       use_sim_time=top.get("use_sim_time", False), static_transforms=transforms, nodes=nodes)


def available_configs():
    return sorted({p.stem for d in CONFIG_DIRS for p in d.glob("*.yaml")})


def load_config(name_or_path):
    """A bundled config by name (nsm, gds, ins, steer, replay, ...) or a YAML file path."""
    path = Path(name_or_path)
    if not path.suffix:
        path = next((d / f"{name_or_path}.yaml" for d in CONFIG_DIRS if (d / f"{name_or_path}.yaml").is_file()),
                     path)
    if not path.is_file():
        raise ConfigError(f"config '{name_or_path}' not found; bundled: {', '.join(available_configs())}")
    try:
        raw = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{path}:{mark.line + 1}:{mark.column + 1}" if mark else str(path)
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ConfigError(f"{where}: YAML syntax error: {problem}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: cannot read: {exc}") from None
    return parse_config(path, raw)
