"""Replays bags/mems_field, clean or with one fault of agnav_sim_eval.fault_injection, through ins_node's callbacks (the
navigation node with the `ins` backend) in one process on a simulated clock, capturing /odometry/filtered and the
node's /diagnostics: sampled once per second as its 1 Hz timer does, and whenever the node publishes them at once (on
a new input problem).

No DDS in the loop: each bag message is handed to the callback of its topic at its recording time (the node clock
follows the bag, as under `agnav run` with use_sim_time), so a replay is fast and deterministic.
"""
import copy
import functools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

BAG = Path(__file__).resolve().parents[2] / "bags" / "mems_field"
INPUTS = ("/tf_static", "/map_datum", "/imu/data_raw", "/gnss/fix", "/gnss/vel", "/ground_truth/odometry")


@functools.lru_cache(maxsize=2)
def bag_messages(seconds):
    """((t, topic, msgtype, msg), ...) of the bag's first `seconds` (t: recording time after the bag start)."""
    from rclpy.serialization import deserialize_message
    from rosbags.rosbag2 import Reader

    from agnav_drivers.ros_types import message_class

    out = []
    with Reader(BAG) as reader:
        start = reader.start_time
        conns = [c for c in reader.connections if c.topic in INPUTS]
        for conn, ns, raw in reader.messages(connections=conns):
            if ns - start > seconds * 1e9:
                break
            out.append(((ns - start) * 1e-9, conn.topic, conn.msgtype,
                        deserialize_message(raw, message_class(conn.msgtype))))
    return tuple(out)


def start_time():
    from rosbags.rosbag2 import Reader
    with Reader(BAG) as reader:
        return reader.start_time * 1e-9


def with_fault(messages, case):
    """Copy of `messages` with a fault_injection.FaultCase applied as `mutate_bag` does (by recording time)."""
    from agnav_sim_eval.fault_injection import mutate

    out, hit, last_good = [], 0, None
    topics = {case.topic, *case.also}
    for t, topic, msgtype, msg in messages:
        if topic in topics and t >= case.t0 and (t < case.end if case.duration > 0 else hit == 0):
            hit += 1
            out.extend((t, topic, msgtype, m) for m in mutate(case, copy.deepcopy(msg), msgtype, last_good))
        else:
            last_good = msg if topic == case.topic and t < case.t0 else last_good
            out.append((t, topic, msgtype, msg))
    assert hit, f"{case.name} hit no message"
    return out


class _Capture:
    def __init__(self):
        self.msgs = []

    def publish(self, msg):
        self.msgs.append(msg)

    send = publish


@dataclass
class Run:
    odom: list                          # /odometry/filtered messages
    diagnostics: list = field(default_factory=list)  # (t, {check: (level, message, values)})
    truth: dict = field(default_factory=dict)         # round(stamp, 2) -> (x, y, yaw)
    node: object = None

    def series(self, t0=0.0):
        """(t rel. to the bag start, horizontal error vector, 2x2 horizontal covariance) of every output."""
        from agnav_common.stamps import to_sec
        base = start_time()
        rows = []
        for o in self.odom:
            t = to_sec(o.header.stamp)
            p = self.truth.get(round(t, 2))
            if p is None or t - base < t0:
                continue
            e = np.array([o.pose.pose.position.x - p[0], o.pose.pose.position.y - p[1]])
            rows.append((t - base, e, np.array(o.pose.covariance).reshape(6, 6)[:2, :2]))
        return rows

    def positions(self):
        from agnav_common.stamps import to_sec
        base = start_time()
        return {round(to_sec(o.header.stamp) - base, 2): np.array([o.pose.pose.position.x, o.pose.pose.position.y])
                for o in self.odom}

    def levels(self, check, t0, t1):
        """[(t, level)] of diagnostic `check` sampled in [t0, t1]."""
        return [(t, d[check][0]) for t, d in self.diagnostics if t0 <= t <= t1]


def replay(messages, parameters=(), publish_from=0.0):
    """Run a fresh InsNode (sim time, datum of the bag) over `messages`; returns a Run with the outputs from
    `publish_from` s (before it the node filters but does not build messages: faster, the filter is unchanged)."""
    from rclpy.parameter import Parameter
    from rclpy.time import Time

    from agnav_fusion.ins_node import InsNode

    base = start_time()
    datum = next(m for _, topic, _, m in messages if topic == "/map_datum")
    node = InsNode(parameter_overrides=[
        Parameter("datum", value=[datum.latitude, datum.longitude, datum.altitude]),
        Parameter("use_sim_time", value=True), Parameter("publish_tf", value=False), *parameters])
    node.odom_pub, node.imu_pub, node.tf_out = _Capture(), _Capture(), _Capture()
    clock = node.get_clock()
    callbacks = {"/tf_static": node.tf.add, "/imu/data_raw": node.on_imu, "/gnss/fix": node.pipeline.on_fix,
                 "/gnss/vel": node.pipeline.on_velocity}
    checks = {"inputs": node.check_inputs, "state": node.check_state}
    run = Run(node.odom_pub.msgs, node=node)

    def sample(t):
        run.diagnostics.append((t, {name: check() for name, check in checks.items()}))

    node.diag.publish = lambda: sample(clock.now().nanoseconds * 1e-9 - base)   # urgent ones, at the node time
    next_diag = 1.0
    node.publish = lambda state: None
    for t, topic, _, msg in messages:
        if t >= publish_from and "publish" in vars(node):
            del node.publish                # the node's own method again
        while t >= next_diag:       # the 1 Hz diagnostic timer fires before later messages are handled
            clock.set_ros_time_override(Time(nanoseconds=int(round((base + next_diag) * 1e9))))
            sample(next_diag)
            next_diag += 1.0
        clock.set_ros_time_override(Time(nanoseconds=int(round((base + t) * 1e9))))
        if topic == "/ground_truth/odometry":
            p, q = msg.pose.pose.position, msg.pose.pose.orientation
            run.truth[round(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, 2)] = (p.x, p.y, yaw(q))
        elif topic in callbacks:
            callbacks[topic](msg)
    return run


def yaw(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def yaw_errors(run, t0=0.0):
    """(t, yaw error, yaw sigma) of every output from t0 [rad]."""
    from agnav_common.stamps import to_sec
    base = start_time()
    rows = []
    for o in run.odom:
        t = to_sec(o.header.stamp)
        p = run.truth.get(round(t, 2))
        if p is not None and t - base >= t0:
            e = math.remainder(yaw(o.pose.pose.orientation) - p[2], 2 * math.pi)
            rows.append((t - base, e, math.sqrt(o.pose.covariance[35])))
    return rows
