"""The bag player latches what the recording says was latched: a topic whose recorded publisher offered
transient-local durability (a base station's /gnss/base/position) reaches a subscriber that joins after the replay
published it, as from the live driver; a volatile topic is replayed volatile."""
from geometry_msgs.msg import PointStamped
from rclpy.experimental import EventsExecutor
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import StoragePlugin, Writer
from sensor_msgs.msg import Imu

from agnav_common.bagio import typestore
from agnav_common.qos import LATCHED_QOS, bag_profiles
from agnav_drivers.bag_player_node import BagPlayerNode

T0_NS = 1_700_000_000_000_000_000


def base_and_imu_bag(path, latched):
    """A rosbag2 with one /gnss/base/position (offered transient-local when `latched`, else volatile) and 20 IMU
    samples, written as the recorder writes offered_qos_profiles."""
    store = typestore()
    base = PointStamped()
    base.header.frame_id, base.point.x, base.point.y, base.point.z = "ecef", -3961904.9, 3348993.8, 3698211.7
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        pos = writer.add_connection("/gnss/base/position", "geometry_msgs/msg/PointStamped", typestore=store,
                                    offered_qos_profiles=bag_profiles("/gnss/base/position",
                                                                      [LATCHED_QOS] if latched else None))
        imu = writer.add_connection("/imu/data_raw", "sensor_msgs/msg/Imu", typestore=store,
                                    offered_qos_profiles=bag_profiles("/imu/data_raw", None))
        writer.write(pos, T0_NS, serialize_message(base))
        for i in range(20):
            writer.write(imu, T0_NS + (i + 1) * 10_000_000, serialize_message(Imu()))
    return path


def replay_then_join(ros, bag):
    """(player, base positions a transient-local subscriber created after the whole replay receives)."""
    player = BagPlayerNode(parameter_overrides=[Parameter("bag", value=str(bag)),
                                                Parameter("external_drive", value=True)])
    late = ros.create_node("late_joiner")
    executor = EventsExecutor()
    executor.add_node(player)
    executor.add_node(late)
    assert not player.play(100)                      # the whole bag published, nobody listening
    got = []
    late.create_subscription(PointStamped, "/gnss/base/position", got.append, LATCHED_QOS)
    for _ in range(200):
        executor.spin_once(timeout_sec=0.01)
        if got:
            break
    durability = {t: p.qos_profile.durability for t, p in player.publishers_.items()}
    player.destroy_node()
    late.destroy_node()
    return durability, got


def test_offered_transient_local_topic_is_latched(ros, tmp_path):
    durability, got = replay_then_join(ros, base_and_imu_bag(tmp_path / "bag", latched=True))
    assert durability == {"/gnss/base/position": DurabilityPolicy.TRANSIENT_LOCAL,
                          "/imu/data_raw": DurabilityPolicy.VOLATILE}
    assert len(got) == 1 and got[0].point.x == -3961904.9 and got[0].header.frame_id == "ecef"


def test_volatile_offer_is_replayed_volatile(ros, tmp_path):
    durability, got = replay_then_join(ros, base_and_imu_bag(tmp_path / "bag", latched=False))
    assert durability["/gnss/base/position"] == DurabilityPolicy.VOLATILE and got == []
