"""qos.subscribe_input and qos.create_output: over DDS outputs leave as bagio.cdr bytes and a raw subscription
decoded by bagio.from_cdr hands the callback the message rclpy would have built; bytes that do not decode are logged
and dropped without stopping the stream; on the deterministic bus the callback gets the published object itself."""
import time

import pytest

pytest.importorskip("rclpy")


def imu(k):
    from sensor_msgs.msg import Imu

    from agnav_common.stamps import to_stamp
    msg = Imu()
    msg.header.stamp, msg.header.frame_id = to_stamp(100.0 + 0.01 * k), "imu_link"
    msg.angular_velocity.z = 0.01 * k
    msg.linear_acceleration.x, msg.linear_acceleration.z = -0.3, 9.81
    msg.angular_velocity_covariance = [1e-6 * (i + 1) for i in range(9)]
    return msg


def spin_until(executor, done, seconds=5.0):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and not done():
        executor.spin_once(timeout_sec=0.02)


def test_over_dds_the_callback_gets_the_message_and_bad_bytes_are_dropped(ros):
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import Imu

    from agnav_common.qos import PUBLISHER_QOS, CdrPublisher, create_output, subscribe_input
    node, driver = ros.create_node("listener"), ros.create_node("driver")
    got = []
    sub = subscribe_input(node, Imu, "/imu/data_raw", got.append)
    assert sub.raw                                       # decoded by bagio, not by rclpy
    carried = []                                         # what DDS delivered, bad bytes included
    node.create_subscription(Imu, "/imu/data_raw", carried.append, PUBLISHER_QOS, raw=True)
    pub = create_output(driver, Imu, "/imu/data_raw", PUBLISHER_QOS)
    assert isinstance(pub, CdrPublisher)
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    ex.add_node(driver)
    spin_until(ex, lambda: pub.get_subscription_count() > 0)
    pub.publish(imu(1))
    spin_until(ex, lambda: got)
    pub.publisher.publish(b"\x00\x01\x00\x00\x07")       # a CDR header and one byte: no Imu
    pub.publish(imu(2))
    spin_until(ex, lambda: len(got) == 2 and len(carried) == 3)
    assert len(carried) == 3 and carried[1] == b"\x00\x01\x00\x00\x07"
    assert carried[0] == serialize_message(imu(1))       # the bytes rclpy would have sent
    assert got == [imu(1), imu(2)] and all(type(m) is Imu for m in got)
    ex.shutdown()
    driver.destroy_node()
    node.destroy_node()


def test_on_the_bus_the_callback_gets_the_published_object(ros):
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import Imu

    from agnav_common.local_bus import LocalBus
    from agnav_common.qos import PUBLISHER_QOS, CdrPublisher, create_output, subscribe_input
    with LocalBus():
        node = ros.create_node("listener", parameter_overrides=[Parameter("use_sim_time", value=True)])
        got = []
        assert not subscribe_input(node, Imu, "/imu/data_raw", got.append).raw
        msg = imu(1)
        pub = create_output(node, Imu, "/imu/data_raw", PUBLISHER_QOS)
        assert not isinstance(pub, CdrPublisher)
        pub.publish(msg)
        assert got == [msg] and got[0] is msg
        node.destroy_node()
