"""agnav_common.local_bus: synchronous depth-first delivery between nodes of one process, sim time that advances
timers and clocks in order before each message, latched topics for late subscriptions, graph queries, and bytes
identical to what DDS carries (agnav_common.bagio.cdr / from_cdr)."""
from pathlib import Path

import pytest
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, NavSatFix
from std_msgs.msg import String

from agnav_common import local_bus
from agnav_common.bagio import cdr, from_cdr, typestore
from agnav_common.local_bus import LocalBus
from agnav_common.qos import LATCHED_QOS, SENSOR_QOS
from agnav_common.stamps import to_stamp

REPO = Path(__file__).resolve().parents[2]
SIM = [Parameter("use_sim_time", value=True)]


@pytest.fixture
def bus(ros):
    with LocalBus() as bus:
        yield bus


def node(ros, name, sim=True):
    return ros.create_node(name, parameter_overrides=SIM if sim else [])


def test_publish_delivers_depth_first_before_returning(ros, bus):
    log = []
    a, b = node(ros, "a"), node(ros, "b")
    relay = b.create_publisher(String, "/out", 10)

    def on_in(msg):
        log.append(("b:in", msg.data))
        relay.publish(String(data=msg.data + "!"))  # delivered (and handled) before on_in returns
        log.append(("b:done", msg.data))

    b.create_subscription(String, "/in", on_in, SENSOR_QOS)
    a.create_subscription(String, "/out", lambda m: log.append(("a:out", m.data)), SENSOR_QOS)
    a.create_subscription(String, "/in", lambda m: log.append(("a:in", m.data)), SENSOR_QOS)
    pub = a.create_publisher(String, "/in", 10)
    pub.publish(String(data="x"))
    assert log == [("b:in", "x"), ("a:out", "x!"), ("b:done", "x"), ("a:in", "x")]  # subscription order
    assert a.count_publishers("/in") == 1 and a.count_subscribers("/in") == 2 and pub.get_subscription_count() == 2
    assert ("/out", ["std_msgs/msg/String"]) in a.get_topic_names_and_types()


def test_type_mismatch_is_not_connected_and_bytes_reach_raw_subscriptions(ros, bus):
    n = node(ros, "n")
    got, raw = [], []
    n.create_subscription(Imu, "/x", got.append, SENSOR_QOS)  # another type than the publisher's: never called
    n.create_subscription(String, "/x", raw.append, SENSOR_QOS, raw=True)
    pub = n.create_publisher(String, "/x", 10)
    pub.publish(String(data="hello"))
    with pytest.raises(TypeError):
        pub.publish(Imu())
    assert got == [] and deserialize_message(raw[0], String).data == "hello"
    assert raw[0] == bytes(typestore().serialize_cdr(typestore().types["std_msgs/msg/String"](data="hello"),
                                                     "std_msgs/msg/String"))


def test_latched_message_reaches_a_later_subscription_once(ros, bus):
    n = node(ros, "n")
    pub = n.create_publisher(NavSatFix, "/map_datum", LATCHED_QOS)
    pub.publish(NavSatFix(latitude=35.0))
    late, volatile = [], []
    n.create_subscription(NavSatFix, "/map_datum", late.append, LATCHED_QOS)
    n.create_subscription(NavSatFix, "/map_datum", volatile.append, SENSOR_QOS)
    assert late == []  # never inside create_subscription
    bus.flush()
    assert [m.latitude for m in late] == [35.0] and volatile == []
    pub.publish(NavSatFix(latitude=36.0))
    assert [m.latitude for m in late] == [35.0, 36.0] and [m.latitude for m in volatile] == [36.0]


def test_clock_fires_due_timers_at_their_time_then_delivers(ros, bus):
    """Timers of sim-time nodes fire in due order with the node clocks at their due time; the clock reaches the
    /clock time before the next message is delivered; a wall-time node's clock is left alone."""
    fast, slow, wall = node(ros, "fast"), node(ros, "slow"), node(ros, "wall", sim=False)
    events = []
    fast.create_timer(0.1, lambda: events.append(("fast", fast.get_clock().now().nanoseconds)))
    slow.create_timer(0.25, lambda: events.append(("slow", slow.get_clock().now().nanoseconds)))
    slow.create_subscription(String, "/m", lambda m: events.append((m.data, slow.get_clock().now().nanoseconds)),
                             SENSOR_QOS)
    clock, msg = fast.create_publisher(Clock, "/clock", 10), fast.create_publisher(String, "/m", 10)
    t0 = 1_000 * 10**9
    for t_ms in (0, 300, 350, 360):
        clock.publish(Clock(clock=to_stamp((t0 + t_ms * 10**6) * 1e-9)))
        msg.publish(String(data=f"m{t_ms}"))
    start = [e for e in events if e[1] == t0]
    assert sorted(start) == [("fast", t0), ("m0", t0), ("slow", t0)]  # overdue at the start: fire at once
    assert events[len(start):] == [("fast", t0 + 100_000_000), ("fast", t0 + 200_000_000),
                                   ("slow", t0 + 250_000_000), ("fast", t0 + 300_000_000), ("m300", t0 + 300_000_000),
                                   ("m350", t0 + 350_000_000), ("m360", t0 + 360_000_000)]
    assert bus.now == t0 + 360_000_000 and wall.get_clock().now().nanoseconds > 1.5e18  # wall time


def test_uninstall_restores_dds(ros):
    with LocalBus():
        assert local_bus.current() is not None
        n = node(ros, "n")
        assert isinstance(n.create_publisher(String, "/a", 10), local_bus.LocalPublisher)
    assert local_bus.current() is None
    assert not isinstance(n.create_publisher(String, "/a", 10), local_bus.LocalPublisher)


def test_publish_also_on_dds_without_a_second_delivery(ros):
    """publish_dds: a DDS subscriber (a viewer) gets each message; bus subscribers get it once, never from DDS."""
    from rclpy.executors import SingleThreadedExecutor
    viewer, seen = ros.create_node("viewer"), []
    viewer.create_subscription(String, "/v", seen.append, SENSOR_QOS)
    with LocalBus(publish_dds=True):
        n, local = node(ros, "n"), []
        n.create_subscription(String, "/v", local.append, SENSOR_QOS)
        pub = n.create_publisher(String, "/v", SENSOR_QOS)
        executor = SingleThreadedExecutor()
        executor.add_node(viewer)
        executor.add_node(n)
        for _ in range(100):  # discovery
            if pub.dds.get_subscription_count():
                break
            executor.spin_once(timeout_sec=0.05)
        for i in range(5):
            pub.publish(String(data=str(i)))
        for _ in range(100):
            if len(seen) == 5:
                break
            executor.spin_once(timeout_sec=0.05)
    assert [m.data for m in seen] == [str(i) for i in range(5)] and [m.data for m in local] == [str(i) for i in range(5)]


def test_cdr_and_from_cdr_match_rclpy_on_a_real_bag():
    """Every message of the bundled loop's first seconds: from_cdr == rclpy's deserialize_message, and cdr of it
    gives back the recorded bytes (zero padding, as DDS and rosbags write)."""
    from agnav_drivers.bag_source import BagSource
    from agnav_drivers.ros_types import message_class
    source = BagSource(REPO / "bags" / "asphalt_loop")
    seen = set()
    for i, m in enumerate(source):
        if i > 3000:
            break
        cls = message_class(m.msgtype)
        msg = from_cdr(m.data, cls)
        assert msg == deserialize_message(m.data, cls) and cdr(msg) == m.data, m.topic
        seen.add(m.topic)
    source.close()
    assert {"/imu/data_raw", "/inclinometer", "/gnss/fix", "/tf_static", "/ground_truth/odometry"} <= seen
