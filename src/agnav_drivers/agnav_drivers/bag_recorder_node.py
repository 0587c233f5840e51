"""Bag recorder: writes chosen topics (default: every topic of the graph) to a rosbag2 mcap.

Messages are stored raw with their message definitions (Foxglove and `ros2 bag` open the result) and every
channel with its publishers' offered QoS (`ros2 bag play` republishes latched topics latched),
time-stamped with the node clock (bag time under use_sim_time). Topics appearing later are picked up.
Every `flush_period` seconds (wall time) the messages so far go to disk as a complete mcap chunk: a recorder
killed without closing (SIGKILL, power loss) leaves a folder that `agnav recover DIR` finishes.
On an installed agnav_common.local_bus the graph queries see the bus, and new topics are subscribed at once.
"""
import time
from dataclasses import dataclass, field
from pathlib import Path

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.rosbag2 import StoragePlugin, Writer

from agnav_common import local_bus
from agnav_common.bagio import definition
from agnav_common.mcap_recording import close_recording, flush_recording, write_message
from agnav_common.diagnostics import OK, Diagnostics
from agnav_common.node_main import main_for
from agnav_common.parameters import bounded, declare, leaves
from agnav_common.qos import bag_profiles
from agnav_drivers.ros_types import message_class

ALWAYS_EXCLUDED = ("/rosout", "/parameter_events")


@dataclass
class BagRecorderSettings:
    output: str = ""  # rosbag2 folder to create (required)
    topics: list = field(default_factory=lambda: [""])   # topics recorded; [""] = every topic of the graph
    exclude: list = field(default_factory=lambda: [""])  # topics not recorded (besides /rosout, /parameter_events)
    flush_period: float = field(default=1.0, metadata=bounded(0.05, 60.0))  # s of wall time between writes to disk


def parameter_entries():
    """[(name, default, description)] of every parameter (tools/gen_params.py writes the params file from it)."""
    return leaves(BagRecorderSettings())


class BagRecorderNode(Node):
    def __init__(self, **kwargs):
        super().__init__("bag_recorder", **kwargs)
        p = declare(self, BagRecorderSettings())
        if not p.output:
            raise ValueError("parameter 'output' (rosbag2 folder to create) is required")
        self.topics = [t for t in p.topics if t]
        self.exclude = set(p.exclude) | set(ALWAYS_EXCLUDED)
        self.writer = Writer(Path(p.output), version=9, storage_plugin=StoragePlugin.MCAP)
        self.writer.open()
        self.connections = {}
        self.counts = {}
        self.closed = False
        self.last_write = None  # monotonic time of the last message written (drain detection)
        self._early = []  # messages received before the (sim) clock started, written at its first tick
        # on a local bus with sim time the node clock is the bus time: read it without a clock call per message
        self._bus = local_bus.current() if self.get_clock().ros_time_is_active else None
        self._discover()
        local_bus.on_new_topic(self._discover)  # in-process bus: subscribe before the first message, not 0.2 s later
        steady = Clock(clock_type=ClockType.STEADY_TIME)  # wall time: not stalled by a paused /clock
        self.create_timer(0.2, self._discover, clock=steady)
        self.create_timer(p.flush_period, self.flush, clock=steady)
        self.diagnostics = Diagnostics(self, "bag_recorder")
        self.diagnostics.add("recording", lambda: (OK, f"{sum(self.counts.values())} messages", dict(self.counts)))

    def _discover(self):
        for topic, types in self.get_topic_names_and_types():
            if topic in self.connections or topic in self.exclude or (self.topics and topic not in self.topics):
                continue
            msgtype = types[0]
            try:
                cls = message_class(msgtype)
            except (ImportError, AttributeError):
                continue
            offered = [info.qos_profile for info in self.get_publishers_info_by_topic(topic)]
            known = definition(msgtype)
            if known is None or not offered:  # as rosbag2: no unpublished topics (yet)
                continue
            self.connections[topic] = self.writer.add_connection(
                topic, msgtype, msgdef=known[0], rihs01=known[1], offered_qos_profiles=bag_profiles(topic, offered))
            self.counts[topic] = 0
            qos = self._qos_for(offered)
            self.create_subscription(cls, topic, lambda data, t=topic: self._write(t, data), qos, raw=True)

    @staticmethod
    def _qos_for(offered):
        """Subscription QoS compatible with every publisher: reliable/latched only if all offer it."""
        qos = QoSProfile(history=HistoryPolicy.KEEP_ALL)
        if offered and any(q.reliability == ReliabilityPolicy.BEST_EFFORT for q in offered):
            qos.reliability = ReliabilityPolicy.BEST_EFFORT
        if offered and all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in offered):
            qos.durability = DurabilityPolicy.TRANSIENT_LOCAL
        return qos

    def _write(self, topic, data):
        if self.closed:
            return
        now = self._bus.now if self._bus is not None else self.get_clock().now().nanoseconds  # the same
        if now == 0:
            self._early.append((topic, data))
            return
        if self._early:
            for early_topic, early_data in self._early:
                write_message(self.writer, self.connections[early_topic], now, early_data)
                self.counts[early_topic] += 1
            self._early.clear()
        write_message(self.writer, self.connections[topic], now, data)
        self.counts[topic] += 1
        if topic != "/diagnostics":
            self.last_write = time.monotonic()

    def flush(self):
        """Write what has been recorded so far to disk (a complete chunk)."""
        if not self.closed:
            flush_recording(self.writer, background=True)

    def close(self):
        """Finish the bag file (also done on node destruction)."""
        if not self.closed:
            self.closed = True
            close_recording(self.writer)

    def destroy_node(self):
        self.close()
        return super().destroy_node()


main = main_for(BagRecorderNode)
