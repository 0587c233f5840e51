"""Reading rosbag2 (mcap, sqlite3) and ROS 1 bags as one ordered stream of raw CDR messages (no ROS)."""
import hashlib
import shutil
import tempfile
from pathlib import Path
from typing import NamedTuple

from rosbags.rosbag2 import Reader

from agnav_common.bagio import typestore
from agnav_common.mcap_recording import unfinished


class BagMessage(NamedTuple):
    topic: str
    msgtype: str      # ROS 2 name, e.g. sensor_msgs/msg/Imu
    stamp_ns: int     # bag (receive) time
    data: bytes       # CDR with encapsulation header, ready for rclpy


def as_rosbag2(path, cache_dir=None):
    """Path of a rosbag2 for `path`; a ROS 1 .bag is converted once into a cache keyed by its content."""
    path = Path(path)
    if path.suffix != ".bag":
        return path
    digest = hashlib.sha256(path.read_bytes()).hexdigest()[:16]
    cache = Path(cache_dir or Path(tempfile.gettempdir()) / "agnav_bag_cache")
    dst = cache / f"{path.stem}-{digest}"
    if not (dst / "metadata.yaml").exists():  # written last: marks a complete conversion
        from rosbags.convert import convert  # ~35 ms of imports, for ROS 1 bags only
        shutil.rmtree(dst, ignore_errors=True)
        cache.mkdir(parents=True, exist_ok=True)
        convert([path], dst, dst_storage="mcap", dst_version=9, compress=None, compress_mode="file",
                default_typestore=None, typestore=typestore(), exclude_topics=(), include_topics=(),
                exclude_msgtypes=(), include_msgtypes=())
    return dst


class BagSource:
    """Ordered messages of a bag, optionally filtered by topic and started at an offset (s); read as raw rosbag2
    (a ROS 1 bag converted first), without rosbags' AnyReader, which parses and checks every type definition."""

    def __init__(self, path, topics=None, start_offset=0.0, cache_dir=None):
        """ValueError (one line) for a bag without messages on the selected topics or a killed recording."""
        self.path = as_rosbag2(path, cache_dir)
        if unfinished(self.path):
            raise ValueError(f"{self.path} is an unfinished recording (its recorder was killed): "
                             f"finish it with `agnav recover {self.path}`")
        self._reader = Reader(self.path)
        self._reader.open()
        wanted = set(topics) if topics else None
        self.connections = [c for c in self._reader.connections
                            if (wanted is None or c.topic in wanted)]
        self.start_ns = self._reader.start_time + int(start_offset * 1e9)
        self.end_ns = self._reader.end_time
        self.message_count = sum(c.msgcount for c in self.connections)
        if self.message_count == 0:
            present = sorted({c.topic for c in self._reader.connections if c.msgcount})
            self._reader.close()
            raise ValueError(f"bag {self.path} holds no messages" + (f" on topics {sorted(wanted)}" if wanted else "")
                             + (f" (it has: {', '.join(present)})" if present else ""))

    @property
    def topics(self):
        """{topic: msgtype} of the selected connections."""
        return {c.topic: c.msgtype for c in self.connections}

    def __iter__(self):
        for conn, stamp_ns, raw in self._reader.messages(connections=self.connections, start=self.start_ns):
            yield BagMessage(conn.topic, conn.msgtype, stamp_ns, bytes(raw))

    def close(self):
        self._reader.close()
