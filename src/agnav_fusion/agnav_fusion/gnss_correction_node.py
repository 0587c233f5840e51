"""GNSS tilt-correction node (SPEC §5.3, eq 4.18-4.24): /gnss/fix (antenna) + /odometry/filtered (attitude)
-> /gnss/fix_corrected (base_link position), for graphs whose navigation node does not publish it (the agnav
navigation node does: its `publish_fix_corrected`). Lever arm from TF base_link->gnss_link; the attitude used is the
one nearest the fix epoch; the covariance adds the attitude variance projected through the lever arm
(agnav_fusion.fix_correction). Fixes without a position (status NO_FIX), with non-finite values or a covariance that
cannot be believed, or stamped off the stream's time are not corrected and are counted; diagnostics report the last
`diagnostic_window` s.
"""
from dataclasses import dataclass

from agnav_common.diagnostics import OK, WARN, Diagnostics
from agnav_common.input_guard import EventWindow
from agnav_common.node_main import main_for
from agnav_common.parameters import declare, leaves
from agnav_common.qos import PUBLISHER_QOS, subscribe_input
from agnav_common.stamps import to_sec
from agnav_common.tf import TfBuffer
from nav_msgs.msg import Odometry
from rclpy.node import Node
from sensor_msgs.msg import NavSatFix

from agnav_fusion.fix_correction import FixCorrection, FixCorrectionSettings


@dataclass
class GnssCorrectionSettings:
    base_frame: str = "base_link"  # frame of the corrected fix (the vehicle reference point)
    gnss_frame: str = "gnss_link"  # GNSS antenna frame (lever arm from TF base_frame -> gnss_frame)
    max_attitude_age: float = 0.5  # s between a fix epoch and the nearest attitude; farther: not corrected
    attitude_wait: float = 2.0     # s of node time a fix waits for the attitude of its epoch
    diagnostic_window: float = 10.0  # s of node time the /diagnostics counts describe


def parameter_entries():
    """[(name, default, description)] of every parameter (tools/gen_params.py writes the params file from it)."""
    return leaves(GnssCorrectionSettings())


class GnssCorrectionNode(Node):
    def __init__(self, **kwargs):
        super().__init__("gnss_correction_node", **kwargs)
        s = declare(self, GnssCorrectionSettings())
        self.base_frame, self.gnss_frame = s.base_frame, s.gnss_frame
        self.tf = TfBuffer(self)
        self.pub = self.create_publisher(NavSatFix, "gnss/fix_corrected", PUBLISHER_QOS)
        self.correction = FixCorrection(FixCorrectionSettings(s.max_attitude_age, s.attitude_wait), s.base_frame,
                                        self.lever, self.pub.publish, self.count, self.now)
        self.create_timer(0.1, self.correction.process)
        self.counts = {}
        self.events = EventWindow(s.diagnostic_window)
        subscribe_input(self, NavSatFix, "gnss/fix", self.correction.add_fix)
        subscribe_input(self, Odometry, "odometry/filtered", self.on_odom)
        Diagnostics(self, "gnss_correction").add("inputs", self.check_inputs)

    def lever(self):
        mount = self.tf.lookup(self.base_frame, self.gnss_frame)
        return None if mount is None else mount[0]

    def now(self):
        return self.get_clock().now().nanoseconds * 1e-9

    def count(self, event):
        self.counts[event] = self.counts.get(event, 0) + 1
        self.events.add(event, self.now())

    def check_inputs(self):
        recent = self.events.recent(self.now())
        bad = {k: v for k, v in recent.items() if k != "corrected"}
        message = ", ".join(f"{v} {k}" for k, v in sorted(bad.items())) or f"{recent.get('corrected', 0)} fixes corrected"
        return (WARN if bad or not recent else OK), message, dict(self.counts, **{f"recent_{k}": v
                                                                              for k, v in recent.items()})

    def on_odom(self, msg):
        """Keeps the stamp, quaternion and attitude variances (Euler angles only for the ~1 Hz fixes' epochs)."""
        q, c = msg.pose.pose.orientation, msg.pose.covariance
        self.correction.add_attitude(to_sec(msg.header.stamp), (q.x, q.y, q.z, q.w), (c[21], c[28], c[35]))


main = main_for(GnssCorrectionNode)
