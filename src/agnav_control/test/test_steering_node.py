"""SteeringNode through real rclpy (localhost DDS): state/command topics, services, watchdog, teaching."""
import math
import os
import time

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", "65")

import pytest  # noqa: E402

rclpy = pytest.importorskip("rclpy")
agnav_msgs = pytest.importorskip("agnav_msgs.msg")

from agnav_common.frames import quaternion_from_euler  # noqa: E402
from agnav_common.stamps import to_stamp  # noqa: E402
from agnav_control.steering_node import SteeringNode  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from std_srvs.srv import SetBool, Trigger  # noqa: E402


class Harness:
    def __init__(self, **params):
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        overrides = [Parameter(k, value=v) for k, v in params.items()]
        self.node = SteeringNode(context=self.ctx, parameter_overrides=overrides)
        self.peer = rclpy.create_node("steering_test_peer", context=self.ctx)
        self.pub = self.peer.create_publisher(Odometry, "/odometry/filtered", 100)
        self.states, self.commands, self.diags = [], [], []
        self.peer.create_subscription(agnav_msgs.GuidanceState, "/guidance/state", self.states.append, 100)
        self.peer.create_subscription(agnav_msgs.SteeringCommand, "/steering/command", self.commands.append, 100)
        self.peer.create_subscription(DiagnosticArray, "/diagnostics", self.diags.append, 100)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self.executor.add_node(self.peer)

    def spin(self, seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.005)

    def odom(self, x, y, yaw, speed=2.0, var=1e-4, stamp=None, age=0.0, cov=None, twist_var=0.0, lateral=0.0):
        """Publish one odometry message stamped `stamp` (s), else the node clock minus `age` (s); `cov`
        {index: value} overrides pose covariance entries; returns the stamp."""
        msg = Odometry()
        stamp = self.node.get_clock().now().nanoseconds * 1e-9 - age if stamp is None else stamp
        msg.header.stamp = to_stamp(stamp)
        msg.header.frame_id, msg.child_frame_id = "map", "base_link"
        msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
        q = quaternion_from_euler(0.0, 0.0, yaw)
        o = msg.pose.pose.orientation
        o.x, o.y, o.z, o.w = q
        pose_cov = [0.0] * 36
        pose_cov[0] = pose_cov[7] = pose_cov[35] = var
        for i, v in (cov or {}).items():
            pose_cov[i] = v
        msg.pose.covariance = pose_cov
        msg.twist.covariance[0] = twist_var
        msg.twist.twist.linear.x, msg.twist.twist.linear.y = speed, lateral
        self.pub.publish(msg)
        self.spin(0.02)
        return stamp

    def call(self, srv_type, name, **fields):
        client = self.peer.create_client(srv_type, name)
        assert client.wait_for_service(timeout_sec=5.0)
        future = client.call_async(srv_type.Request(**fields))
        end = time.monotonic() + 5.0
        while not future.done() and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.01)
        return future.result()

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        self.peer.destroy_node()
        rclpy.shutdown(context=self.ctx)


@pytest.fixture
def harness():
    h = Harness(**{"line.a": [0.0, 0.0], "line.b": [100.0, 0.0], "controller": "pid"})
    h.spin(0.3)  # discovery
    yield h
    h.close()


def test_state_engage_stale_and_no_self_reengage(harness):
    h = harness
    for k in range(15):
        h.odom(k * 0.04, 0.5, 0.0)
    assert h.states and all(not s.engaged for s in h.states)
    assert h.states[-1].cross_track_error == pytest.approx(0.5)
    assert all(not c.engaged and c.steering_angle == 0.0 for c in h.commands)

    assert h.call(SetBool, "/steering/engage", data=True).success
    for k in range(15, 30):
        h.odom(k * 0.04, 0.5, 0.0)
    engaged = [c for c in h.commands if c.engaged]
    assert engaged and engaged[-1].steering_angle < 0.0  # left of the line: steer right

    n_before = len(h.commands)
    h.spin(0.6)  # odometry stops: timer watchdog must command neutral
    after = h.commands[n_before:]
    assert after and not after[-1].engaged and after[-1].steering_angle == 0.0
    statuses = [s for d in h.diags for s in d.status if s.name.endswith("autosteer")]
    assert any("stale" in s.message for s in statuses)

    for k in range(30, 45):  # odometry resumes healthy: stays disengaged
        h.odom(k * 0.04, 0.5, 0.0)
    assert not h.commands[-1].engaged and not h.states[-1].engaged


def test_dgps_status_opens_the_decimetre_gates_and_crab_feeds_forward(harness):
    h = harness
    honest = {0: 0.8**2, 7: 0.8**2, 35: math.radians(1.6) ** 2}  # NMEA DGPS without GST, unseen-crab heading σ
    for k in range(5):
        h.odom(k * 0.04, 0.0, 0.0, cov=honest)
    reply = h.call(SetBool, "/steering/engage", data=True)
    assert not reply.success and "position std" in reply.message
    status_pub = h.peer.create_publisher(agnav_msgs.GnssStatus, "/gnss/status", 10)
    h.spin(0.3)  # discovery
    status_pub.publish(agnav_msgs.GnssStatus(fix_type=agnav_msgs.GnssStatus.FIX_DGPS))
    h.spin(0.1)
    for k in range(5, 10):
        h.odom(k * 0.04, 0.0, 0.0, cov=honest)
    assert h.call(SetBool, "/steering/engage", data=True).success
    # on the line, yaw along it, sliding right at 0.03 rad: the course error -0.03 rad steers left
    for k in range(10, 20):
        h.odom(k * 0.04, 0.0, 0.0, cov=honest, lateral=-2.0 * math.tan(0.03))
    assert h.commands[-1].engaged and h.commands[-1].steering_angle > 0.0
    assert h.states[-1].heading_error == pytest.approx(0.0)  # GuidanceState keeps the body heading error


def test_nan_odometry_never_published_and_refused_engage(harness):
    h = harness
    for k in range(10):
        h.odom(k * 0.04, 0.2, 0.0)
    assert h.call(SetBool, "/steering/engage", data=True).success
    h.odom(0.5, float("nan"), 0.0)
    assert not h.commands[-1].engaged
    for msg in h.states + h.commands:
        assert all(math.isfinite(v) for v in (getattr(msg, f, 0.0) for f in ("cross_track_error", "heading_error", "steering_angle")))
    h.odom(0.6, 0.2, 0.0, speed=0.0)
    reply = h.call(SetBool, "/steering/engage", data=True)
    assert not reply.success and "speed" in reply.message


def test_teach_and_set_line_here(harness):
    h = harness
    assert h.call(SetBool, "/steering/teach", data=True).success
    for k in range(60):  # 6 m north-east at 45 deg
        d = 0.1 * k
        h.odom(10.0 + d * math.cos(0.785), 5.0 + d * math.sin(0.785), 0.785)
    reply = h.call(SetBool, "/steering/teach", data=False)
    assert reply.success, reply.message
    h.odom(20.0, 5.0, 0.785)
    assert h.states[-1].line_yaw == pytest.approx(0.785, abs=1e-3)
    assert h.call(Trigger, "/steering/set_line_here").success
    h.odom(20.0, 6.0, 1.0)
    assert h.states[-1].line_yaw == pytest.approx(0.785, abs=1e-3)
    assert h.states[-1].cross_track_error == pytest.approx(math.cos(0.785), abs=1e-3)


def test_watchdog_probe_gets_neutral_command_each_trial():
    from agnav_control.watchdog_probe import measure_reaction
    reactions = measure_reaction(trials=2)
    assert len(reactions) == 2 and all(r > 0.0 for r in reactions)


def test_engage_when_ready_is_one_shot():
    h = Harness(**{"line.a": [0.0, 0.0], "line.b": [100.0, 0.0], "engage_when_ready": True})
    try:
        h.spin(0.3)
        h.odom(0.0, 0.1, 0.0, speed=0.0)  # too slow: not yet
        assert not h.commands[-1].engaged
        for k in range(5):
            h.odom(0.04 * k, 0.1, 0.0)
        assert h.commands[-1].engaged
        assert h.call(SetBool, "/steering/engage", data=False).success
        for k in range(5, 15):
            h.odom(0.04 * k, 0.1, 0.0)
        assert not h.commands[-1].engaged
    finally:
        h.close()
