"""Measures the SteeringNode fail-safe through real rclpy: stream healthy odometry, engage, stop the stream and
time (wall clock) from the last odometry publish to the first neutral, disengaged /steering/command."""
import os
import time

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

import rclpy  # noqa: E402
from agnav_msgs.msg import SteeringCommand  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from std_srvs.srv import SetBool  # noqa: E402

from .steering_node import SteeringNode  # noqa: E402


def _odometry(stamp, x):
    msg = Odometry()
    msg.header.stamp, msg.header.frame_id, msg.child_frame_id = stamp, "map", "base_link"
    msg.pose.pose.position.x, msg.pose.pose.position.y = x, 0.05
    msg.pose.pose.orientation.w = 1.0
    cov = [0.0] * 36
    cov[0] = cov[7] = cov[35] = 1e-4
    msg.pose.covariance = cov
    msg.twist.twist.linear.x = 2.0
    return msg


def measure_reaction(trials: int = 5, rate_hz: float = 100.0, timeout: float = 2.0) -> list[float]:
    """Reaction times (s), one per trial."""
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = SteeringNode(context=ctx, parameter_overrides=[Parameter("line.a", value=[0.0, 0.0]),
                                                          Parameter("line.b", value=[100.0, 0.0])])
    peer = rclpy.create_node("watchdog_probe", context=ctx)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    executor.add_node(peer)
    pub = peer.create_publisher(Odometry, "/odometry/filtered", 100)
    neutral = []
    peer.create_subscription(SteeringCommand, "/steering/command",
                             lambda m: neutral.append(time.monotonic()) if not m.engaged else None, 100)
    client = peer.create_client(SetBool, "/steering/engage")
    reactions, x = [], 0.0

    def spin_until(predicate, seconds):
        end = time.monotonic() + seconds
        while not predicate() and time.monotonic() < end:
            executor.spin_once(timeout_sec=0.001)

    def stream(seconds):
        nonlocal x
        end, last = time.monotonic() + seconds, 0.0
        while time.monotonic() < end:
            x += 0.02
            pub.publish(_odometry(node.get_clock().now().to_msg(), x))
            last = time.monotonic()
            spin_until(lambda: time.monotonic() - last >= 1.0 / rate_hz, 1.0 / rate_hz)
        return last

    try:
        client.wait_for_service(timeout_sec=5.0)
        for _ in range(trials):
            stream(0.3)
            future = client.call_async(SetBool.Request(data=True))
            spin_until(future.done, timeout)
            if not (future.done() and future.result().success):
                raise RuntimeError(f"engage refused: {future.result().message if future.done() else 'timeout'}")
            last = stream(0.2)
            neutral.clear()
            spin_until(lambda: bool(neutral), timeout)
            if not neutral:
                raise RuntimeError("no neutral command after odometry stopped")
            reactions.append(neutral[0] - last)
    finally:
        executor.shutdown()
        node.destroy_node()
        peer.destroy_node()
        rclpy.shutdown(context=ctx)
    return reactions
