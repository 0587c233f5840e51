"""Bag player: replays a rosbag2/ROS 1 bag with its timing (scaled by `rate`) or as fast as possible.

rate > 0 keeps the bag's timing scaled by rate; rate 0 publishes as fast as the graph consumes: at most
`window` messages ahead of what this node's own probe subscriptions have received (in one process with the
EventsExecutor's FIFO events, every earlier message has then been handled by every node), and a message
that a lagging subscriber in another process cannot take yet is held and retried (see REPLAY_QOS), so a slow
node slows the replay instead of losing data.
`external_drive`: no timer and no flow control; the owner calls play() (agnav run's deterministic replay, where
agnav_common.local_bus delivers every message to the whole graph before publish() returns).
Publishes /clock from the bag timeline (a recorded /clock is not replayed); /tf_static, /map_datum and every topic
whose recorded publisher offered transient-local durability (the connection's offered_qos_profiles, e.g. a base
station's /gnss/base/position) latched (transient-local, keep-last 1) for subscribers that join late; a bag's
latched topic other than /tf_static only when no node of the graph publishes it.
`progress` shows a tqdm bar on stderr when it is a terminal (nothing in files and CI logs).
"""
import itertools
import sys
import time
from dataclasses import dataclass, field

from rclpy._rclpy_pybind11 import RCLError
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.interfaces import QosDurability
from rosgraph_msgs.msg import Clock
from tqdm import tqdm

from agnav_common.diagnostics import OK, WARN, Diagnostics
from agnav_common.message_factory import new_message
from agnav_common.node_main import main_for
from agnav_common.parameters import declare, leaves
from agnav_common.qos import LATCHED_QOS, SENSOR_QOS
from agnav_drivers.bag_source import BagSource
from agnav_drivers.ros_types import message_class

LATCHED_TOPICS = ("/tf_static", "/map_datum")   # latched whatever the bag says (older bags lack offered QoS)
# Keep-all writer: while a subscriber (keep-all, SENSOR_QOS) lags, its unacknowledged samples fill the writer's
# history and publish() fails; the player then holds the message and retries instead of dropping it.
REPLAY_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)


@dataclass
class BagPlayerSettings:
    bag: str = ""                # rosbag2 folder, .mcap, .db3 or ROS 1 .bag to replay (required)
    rate: float = 1.0            # bag time per wall time; 0 = as fast as the graph consumes (flow control)
    topics: list = field(default_factory=lambda: [""])   # bag topics replayed; [""] = every topic
    remap: list = field(default_factory=lambda: [""])    # "bag_topic:=graph_topic" entries; [""] = none
    exclude: list = field(default_factory=lambda: [""])  # bag topics not replayed; [""] = none
    start_offset: float = 0.0    # s of the bag skipped at its start
    loop: bool = False           # restart at the end of the bag instead of finishing
    clock: bool = True           # publish /clock from the bag timeline
    progress: bool = False       # tqdm progress bar on stderr when it is a terminal
    window: int = 20             # messages published ahead of what the probes have received (rate 0)
    start_delay: float = 1.0     # s before the first message (subscribers in other processes discover us)
    min_subscribers: int = 0     # subscribers every topic waits for before the start (at most 10 s); rate 0 adds
    # this node's probe
    cache_dir: str = ""          # folder of ROS 1 bags converted to rosbag2; "" = the system temp folder
    external_drive: bool = False  # no timer, no flow control: the owner calls play() (deterministic replay)


def offered_latched(connection):
    """True when the bag's publisher of `connection` offered transient-local durability (rosbag2
    offered_qos_profiles; rosbags converts a ROS 1 latching publisher to it)."""
    profiles = getattr(connection.ext, "offered_qos_profiles", None) or []
    return any(getattr(q, "durability", None) == QosDurability.TRANSIENT_LOCAL for q in profiles)


def parameter_entries():
    """[(name, default, description)] of every parameter (tools/gen_params.py writes the params file from it)."""
    return leaves(BagPlayerSettings())


class BagPlayerNode(Node):
    def __init__(self, **kwargs):
        super().__init__("bag_player", **kwargs)
        self.source, self._bar = None, None  # destroy_node works on a node whose construction failed
        p = declare(self, BagPlayerSettings())
        if not p.bag:
            raise ValueError("parameter 'bag' (path of a rosbag2 folder, .mcap, .db3 or ROS 1 .bag) is required")
        self.rate, self.external, self.window = p.rate, p.external_drive, p.window
        self.loop, self.progress = p.loop, p.progress
        remap = dict(r.split(":=", 1) for r in p.remap if r)
        self.source = BagSource(p.bag, topics=[t for t in p.topics if t] or None,
                                start_offset=p.start_offset, cache_dir=p.cache_dir or None)
        self.publishers_ = {}
        self.skipped = {}
        self.withheld = []  # latched bag topics the graph publishes itself
        self.latched = set(LATCHED_TOPICS) | {c.topic for c in self.source.connections if offered_latched(c)}
        self._matched = set()  # topics that have had a subscriber
        self.published = 0
        self.received = 0
        self.retries = 0
        exclude = {t for t in p.exclude if t}
        for topic, msgtype in self.source.topics.items():
            if topic == "/clock" or topic in exclude:
                continue
            try:
                cls = message_class(msgtype)
            except (ImportError, AttributeError):
                self.skipped[topic] = msgtype
                self.get_logger().warning(f"{topic}: type {msgtype} is not installed here; not replayed")
                continue
            out = remap.get(topic, topic)
            qos = LATCHED_QOS if topic in self.latched else REPLAY_QOS
            self.publishers_[topic] = self.create_publisher(cls, out, qos)
            if self.rate == 0.0 and not self.external:  # probes: count what the graph has received
                self.create_subscription(cls, out, self._on_probe, SENSOR_QOS, raw=True)
        self.clock_pub = self.create_publisher(Clock, "/clock", 10) if p.clock else None
        self.finished = False
        self._iter = None
        self._start_wall = None
        self._t0 = None
        self._last_clock = -1
        self._pending = None
        self._last_progress = 0.0
        # Start once every topic has min_subscribers matched (probe and recorder count) and start_delay
        # has passed, so that subscribers in other processes have discovered us; give up waiting after 10 s.
        self.min_subscribers = p.min_subscribers + (1 if self.rate == 0.0 else 0)
        self._ready_at = time.monotonic() + p.start_delay
        self.diagnostics = Diagnostics(self, "bag_player")
        self.diagnostics.add("replay", self._diagnose)
        if not self.external:
            self.create_timer(0.002, self._tick)

    def _on_probe(self, _):
        self.received += 1

    def _diagnose(self):
        lost = self._subscribers_lost()
        level = WARN if self.skipped or lost else OK
        message = f"subscribers lost: {','.join(lost)}" if lost else "finished" if self.finished else "playing"
        return level, message, {
            "published": self.published, "retries": self.retries, "skipped_topics": ",".join(self.skipped) or "none",
            "withheld_topics": ",".join(self.withheld) or "none", "subscribers_lost": ",".join(lost) or "none"}

    def _subscribers_lost(self):
        """Topics whose every subscriber (but this node's probes) has gone since it was matched: the graph that
        consumed the replay is gone (a node died, the link to another computer is down)."""
        own = 1 if self.rate == 0.0 and not self.external else 0
        lost = []
        for topic, pub in self.publishers_.items():
            if pub.get_subscription_count() > own:
                self._matched.add(topic)
            elif topic in self._matched:
                lost.append(topic)
        return lost

    def _check_sole_publisher(self):
        """A node that publishes a replayed topic would mix its output into the recording's input (and into the
        probes' count): refuse to play; `remap` (a config's bag_remap) moves the bag's topic aside. A latched output
        that the graph publishes itself (the navigation node's /map_datum) is withheld instead: the graph's value
        is the one in force, so a recording holds one datum. /tf_static adds up over publishers: always replayed."""
        for topic, pub in list(self.publishers_.items()):
            if topic == "/tf_static" or self.count_publishers(pub.topic_name) <= 1:
                continue
            if topic not in self.latched:
                raise RuntimeError(f"another node publishes {pub.topic_name}, which the bag replays as {topic}: "
                                   "remap the bag topic (player parameter remap, config bag_remap), or leave it "
                                   "out (exclude, agnav run --exclude)")
            self.withheld.append(topic)
            self.get_logger().info(f"{pub.topic_name} is published by the graph: the bag's {topic} is not replayed")
            self.destroy_publisher(self.publishers_.pop(topic))

    def _restart(self):
        self._iter = iter(self.source)
        self._start_wall = time.monotonic()
        self._t0 = None

    def _ready(self):
        now = time.monotonic()
        if now < self._ready_at:
            return False
        matched = all(pub.get_subscription_count() >= self.min_subscribers for pub in self.publishers_.values())
        return matched or now > self._ready_at + 10.0

    def _tick(self):
        if self.finished or (self._iter is None and not self._ready()):
            return
        if self._iter is None:
            self._check_sole_publisher()
            self._restart()
        budget = self.window - (self.published - self.received) if self.rate == 0.0 else 10_000
        while budget > 0:
            msg = self._pending or next(self._iter, None)
            self._pending = None
            if msg is None:
                if self.loop:
                    self._restart()
                    continue
                self._finish()
                return
            if self._t0 is None:
                self._t0 = msg.stamp_ns
            if self.rate > 0.0 and (msg.stamp_ns - self._t0) / 1e9 / self.rate > time.monotonic() - self._start_wall:
                self._pending = msg
                break
            if not self._publish(msg):
                self._pending = msg  # a subscriber lags: retry on the next tick
                break
            budget -= 1
        self._show_progress()

    def play(self, count):
        """External drive: publish the next `count` bag messages (with /clock); False once the bag has ended."""
        if self._iter is None:
            self._check_sole_publisher()
            self._restart()
        for msg in itertools.islice(self._iter, count):
            if self._t0 is None:
                self._t0 = msg.stamp_ns
            self._publish(msg)
            count -= 1
        self._show_progress()
        if count > 0:
            self._finish()
        return count == 0

    def _publish(self, msg):
        """Publish one bag message (and /clock); False when the writer is full and it must be retried."""
        if self.clock_pub is not None and msg.stamp_ns > self._last_clock:
            self._last_clock = msg.stamp_ns
            clock = new_message(Clock)
            clock.clock.sec, clock.clock.nanosec = divmod(msg.stamp_ns, 1_000_000_000)  # the bag time exactly
            self.clock_pub.publish(clock)
        pub = self.publishers_.get(msg.topic)
        if pub is not None:
            try:
                pub.publish(msg.data)
            except RCLError:
                self.retries += 1
                return False
            self.published += 1
        return True

    def _show_progress(self, final=False):
        now = time.monotonic()
        if not self.progress or self._t0 is None or not (final or now - self._last_progress > 0.25):
            return
        self._last_progress = now
        span = max(self.source.end_ns - self.source.start_ns, 1) * 1e-9
        if self._bar is None:
            self._bar = tqdm(total=round(span, 1), unit="s", desc="replay", disable=not sys.stderr.isatty(),
                             bar_format="{desc} {percentage:5.1f}%|{bar}| {n:.1f}/{total:.1f} s bag [{elapsed}{postfix}]")
        done = round(min(max((self._last_clock - self.source.start_ns) * 1e-9, 0.0), span), 1)
        self._bar.set_postfix_str(f"{self.published} msgs", refresh=False)
        self._bar.update(done - self._bar.n)

    def _finish(self):
        self.finished = True
        self._show_progress(final=True)
        self._close_bar()
        self.get_logger().info(f"replay finished: {self.published} messages")

    def _close_bar(self):
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def destroy_node(self):
        self._close_bar()
        if self.source is not None:
            self.source.close()
        return super().destroy_node()


main = main_for(BagPlayerNode)
