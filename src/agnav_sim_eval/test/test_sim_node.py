"""Live tractor_sim node: publishes the sensor topics and /clock and follows /steering/command in closed loop."""
import math
import time

from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter

from agnav_common.qos import SENSOR_QOS


def test_live_simulator_follows_steering_command(ros):
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import Imu

    from agnav_sim_eval.sim.scenarios import SCENARIOS
    from agnav_sim_eval.sim_node import TractorSimNode
    from agnav_msgs.msg import SteeringCommand

    sim = TractorSimNode(parameter_overrides=[
        Parameter("scenario", value="asphalt_loop"), Parameter("real_time_factor", value=4.0),
        Parameter("start_standstill_s", value=0.0)])
    probe = ros.create_node("sim_probe")
    got = {"odom": [], "imu": 0, "clock": 0}
    probe.create_subscription(Odometry, "/ground_truth/odometry", lambda m: got["odom"].append(m), SENSOR_QOS)
    probe.create_subscription(Imu, "/imu/data_raw", lambda m: got.__setitem__("imu", got["imu"] + 1), SENSOR_QOS)
    probe.create_subscription(Clock, "/clock", lambda m: got.__setitem__("clock", got["clock"] + 1), 10)
    pub = probe.create_publisher(SteeringCommand, "/steering/command", SENSOR_QOS)
    delta = 0.25
    probe.create_timer(0.05, lambda: pub.publish(SteeringCommand(engaged=True, steering_angle=delta)))
    executor = SingleThreadedExecutor()
    executor.add_node(sim)
    executor.add_node(probe)
    try:
        end = time.monotonic() + 5.0
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
    finally:
        executor.shutdown()
        sim.destroy_node()
        probe.destroy_node()
    assert got["imu"] > 100 and got["clock"] > 100 and len(got["odom"]) > 100
    last = got["odom"][-1]
    speed, wz = last.twist.twist.linear.x, last.twist.twist.angular.z
    assert speed > 0.3
    expected = speed * math.tan(delta) / SCENARIOS["asphalt_loop"].vehicle.wheelbase_m  # bicycle yaw rate
    assert abs(wz - expected) < 0.05 * expected
