"""The live parts of `agnav bench latency`: the synthetic sensor source (a vehicle driving straight east), the probe
that times /odometry/filtered (or the relay's echo) by IMU stamp, and the bare rclpy relay of the baseline."""
import math
import time

import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from geometry_msgs.msg import TwistWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.experimental import EventsExecutor
from sensor_msgs.msg import Imu, NavSatFix

from agnav_common.frames import quaternion_from_euler
from agnav_common.geodesy import LocalTangentPlane
from agnav_common.node_main import init_without_signal_handlers, parent_gone, stop_on_signals
from agnav_common.qos import PUBLISHER_QOS, SENSOR_QOS
from agnav_common.tf import StaticTransformPublisher, make_transform
from agnav_msgs.msg import Inclination

DATUM = (35.996, 139.6, 50.0)
SPEED = 1.0                       # m/s east
GRID_NS = 100_000                 # stamps on a 0.1 ms grid: the key matching odometry to its IMU sample
MAX_BURST = 20                    # samples a late source tick catches up; older ones are skipped (counted)


def key_of(stamp):
    return round((stamp.sec * 1_000_000_000 + stamp.nanosec) / GRID_NS)


class Source:
    """Synthetic sensors on `node`; set_phase(rate, receivers) restarts the schedule (stamps stay increasing)."""

    def __init__(self, node, config, imu_topic, graph):
        self.node, self.graph = node, graph
        self.imu_pub = node.create_publisher(Imu, imu_topic, PUBLISHER_QOS)
        if graph:
            self.incl_pub = node.create_publisher(Inclination, "/inclinometer", PUBLISHER_QOS)
            self.fix_pub = node.create_publisher(NavSatFix, "/gnss/fix", PUBLISHER_QOS)
            self.vel_pub = node.create_publisher(TwistWithCovarianceStamped, "/gnss/vel", PUBLISHER_QOS)
            self.tf = StaticTransformPublisher(node)
            now = node.get_clock().now().to_msg()
            self.tf.send([make_transform(t["parent"], t["child"], now, t.get("xyz", [0] * 3), quaternion_from_euler(
                *t.get("rpy", [0] * 3))) for t in config.static_transforms])  # the config's mounts
            zero = next((n.parameters.get("incl_zero_deg") for n in config.nodes if "incl_zero_deg" in n.parameters),
                        (0.0, 0.0))
            self.incl = Inclination(roll=math.radians(zero[0]), pitch=math.radians(zero[1]),
                                    roll_variance=-1.0, pitch_variance=-1.0)
            self.incl.header.frame_id = "inclinometer_link"
            self.plane = LocalTangentPlane(*DATUM)
        self.imu = Imu()  # one message object, restamped (publish serialises at once)
        self.imu.header.frame_id = "imu_link"
        self.imu.orientation_covariance[0] = -1.0
        self.imu.linear_acceleration.z = 9.80665
        self.imu.angular_velocity_covariance = [1e-6 if i % 4 == 0 else 0.0 for i in range(9)]
        rng = np.random.default_rng(1)  # sensor noise: gyro rad/s, accelerometer m/s^2 (a constant IMU is "stuck")
        self.noise = np.hstack([rng.normal(0.0, 1e-3, (4096, 3)), rng.normal(0.0, 0.01, (4096, 3))]).tolist()
        self.sent = {}    # key -> (monotonic publish time, phase index)
        self.timer, self.phase, self.first_ns = None, -1, None
        self.last_ns = (time.time_ns() // 1_000_000) * 1_000_000
        self.skipped = []

    def set_phase(self, rate, receivers=1):
        if self.timer is not None:
            self.node.destroy_timer(self.timer)
        self.phase += 1
        self.skipped.append(0)
        self.rate, self.period_ns, self.k = rate, round(1e9 / rate), 0
        self.base_ns = self.last_ns + self.period_ns
        self.t0 = time.monotonic()
        self.next_fix = [self.base_ns + round(j * 1e9 / receivers) for j in range(receivers)]
        self.timer = self.node.create_timer(1.0 / rate, self.tick)

    def stop(self):
        if self.timer is not None:
            self.node.destroy_timer(self.timer)
            self.timer = None

    def tick(self):
        n = int((time.monotonic() - self.t0) * self.rate) + 1 - self.k
        if n > MAX_BURST:
            self.skipped[-1] += n - MAX_BURST
            self.k += n - MAX_BURST
            n = MAX_BURST
        for _ in range(n):
            self.sample(self.base_ns + self.k * self.period_ns)
            self.k += 1

    def sample(self, t_ns):
        self.last_ns = t_ns
        stamp = Time(sec=t_ns // 1_000_000_000, nanosec=t_ns % 1_000_000_000)
        if self.graph:
            self.incl.header.stamp = stamp
            self.incl_pub.publish(self.incl)
        gnss = []  # built before the IMU's clock starts: the source's own work is not the graph's latency
        for j, due in enumerate(self.next_fix if self.graph else ()):
            if t_ns >= due:
                gnss += self.fix(stamp, t_ns)
                self.next_fix[j] += 1_000_000_000
        self.imu.header.stamp = stamp
        w, a, n = self.imu.angular_velocity, self.imu.linear_acceleration, self.noise[len(self.sent) % 4096]
        w.x, w.y, w.z, a.x, a.y, a.z = n[0], n[1], n[2], n[3], n[4], 9.80665 + n[5]
        self.sent[t_ns // GRID_NS] = (time.monotonic(), self.phase)
        self.imu_pub.publish(self.imu)
        for pub, msg in gnss:  # after the IMU of their epoch, as a receiver's latency has them
            pub.publish(msg)

    def fix(self, stamp, t_ns):
        """The /gnss/fix and /gnss/vel of epoch t_ns as (publisher, message) pairs."""
        self.first_ns = self.first_ns or t_ns
        east = SPEED * (t_ns - self.first_ns) * 1e-9
        lat, lon, alt = self.plane.to_geodetic(east, 0.0, 2.0)  # antenna 2 m up (gnss_link), level vehicle
        fix = NavSatFix(latitude=float(lat), longitude=float(lon), altitude=float(alt), position_covariance_type=2)
        fix.header.stamp, fix.header.frame_id = stamp, "gnss_link"
        fix.status.status, fix.status.service = 0, 1  # STATUS_FIX, GPS
        fix.position_covariance = [0.02 ** 2, 0.0, 0.0, 0.0, 0.02 ** 2, 0.0, 0.0, 0.0, 0.04 ** 2]
        vel = TwistWithCovarianceStamped()
        vel.header.stamp, vel.header.frame_id = stamp, "gnss_link"
        vel.twist.twist.linear.x = SPEED
        vel.twist.covariance = [0.05 ** 2 if i in (0, 7, 14) else 0.0 for i in range(36)]
        return [(self.fix_pub, fix), (self.vel_pub, vel)]


class Probe:
    """Arrival times by stamp key of /odometry/filtered (graph) or the relay's echo (bare, + one-way hop)."""

    def __init__(self, node, graph):
        self.arrived, self.hop = {}, {}
        if graph:
            node.create_subscription(Odometry, "/odometry/filtered", self.on_msg, SENSOR_QOS)
        else:
            node.create_subscription(Imu, "/bench/imu_echo", self.on_msg, SENSOR_QOS)
        self.graph = graph

    def on_msg(self, msg):
        key = key_of(msg.header.stamp)
        self.arrived.setdefault(key, time.monotonic())
        if not self.graph:
            self.hop[key] = msg.linear_acceleration.x  # the relay's monotonic receive time


def relay_node():
    """Bare rclpy relay: /bench/imu -> /bench/imu_echo, receive time (monotonic) in linear_acceleration.x."""
    node = rclpy.create_node("latency_relay")
    pub = node.create_publisher(Imu, "/bench/imu_echo", PUBLISHER_QOS)

    def on_imu(msg):
        msg.linear_acceleration.x = time.monotonic()
        pub.publish(msg)
    node.create_subscription(Imu, "/bench/imu", on_imu, SENSOR_QOS)
    return node


def run_relay_process():
    init_without_signal_handlers(["--ros-args"])
    stopping = stop_on_signals()
    node = relay_node()
    executor = EventsExecutor()
    executor.add_node(node)
    try:
        while rclpy.ok() and not stopping and not parent_gone():
            executor.spin_once(timeout_sec=0.1)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
