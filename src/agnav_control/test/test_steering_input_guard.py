"""SteeringNode odometry input guard through real rclpy: stamp age against the node clock (wall, sim time, or a
live simulator's /clock), invalid covariances, lone future and backwards stamps, windowed diagnostics."""
import math
import os

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", "65")

import pytest  # noqa: E402

rclpy = pytest.importorskip("rclpy")
pytest.importorskip("agnav_msgs.msg")

from agnav_common.diagnostics import ERROR  # noqa: E402
from agnav_common.stamps import to_stamp  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402
from std_srvs.srv import SetBool  # noqa: E402
from test_steering_node import Harness  # noqa: E402

# the receive-time timeout (tested in test_steering_node) is relaxed so that a stall of a loaded machine cannot
# trip the watchdog before the stamp rules under test do
LINE = {"line.a": [0.0, 0.0], "line.b": [100.0, 0.0], "watchdog.stale_timeout": 1.0}


@pytest.fixture
def harness():
    h = Harness(**LINE, **{"diagnostics.window": 1.0})
    h.spin(0.3)  # discovery
    yield h
    h.close()


def engaged_on(h, n=10, x0=0.0):
    for k in range(n):
        h.odom(x0 + 0.04 * k, 0.2, 0.0)
    assert h.call(SetBool, "/steering/engage", data=True).success
    stamp = h.odom(x0 + 0.04 * n, 0.2, 0.0)
    assert h.commands[-1].engaged
    return stamp


def status(h):
    level, message, values = h.node._diagnose()
    return level, message, values


def test_old_stamps_refuse_engage_and_disengage(harness):
    h = harness
    for k in range(10):  # received now, measured 2 s ago
        h.odom(0.04 * k, 0.2, 0.0, age=2.0)
    reply = h.call(SetBool, "/steering/engage", data=True)
    assert not reply.success and "old" in reply.message
    assert "old" in status(h)[2]["fault"] and float(status(h)[2]["stamp_age"]) > 2.0
    stamp = engaged_on(h, x0=1.0)
    for k in range(40):  # a lagging source: messages keep coming, each measured only 1 ms after the previous
        h.odom(2.0 + 0.04 * k, 0.2, 0.0, stamp=stamp + 0.001 * (k + 1))
        if not h.node.watchdog.engaged:
            break
    h.spin(0.05)
    assert not h.commands[-1].engaged and h.commands[-1].steering_angle == 0.0
    assert "old (max 0.3 s)" in h.node.watchdog.transitions[-1].reason
    h.odom(4.0, 0.2, 0.0, stamp=stamp + 0.05)  # a further old message is counted
    level, message, values = status(h)
    assert "fail-safe" in message and "old" in message and level == ERROR
    assert int(values["odometry.old_stamp"].split()[0]) >= 1


@pytest.mark.parametrize("cov, twist_var, reason", [({7: math.nan}, 0.0, "pose nan covariance"),
                                                      ({35: -1e-4}, 0.0, "pose negative covariance"),
                                                      ({}, math.inf, "twist nan covariance")])
def test_invalid_covariance_disengages_with_a_diagnostic(harness, cov, twist_var, reason):
    h = harness
    engaged_on(h)
    h.odom(0.5, 0.2, 0.0, cov=cov, twist_var=twist_var)
    assert not h.commands[-1].engaged and h.commands[-1].steering_angle == 0.0
    level, message, values = status(h)
    assert f"invalid odometry: {reason}" in message
    assert values[f"odometry.{reason.replace(' ', '_')}"].startswith("1 in the last")
    reply = h.call(SetBool, "/steering/engage", data=True)
    assert not reply.success and reason in reply.message


def test_lone_future_and_backwards_stamps_are_dropped_and_the_stream_goes_on(harness):
    h = harness
    stamp = engaged_on(h)
    n_states = len(h.states)
    h.odom(0.5, 0.2, 0.0, age=-10.0)  # one message stamped 10 s ahead
    h.odom(0.5, 0.2, 0.0, stamp=stamp - 0.01)  # and one before the last accepted
    assert len(h.states) == n_states
    for k in range(10):
        h.odom(0.6 + 0.04 * k, 0.2, 0.0)
    assert len(h.states) == n_states + 10 and h.commands[-1].engaged  # nothing lost, still steering
    level, message, values = status(h)
    assert values["odometry.stamp_ahead_of_clock"].startswith("1 in the last 1 s, 1 total")
    assert values["odometry.backwards_stamp"].startswith("1 in the last 1 s, 1 total")
    assert "engaged; odometry problems" in message
    for k in range(10, 70):  # 1.2 s later the window has forgotten them; the totals stay
        h.odom(0.6 + 0.04 * k, 0.2, 0.0)
    level, message, values = status(h)
    assert message == "engaged" and values["odometry.stamp_ahead_of_clock"] == "0 in the last 1 s, 1 total"


def sim_clock(h, t):
    h.clock_pub.publish(Clock(clock=to_stamp(t)))
    h.spin(0.01)


@pytest.mark.parametrize("use_sim_time", [True, False])
def test_stamp_age_on_a_simulated_clock(use_sim_time):
    """Stamps on a simulated clock (1000 s): under use_sim_time the node clock, else the published /clock (a live
    simulator) is the reference of the stamp age."""
    h = Harness(**LINE, use_sim_time=use_sim_time)
    h.clock_pub = h.peer.create_publisher(Clock, "/clock", 10)
    try:
        h.spin(0.3)
        if use_sim_time:  # no /clock yet: the age cannot be judged
            h.odom(0.0, 0.2, 0.0, stamp=999.0)
            reply = h.call(SetBool, "/steering/engage", data=True)
            assert not reply.success and "no clock" in reply.message
        for k in range(10):
            sim_clock(h, 1000.0 + 0.04 * k)
            h.odom(0.04 * k, 0.2, 0.0, stamp=1000.0 + 0.04 * k - 0.05)
        assert h.call(SetBool, "/steering/engage", data=True).success
        ages = []
        for k in range(1, 30):  # the source lags: the clock runs 40 ms per message, the stamps 10 ms
            sim_clock(h, 1000.4 + 0.04 * k)
            h.odom(0.4 + 0.04 * k, 0.2, 0.0, stamp=1000.35 + 0.01 * k)
            ages.append(0.05 + 0.03 * k)
            if not h.node.watchdog.engaged:
                break
        h.spin(0.05)
        assert ages[-2] < 0.3 < ages[-1] + 0.04 and not h.commands[-1].engaged  # tripped once 0.3 s old
        assert "old (max 0.3 s)" in h.node.watchdog.transitions[-1].reason
    finally:
        h.close()
