"""QoS profiles shared by every agnav node."""
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


def subscribe_input(node, msg_type, topic, callback):
    """A sensor-input subscription with SENSOR_QOS that a user may override with the standard ROS 2 parameters
    `qos_overrides.<topic>.subscription.{reliability,history,depth}` (read-only, set at start), e.g. reliability
    best_effort to match a driver that publishes with SensorDataQoS (a reliable reader never hears it)."""
    return node.create_subscription(msg_type, topic, callback, SENSOR_QOS,
                                    qos_overriding_options=QoSOverridingOptions.with_default_policies())
