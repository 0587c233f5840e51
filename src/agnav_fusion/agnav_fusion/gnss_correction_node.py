"""GNSS tilt-correction node (SPEC §5.3, eq 4.18-4.24): /gnss/fix (antenna) + /odometry/filtered (attitude)
-> /gnss/fix_corrected (base_link position). Lever arm from TF base_link->gnss_link; the attitude used is the
one nearest the fix epoch; the covariance adds the attitude variance projected through the lever arm.
"""
import math
from collections import deque

import numpy as np
from agnav_common.diagnostics import OK, WARN, Diagnostics
from agnav_common.frames import euler_from_quaternion, heading_from_yaw
from agnav_common.geodesy import LocalTangentPlane
from agnav_common.node_main import main_for
from agnav_common.qos import PUBLISHER_QOS, SENSOR_QOS
from agnav_common.stamps import StampGuard, to_sec
from agnav_common.tf import TfBuffer
from nav_msgs.msg import Odometry
from rclpy.node import Node
from sensor_msgs.msg import NavSatFix

from agnav_fusion import tilt_correction


class GnssCorrectionNode(Node):
    def __init__(self, **kwargs):
        super().__init__("gnss_correction_node", **kwargs)
        p = lambda n, d: self.declare_parameter(n, d).value  # noqa: E731
        self.base_frame = p("base_frame", "base_link")
        self.gnss_frame = p("gnss_frame", "gnss_link")
        self.max_attitude_age = p("max_attitude_age", 0.5)  # s between fix epoch and nearest attitude
        self.tf = TfBuffer(self)
        self.attitudes = deque(maxlen=400)  # (t, heading, pitch nose-up, roll, variances) thesis conventions
        self.guard = StampGuard()
        self.counts = {"corrected": 0, "bad_value": 0, "bad_stamp": 0, "no_attitude": 0, "no_tf": 0}
        self.pub = self.create_publisher(NavSatFix, "/gnss/fix_corrected", PUBLISHER_QOS)
        self.create_subscription(NavSatFix, "/gnss/fix", self.on_fix, SENSOR_QOS)
        self.create_subscription(Odometry, "/odometry/filtered", self.on_odom, SENSOR_QOS)
        Diagnostics(self, "gnss_correction").add("inputs", lambda: (
            OK if self.counts["corrected"] and sum(self.counts.values()) == self.counts["corrected"] else WARN,
            f"{self.counts['corrected']} fixes corrected", self.counts))

    def on_odom(self, msg):
        q, c = msg.pose.pose.orientation, msg.pose.covariance
        roll, pitch, yaw = euler_from_quaternion(q.x, q.y, q.z, q.w)
        if np.all(np.isfinite([roll, pitch, yaw])):
            self.attitudes.append((to_sec(msg.header.stamp), float(heading_from_yaw(yaw)), -pitch, roll,
                                   (c[21], c[28], c[35])))

    def on_fix(self, msg):
        t = to_sec(msg.header.stamp)
        if not np.all(np.isfinite([msg.latitude, msg.longitude, msg.altitude])):
            self.counts["bad_value"] += 1
            return
        if self.guard.check(t):
            self.counts["bad_stamp"] += 1
            return
        mount = self.tf.lookup(self.base_frame, self.gnss_frame)
        if mount is None:
            self.counts["no_tf"] += 1
            return
        att = min(self.attitudes, key=lambda a: abs(a[0] - t), default=None)
        if att is None or abs(att[0] - t) > self.max_attitude_age:
            self.counts["no_attitude"] += 1
            return
        _, heading, pitch, roll, (v_roll, v_pitch, v_yaw) = att
        lever = tilt_correction.lever_from_flu(mount[0])
        offset = tilt_correction.antenna_offset(lever, heading, pitch, roll)  # ENU, eq 4.23
        here = LocalTangentPlane(msg.latitude, msg.longitude, msg.altitude)
        lat, lon, alt = here.to_geodetic(-offset[0], -offset[1], -offset[2])  # eq 4.24
        out = NavSatFix(header=msg.header, status=msg.status)
        out.header.frame_id = self.base_frame
        out.latitude, out.longitude, out.altitude = float(lat), float(lon), float(alt)
        tilt_var = lever[2] ** 2 * (min(v_roll, 1.0) + min(v_pitch, 1.0)) / 2 + \
            (lever[0] ** 2 + lever[1] ** 2) * min(v_yaw, math.pi ** 2)
        cov = np.array(msg.position_covariance).reshape(3, 3) + np.diag([tilt_var, tilt_var, 0.0])
        out.position_covariance = [float(v) for v in cov.ravel()]
        out.position_covariance_type = NavSatFix.COVARIANCE_TYPE_KNOWN
        self.pub.publish(out)
        self.counts["corrected"] += 1


main = main_for(GnssCorrectionNode)
