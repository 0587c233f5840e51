"""GNSS tilt-correction node (SPEC §5.3, eq 4.18-4.24): /gnss/fix (antenna) + /odometry/filtered (attitude)
-> /gnss/fix_corrected (base_link position). Lever arm from TF base_link->gnss_link; the attitude used is the
one nearest the fix epoch; the covariance adds the attitude variance projected through the lever arm. Fixes without
a position (status NO_FIX), with non-finite values or a covariance that cannot be believed, or stamped off the
stream's time are not corrected and are counted; diagnostics report the last `diagnostic_window` s.
"""
import bisect
import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from agnav_common.diagnostics import OK, WARN, Diagnostics
from agnav_common.input_guard import EventWindow, StreamClock, covariance
from agnav_common.frames import euler_from_quaternion, heading_from_yaw
from agnav_common.geodesy import LocalTangentPlane
from agnav_common.node_main import main_for
from agnav_common.parameters import declare, leaves
from agnav_common.qos import PUBLISHER_QOS, subscribe_input
from agnav_common.stamps import to_sec
from agnav_common.tf import TfBuffer
from nav_msgs.msg import Odometry
from rclpy.node import Node
from sensor_msgs.msg import NavSatFix, NavSatStatus

from agnav_fusion import tilt_correction


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
        self.max_attitude_age, self.attitude_wait = s.max_attitude_age, s.attitude_wait
        self.tf = TfBuffer(self)
        # (t, quaternion xyzw, roll/pitch/yaw variances); 30 s at 100 Hz: a fix delivered seconds
        # late (across processes DDS may resend a sample at its next heartbeat) still finds its epoch
        self.attitudes = deque(maxlen=3000)
        self.clock = StreamClock()
        self.pending = []  # (t, fix, covariance, known, node arrival time) waiting for the attitude of their epoch
        self.create_timer(0.1, self.correct_pending)
        self.counts = {}
        self.events = EventWindow(s.diagnostic_window)
        self.pub = self.create_publisher(NavSatFix, "gnss/fix_corrected", PUBLISHER_QOS)
        subscribe_input(self, NavSatFix, "gnss/fix", self.on_fix)
        subscribe_input(self, Odometry, "odometry/filtered", self.on_odom)
        Diagnostics(self, "gnss_correction").add("inputs", self.check_inputs)

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
        quat = (q.x, q.y, q.z, q.w)
        if all(map(math.isfinite, quat)):
            self.attitudes.append((to_sec(msg.header.stamp), quat, (c[21], c[28], c[35])))
            if self.pending:
                self.correct_pending()

    def on_fix(self, msg):
        t = to_sec(msg.header.stamp)
        if msg.status.status < NavSatStatus.STATUS_FIX:
            self.count("no_fix")
            return
        if not np.all(np.isfinite([msg.latitude, msg.longitude, msg.altitude])):
            self.count("bad_value")
            return
        known = msg.position_covariance_type != NavSatFix.COVARIANCE_TYPE_UNKNOWN
        cov, problem = covariance(np.reshape(msg.position_covariance, (3, 3))) if known else (np.zeros((3, 3)), None)
        if cov is None:
            self.count(problem)
            return
        reason = self.clock.check(t)
        if reason:
            self.count(reason)
            return
        self.pending.append((t, msg, cov, known, self.now()))
        self.correct_pending()

    def correct_pending(self):
        """Correct the waiting fixes whose epoch the attitude stream has reached (the module's odometry may arrive
        after the fix), or that have waited attitude_wait s of node time."""
        latest = self.attitudes[-1][0] if self.attitudes else -math.inf
        while self.pending and (self.pending[0][0] <= latest
                                or self.now() - self.pending[0][4] > self.attitude_wait):
            t, msg, cov, known, _ = self.pending.pop(0)
            att = self.nearest_attitude(t)
            if att is None or abs(att[0] - t) > self.max_attitude_age:
                self.count("no_attitude")
            else:
                self.correct(msg, cov, known, att)

    def nearest_attitude(self, t):
        if not self.attitudes:
            return None
        i = bisect.bisect_left(self.attitudes, t, key=lambda a: a[0])
        return min((self.attitudes[j] for j in (i - 1, i) if 0 <= j < len(self.attitudes)), key=lambda a: abs(a[0] - t))

    def correct(self, msg, cov, known, att):
        mount = self.tf.lookup(self.base_frame, self.gnss_frame)
        if mount is None:
            self.count("no_tf")
            return
        _, quat, (v_roll, v_pitch, v_yaw) = att
        roll, pitch, yaw = euler_from_quaternion(*quat)
        heading, pitch = float(heading_from_yaw(yaw)), -pitch  # thesis conventions: heading, pitch nose-up
        lever = tilt_correction.lever_from_flu(mount[0])
        offset = tilt_correction.antenna_offset(lever, heading, pitch, roll)  # ENU, eq 4.23
        here = LocalTangentPlane(msg.latitude, msg.longitude, msg.altitude)
        lat, lon, alt = here.to_geodetic(-offset[0], -offset[1], -offset[2])  # eq 4.24
        out = NavSatFix(header=msg.header, status=msg.status)
        out.header.frame_id = self.base_frame
        out.latitude, out.longitude, out.altitude = float(lat), float(lon), float(alt)
        if known:  # an unknown covariance stays unknown
            tilt_var = tilt_correction.tilt_variance(lever, v_roll, v_pitch, v_yaw)
            out.position_covariance = [float(v) for v in (cov + np.diag([tilt_var, tilt_var, 0.0])).ravel()]
            out.position_covariance_type = NavSatFix.COVARIANCE_TYPE_KNOWN
        self.pub.publish(out)
        self.count("corrected")


main = main_for(GnssCorrectionNode)
