"""A bag replayed through real rclpy nodes in one process arrives complete, in order, with stamps and /clock."""
import pytest
from rclpy.experimental import EventsExecutor
from rclpy.parameter import Parameter
from rosbags.rosbag2 import StoragePlugin
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu

from agnav_common.qos import SENSOR_QOS
from agnav_common.stamps import to_sec, to_stamp
from agnav_drivers.bag_player_node import BagPlayerNode
from agnav_msgs.msg import Inclination
from test.foundation.bagmaker import write_bag

T0 = 1_700_000_000.0


def imu_and_inclinometer_bag(path, storage, n=300):
    msgs = []
    for i in range(n):
        t = T0 + i * 0.01
        imu = Imu()
        imu.header.stamp, imu.header.frame_id = to_stamp(t), "imu_link"
        imu.angular_velocity.z = float(i)
        msgs.append(("/imu/data_raw", "sensor_msgs/msg/Imu", int(t * 1e9) + 2_000_000, imu))
        if i % 10 == 0:
            inc = Inclination(roll=0.001 * i, pitch=-0.001 * i, roll_variance=-1.0, pitch_variance=-1.0)
            inc.header.stamp = to_stamp(t)
            msgs.append(("/inclinometer", "agnav_msgs/msg/Inclination", int(t * 1e9) + 3_000_000, inc))
    bogus = Clock(clock=to_stamp(5.0))  # a recorded /clock must not be replayed
    msgs.append(("/clock", "rosgraph_msgs/msg/Clock", int(T0 * 1e9) + 2_000_000, bogus))
    return write_bag(path, sorted(msgs, key=lambda m: m[2]), storage)


@pytest.mark.parametrize("storage,rate", [(StoragePlugin.MCAP, 0.0), (StoragePlugin.SQLITE3, 5.0)])
def test_replay_complete_ordered_with_clock(ros, tmp_path, storage, rate):
    bag = imu_and_inclinometer_bag(tmp_path / "in", storage)
    node = ros.create_node("probe")
    imus, incs, clocks = [], [], []
    node.create_subscription(Imu, "/imu/data_raw", imus.append, SENSOR_QOS)
    node.create_subscription(Inclination, "/inclinometer", incs.append, SENSOR_QOS)
    node.create_subscription(Clock, "/clock", lambda m: clocks.append(to_sec(m.clock)), 100)
    player = BagPlayerNode(parameter_overrides=[
        Parameter("bag", value=str(bag)), Parameter("rate", value=rate),
        Parameter("min_subscribers", value=1), Parameter("start_delay", value=0.1)])
    executor = EventsExecutor()
    executor.add_node(node)
    executor.add_node(player)
    for _ in range(2000):
        executor.spin_once(timeout_sec=0.01)
        if player.finished and len(imus) == 300 and len(incs) == 30:
            break
    for _ in range(20):
        executor.spin_once(timeout_sec=0.01)
    player.destroy_node()
    node.destroy_node()
    assert [m.angular_velocity.z for m in imus] == [float(i) for i in range(300)]
    assert [to_sec(m.header.stamp) for m in imus] == pytest.approx([T0 + i * 0.01 for i in range(300)], abs=1e-6)
    assert [m.roll for m in incs] == pytest.approx([0.01 * k for k in range(30)])
    assert clocks == sorted(clocks) and len(set(clocks)) == len(clocks)
    assert 5.0 not in clocks
    assert clocks[0] == pytest.approx(T0 + 0.002, abs=1e-6)
    assert clocks[-1] == pytest.approx(T0 + 2.99 + 0.002, abs=1e-6)


def test_player_rejects_missing_bag_parameter(ros):
    with pytest.raises(ValueError, match="bag"):
        BagPlayerNode()
