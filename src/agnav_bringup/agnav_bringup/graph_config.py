"""Graph configs: YAML with the node list, parameters, remaps, static transforms and the default bag.

```yaml
description: one line
bag: bags/asphalt_loop            # default input for replay (relative to the repository root), optional
record: []                        # topics to record with --record (empty: every topic)
bag_remap: {/imu/data: /imu/data_raw}   # bag topic -> graph topic, as the player publishes it (optional)
static_transforms:                # base_link -> sensor mounts for live runs (bags carry /tf_static)
  - {parent: base_link, child: gnss_link, xyz: [0.0, 0.0, 1.5], rpy: [0.0, 0.0, 0.0]}
nodes:
  - executable: nav_sensor_module_node   # console script of an agnav package
    name: nav_sensor_module              # node name (optional)
    parameters: {key: value}             # ros__parameters of that node
    remappings: {/from: /to}
```
"""
import os
import sys
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from pathlib import Path

import yaml

REPO_ROOT = Path(__file__).resolve().parents[3]  # the source checkout (editable install)
# Bundled configs: the source tree, then the install prefixes (colcon / ament layout).
CONFIG_DIRS = [Path(__file__).resolve().parents[1] / "config"] + [
    Path(p) / "share" / "agnav_bringup" / "config"
    for p in [sys.prefix] + os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]


@dataclass
class NodeSpec:
    executable: str
    name: str = ""
    parameters: dict = field(default_factory=dict)
    remappings: dict = field(default_factory=dict)

    def node_class(self):
        """The rclpy Node class behind the console script (exposed by agnav_common.node_main.main_for)."""
        found = entry_points(group="console_scripts", name=self.executable)
        if not found:
            raise LookupError(f"no console script '{self.executable}' is installed (run `make setup`)")
        main = next(iter(found)).load()
        if not hasattr(main, "node_class"):
            raise LookupError(f"'{self.executable}' is not an agnav node entry point")
        return main.node_class

    def ros_args(self):
        """--ros-args remapping arguments (node name and topics)."""
        args = ["--ros-args", "-r", f"__node:={self.name or self.executable}"]
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
    static_transforms: list = field(default_factory=list)
    nodes: list = field(default_factory=list)

    def bag_path(self):
        if not self.bag:
            return None
        p = Path(os.path.expanduser(self.bag))
        return p if p.is_absolute() or p.exists() else REPO_ROOT / p


def available_configs():
    return sorted({p.stem for d in CONFIG_DIRS for p in d.glob("*.yaml")})


def load_config(name_or_path):
    """A bundled config by name (nsm, gds, ins, steer, replay, ...) or a YAML file path."""
    path = Path(name_or_path)
    if not path.suffix:
        path = next((d / f"{name_or_path}.yaml" for d in CONFIG_DIRS if (d / f"{name_or_path}.yaml").is_file()),
                     path)
    if not path.is_file():
        raise FileNotFoundError(f"config '{name_or_path}' not found; bundled: {', '.join(available_configs())}")
    raw = yaml.safe_load(path.read_text()) or {}
    unknown = set(raw) - {"description", "bag", "record", "bag_remap", "static_transforms", "nodes"}
    if unknown:
        raise ValueError(f"{path}: unknown keys {sorted(unknown)}")
    nodes = [NodeSpec(**n) for n in raw.get("nodes") or []]
    return GraphConfig(path=path, description=raw.get("description", ""), bag=raw.get("bag") or "",
                       record=raw.get("record") or [], bag_remap=raw.get("bag_remap") or {},
                       static_transforms=raw.get("static_transforms") or [],
                       nodes=nodes)
