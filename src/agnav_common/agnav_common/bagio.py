"""rosbag2 type store for agnav: ROS 2 Kilted standard types plus agnav_msgs and tf2_msgs from .msg files."""
import os
import sys
from functools import lru_cache
from pathlib import Path

from rosbags.typesys import Stores, get_typestore, get_types_from_msg

INTERFACE_PACKAGES = ("agnav_msgs", "tf2_msgs")


def _share_dirs():
    """Install prefixes to search for interface definitions: the venv, then AMENT_PREFIX_PATH."""
    prefixes = [sys.prefix] + os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep)
    return [Path(p) / "share" for p in prefixes if p]


def msg_definitions(package):
    """{'pkg/msg/Name': text} for every .msg file of an installed interface package."""
    for share in _share_dirs():
        folder = share / package / "msg"
        if folder.is_dir():
            return {f"{package}/msg/{f.stem}": f.read_text() for f in sorted(folder.glob("*.msg"))}
    raise FileNotFoundError(f"interface package {package} is not installed (run `make setup`)")


@lru_cache(maxsize=1)
def typestore():
    """Kilted type store with the project's interfaces registered (cached)."""
    store = get_typestore(Stores.ROS2_KILTED)
    types = {}
    for package in INTERFACE_PACKAGES:
        for name, text in msg_definitions(package).items():
            if name not in store.types:
                types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


def filter_bag(src, dst, keep):
    """Copy the rosbag2 at src to dst (mcap) with the messages for which keep(topic, t_ns) is true; every
    connection keeps its type and offered QoS (latched topics stay latched)."""
    from rosbags.rosbag2 import Reader, Writer
    from rosbags.rosbag2.enums import StoragePlugin

    store = typestore()
    with Reader(src) as reader, Writer(dst, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        out = {c.id: writer.add_connection(c.topic, c.msgtype, typestore=store,
                                           offered_qos_profiles=c.ext.offered_qos_profiles)
               for c in reader.connections}
        for c, t, raw in reader.messages():
            if keep(c.topic, t):
                writer.write(out[c.id], t, raw)
