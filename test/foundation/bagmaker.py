"""Small rosbag2 files for tests, written with rosbags from rclpy messages."""
from pathlib import Path

from rclpy.serialization import serialize_message
from rosbags.rosbag2 import StoragePlugin, Writer

from agnav_common.bagio import typestore


def write_bag(path, messages, storage=StoragePlugin.MCAP):
    """messages: iterable of (topic, msgtype, t_ns, rclpy message) -> rosbag2 at path."""
    store = typestore()
    connections = {}
    with Writer(Path(path), version=9, storage_plugin=storage) as writer:
        for topic, msgtype, t_ns, msg in messages:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(connections[topic], t_ns, serialize_message(msg))
    return Path(path)
