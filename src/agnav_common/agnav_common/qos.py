"""QoS profiles shared by every agnav node, and their rosbag2 form (offered_qos_profiles of a recording).
Wire format: over DDS, sensor inputs arrive as serialized bytes decoded by bagio.from_cdr and high-rate outputs
leave as bagio.cdr bytes (rclpy's own conversion costs several times more); on the deterministic bus
(agnav_common.local_bus) messages pass as objects."""
import math
import time

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.qos_overriding_options import QoSOverridingOptions

# Sensor-stream subscriptions: reliable, keep-all: every sample stays queued until the callback takes it, so a
# node in another process that falls behind a replay loses nothing (the player waits for acknowledgements).
SENSOR_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
# Sensor-stream publishers: reliable, keep-last 100 (1 s at 100 Hz): publish() never blocks a driver or filter.
PUBLISHER_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE)
# Latched topics (/tf_static, /map_datum): late joiners get the last message.
LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
LATCHED_NAMES = ("tf_static", "map_datum")  # last name part: /tractor1/map_datum is latched too


def subscribe_input(node, msg_type, topic, callback):
    """A sensor-input subscription with SENSOR_QOS that a user may override with the standard ROS 2 parameters
    `qos_overrides.<topic>.subscription.{reliability,history,depth}` (read-only, set at start), e.g. reliability
    best_effort to match a driver that publishes with SensorDataQoS (a reliable reader never hears it).
    Over DDS it takes the serialized message and decodes it with bagio.from_cdr (the message rclpy would build, at a
    fraction of rclpy's cost); on the deterministic bus (agnav_common.local_bus) it takes the published object."""
    from agnav_common import local_bus
    options = {"qos_overriding_options": QoSOverridingOptions.with_default_policies()}
    if local_bus.current() is not None:
        return node.create_subscription(msg_type, topic, callback, SENSOR_QOS, **options)
    return node.create_subscription(msg_type, topic, _decoding(node, msg_type, topic, callback), SENSOR_QOS,
                                    raw=True, **options)


def create_output(node, msg_type, topic, qos):
    """A publisher for a high-rate output: publish(msg) sends the message's bagio.cdr bytes over DDS (a fraction
    of rclpy's serialization, zeroed padding); on the deterministic bus the plain publisher (it passes objects)."""
    from agnav_common import local_bus
    publisher = node.create_publisher(msg_type, topic, qos)
    return publisher if local_bus.current() is not None else CdrPublisher(publisher)


class CdrPublisher:
    """An rclpy publisher whose publish(msg) sends msg as bagio.cdr bytes; everything else is the publisher's."""

    def __init__(self, publisher):
        from agnav_common.bagio import cdr
        self.publisher, self._cdr = publisher, cdr

    def publish(self, msg):
        self.publisher.publish(self._cdr(msg))

    def __getattr__(self, name):
        return getattr(self.publisher, name)


def _decoding(node, msg_type, topic, callback):
    """callback(message) of serialized bytes; bytes that do not decode are an error in the log, never a crash."""
    from agnav_common.bagio import from_cdr
    logged = [-math.inf]    # monotonic time of this topic's last such error (one line per 5 s and topic)

    def on_bytes(data):
        try:
            msg = from_cdr(data, msg_type)
        except Exception as exc:  # noqa: BLE001  (struct, index, unicode or rclpy errors of malformed bytes)
            if time.monotonic() - logged[0] >= 5.0:
                logged[0] = time.monotonic()
                node.get_logger().error(f"{topic}: dropped a message that does not decode as {msg_type.__name__} "
                                        f"({type(exc).__name__}: {exc})")
            return
        callback(msg)
    return on_bytes


def known_profile(topic):
    """The QoS agnav's own publishers offer on `topic`."""
    return LATCHED_QOS if topic.rsplit("/", 1)[-1] in LATCHED_NAMES else PUBLISHER_QOS


def bag_profiles(topic, offered):
    """rosbags Qos list for a recording's offered_qos_profiles (written as rosbag2 Kilted does: policies as lowercase
    names, durations as {sec, nsec}) from the rclpy QoSProfiles of the topic's publishers; none: known_profile.
    Fast DDS reports no history of remote writers (unknown, depth 0; rosbag2 records that too): on latched topics
    the known keep-last 1 fills in."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    def time(duration):
        return QosTime(*divmod(duration.nanoseconds, 1_000_000_000))

    known = known_profile(topic)
    profiles = []
    for q in offered or [known]:
        history, depth = q.history, q.depth
        if history == HistoryPolicy.UNKNOWN and known is LATCHED_QOS:
            history, depth = known.history, known.depth
        profiles.append(Qos(QosHistory(int(history)), depth, QosReliability(int(q.reliability)),
                            QosDurability(int(q.durability)), time(q.deadline), time(q.lifespan),
                            QosLiveliness(int(q.liveliness)), time(q.liveliness_lease_duration),
                            q.avoid_ros_namespace_conventions))
    return profiles
