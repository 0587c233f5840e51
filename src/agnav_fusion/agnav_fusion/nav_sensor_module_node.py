"""Navigation sensor module node (SPEC §6.3): /imu/data_raw + /inclinometer + /gnss/fix (+ /gnss/vel, + wheel or
radar speed on /wheel/odometry: nav_msgs/Odometry twist.linear.x with its covariance)
-> /odometry/filtered at the IMU rate (frame map, child base_link, pose + twist covariance), TF map->odom->base_link
(map->odom identity: the module's map pose is continuous enough between 1 Hz fixes), /map_datum (latched).

Mounts come from TF (base_link->imu_link rotation, ->gnss_link lever arm, ->inclinometer_link); the datum from the
parameter `datum: [lat, lon, alt]` or the first good fix. IMUs without inclinometers (`tilt_source: accelerometer`)
feed the tilt filters with the accelerometer's gravity direction, which errs by a/g like a pendulum (the module's
acceleration compensation applies; its lag `*_kf.tau` should then be about one IMU period). GNSS messages are stamped at their epoch and may arrive
late: the module replays its IMU history. A receiver publishes /gnss/fix before /gnss/vel of the same epoch, so once
/gnss/vel has been seen a fix waits for its velocity up to `velocity_wait` s of IMU time (the velocity gives the
course that initialises the absolute heading); a receiver without /gnss/vel gets the velocity of its fixes over
the last `fix_velocity_baseline` m (at most FIX_HISTORY fixes back). Like robot_localization, nothing is published on /odometry/filtered
or TF until heading and position are initialised (diagnostic "initialising"). Rejected inputs are counted on
/diagnostics; outputs never hold NaN.
"""
import math

import numpy as np
from agnav_common.diagnostics import OK, WARN, Diagnostics
from agnav_common.frames import quaternion_from_euler
from agnav_common.geodesy import LocalTangentPlane
from agnav_common.node_main import main_for
from agnav_common.qos import LATCHED_QOS, PUBLISHER_QOS, SENSOR_QOS
from agnav_common.stamps import to_sec, to_stamp
from agnav_common.tf import TfBuffer, TransformBroadcaster
from agnav_msgs.msg import Inclination
from geometry_msgs.msg import TwistWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import Imu, NavSatFix, NavSatStatus

from agnav_fusion.nav_sensor_module import NavSensorModule
from agnav_fusion.nav_settings import declare_settings
from agnav_fusion.navigation_output import map_datum_message, pose_transforms

VEL_MATCH_S = 0.1  # s, a /gnss/vel within this of a fix epoch is fused with it
FIX_HISTORY = 10  # fixes kept for the fix-difference velocity


def accelerometer_tilt(f):
    """REP-103 (roll, pitch) of the specific force f (base_link FLU, m/s^2; +g up at rest)."""
    return math.atan2(f[1], f[2]), math.atan2(-f[0], math.hypot(f[1], f[2]))


def imu_message(s, frame_id, max_yaw_variance=None):
    """sensor_msgs/Imu of a module state: orientation + covariance, bias-corrected rates, no acceleration."""
    msg = Imu()
    msg.header.stamp = to_stamp(s.t)
    msg.header.frame_id = frame_id
    q = msg.orientation
    q.x, q.y, q.z, q.w = quaternion_from_euler(*s.rpy)
    cov = s.pose_cov[3:, 3:].copy()
    if max_yaw_variance is not None:
        cov[2, 2] = min(cov[2, 2], max_yaw_variance)
    msg.orientation_covariance = [float(v) for v in cov.ravel()]
    w = msg.angular_velocity
    w.x, w.y, w.z = (float(v) for v in s.rates)
    msg.angular_velocity_covariance = [float(v) for v in s.twist_cov[3:, 3:].ravel()]
    msg.linear_acceleration_covariance[0] = -1.0
    return msg


class NavSensorModuleNode(Node):
    uses_gnss = True

    def __init__(self, name="nav_sensor_module_node", **kwargs):
        super().__init__(name, **kwargs)
        p = lambda n, d: self.declare_parameter(n, d).value  # noqa: E731
        self.frames = {k: p(f"{k}_frame", d) for k, d in (("map", "map"), ("odom", "odom"), ("base", "base_link"),
                                                           ("imu", "imu_link"), ("gnss", "gnss_link"),
                                                           ("inclinometer", "inclinometer_link"))}
        datum = p("datum", [0.0])  # [lat, lon, alt]; anything shorter: the first good fix
        self.publish_tf = p("publish_tf", True)
        self.tilt_source = p("tilt_source", "inclinometer")  # inclinometer | accelerometer (/imu/data_raw)
        if self.tilt_source not in ("inclinometer", "accelerometer"):
            raise ValueError(f"tilt_source must be inclinometer or accelerometer, not {self.tilt_source!r}")
        self.velocity_wait = p("velocity_wait", 0.2)  # s of IMU time a fix waits for its /gnss/vel
        self.fix_velocity_baseline = p("fix_velocity_baseline", 2.0)  # m; 0: no velocity without /gnss/vel
        self.unknown_fix_sigma = p("unknown_fix_sigma", 1.0)  # m per axis of a fix whose covariance type is UNKNOWN
        self.imu_timeout = p("imu_timeout", 0.5)  # s of node time without an IMU message: diagnostics say stale
        self.nsm = NavSensorModule(declare_settings(self))
        self.plane = None
        self.tf = TfBuffer(self)
        self.tf_out = TransformBroadcaster(self)
        self.create_subscription(Imu, "/imu/data_raw", self.on_imu, SENSOR_QOS)
        if self.tilt_source == "inclinometer":
            self.create_subscription(Inclination, "/inclinometer", self.on_incl, SENSOR_QOS)
        if self.uses_gnss:
            self.odom_pub = self.create_publisher(Odometry, "/odometry/filtered", PUBLISHER_QOS)
            self.imu_pub = self.create_publisher(Imu, "/imu/data", PUBLISHER_QOS)  # the fused attitude
            self.datum_pub = self.create_publisher(NavSatFix, "/map_datum", LATCHED_QOS)
            self.create_subscription(NavSatFix, "/gnss/fix", self.on_fix, SENSOR_QOS)
            self.create_subscription(TwistWithCovarianceStamped, "/gnss/vel", self.on_vel, SENSOR_QOS)
            self.create_subscription(Odometry, "/wheel/odometry", self.on_wheel, SENSOR_QOS)
        self.imu_rotation = None
        self.velocities = []
        self.pending_fixes = []  # (t, enu, cov, deadline) waiting for their velocity
        self.recent_fixes = []   # (t, enu, cov) for the fix-difference velocity
        self.last_imu_t = 0.0
        self.last_imu_arrival = None  # node time of the latest /imu/data_raw message
        self.published = 0
        if len(datum) >= 3 and self.uses_gnss:
            self.set_datum(*datum[:3])
        diag = Diagnostics(self, "nav_sensor_module")
        diag.add("inputs", self.check_inputs)
        diag.add("state", self.check_state)

    # ---- mounts and datum ---------------------------------------------------------------------------
    def mounts_ready(self):
        if self.imu_rotation is not None:
            return True
        mounts = self.tf.lookup_mounts(self.frames["base"], self.frames["imu"], self.frames["gnss"])
        if mounts is None:
            self.nsm.guard.count("missing_tf")
            return False
        imu, gnss = mounts
        incl = self.tf.lookup(self.frames["base"], self.frames["inclinometer"])
        self.imu_rotation = Rotation.from_quat(imu[1]).as_matrix()
        self.nsm.set_mounts(gnss[0], imu[0] if incl is None else incl[0])
        return True

    def set_datum(self, lat, lon, alt, stamp=None):
        self.plane = LocalTangentPlane(float(lat), float(lon), float(alt))
        self.datum_pub.publish(map_datum_message(lat, lon, alt, self.frames["map"], stamp or self.get_clock().now().to_msg()))

    # ---- inputs ---------------------------------------------------------------------------------------
    def node_time(self):
        return self.get_clock().now().nanoseconds * 1e-9

    def on_imu(self, msg):
        self.last_imu_arrival = self.node_time()
        if not self.mounts_ready():
            return
        t = to_sec(msg.header.stamp)
        self.submit_fixes(lambda fix: fix[3] < t)
        if self.tilt_source == "accelerometer":
            a = msg.linear_acceleration
            self.nsm.inclinometer(t, *accelerometer_tilt(self.imu_rotation @ np.array([a.x, a.y, a.z])))
        w = msg.angular_velocity
        state = self.nsm.imu(t, self.imu_rotation @ np.array([w.x, w.y, w.z]))
        if state is not None:
            self.last_imu_t = max(self.last_imu_t, state.t)
            if self.ready(state):
                self.publish(state)
                self.published += 1

    def ready(self, state):
        """Publish only an initialised solution (absolute heading and position)."""
        return state.heading_valid and state.position_valid

    def on_incl(self, msg):
        self.nsm.inclinometer(to_sec(msg.header.stamp), msg.roll, msg.pitch)

    def on_wheel(self, msg):
        var = msg.twist.covariance[0]  # 0 or -1: unknown (the module's wheel_speed_sigma); negative/NaN: rejected
        var = None if var in (0.0, -1.0) else (var if var > 0 else math.nan)
        self.nsm.wheel_speed(to_sec(msg.header.stamp), msg.twist.twist.linear.x, var)

    def on_vel(self, msg):
        v, c = msg.twist.twist.linear, msg.twist.covariance
        # -1: unknown (the module's velocity_sigma); NaN or a negative variance: the velocity is dropped, counted
        var = None if c[0] == -1.0 else ((c[0] + c[7]) / 2 if c[0] >= 0 and c[7] >= 0 else math.nan)
        self.velocities = (self.velocities + [(to_sec(msg.header.stamp), np.array([v.x, v.y, v.z]), var)])[-10:]
        self.submit_fixes(lambda fix: self.velocity_at(fix[0]) is not None)

    def velocity_at(self, t):
        """(ENU velocity, per-axis variance or None) of /gnss/vel at the fix epoch t, else None."""
        return next(((v, var) for tv, v, var in self.velocities if abs(tv - t) <= VEL_MATCH_S), None)

    def fix_velocity(self, t, enu, cov):
        """(ENU velocity, per-axis variance) from the latest earlier fix at least fix_velocity_baseline m away
        (variance: both fixes' horizontal variances over the time squared), else None."""
        base = next(((t0, p0, c0) for t0, p0, c0 in reversed(self.recent_fixes)
                     if t0 < t and np.hypot(*(enu[:2] - p0[:2])) >= self.fix_velocity_baseline), None)
        self.recent_fixes = (self.recent_fixes + [(t, enu, cov)])[-FIX_HISTORY:]
        if base is None or self.fix_velocity_baseline <= 0:
            return None
        dt = t - base[0]
        return (enu - base[1]) / dt, float(np.trace(cov[:2, :2]) + np.trace(base[2][:2, :2])) / 2 / dt ** 2

    def submit_fixes(self, due):
        """Hand the pending fixes up to the last due one to the module, in epoch order."""
        last = max((i for i, fix in enumerate(self.pending_fixes) if due(fix)), default=-1)
        for t, enu, cov, _ in self.pending_fixes[:last + 1]:
            vel = self.velocity_at(t) if self.velocities else self.fix_velocity(t, enu, cov)
            self.nsm.gnss(t, enu, cov, *(vel or ()))
        del self.pending_fixes[:last + 1]

    def on_fix(self, msg):
        if msg.status.status < NavSatStatus.STATUS_FIX:
            self.nsm.guard.count("gnss_no_fix")
            return
        if not (np.all(np.isfinite([msg.latitude, msg.longitude, msg.altitude]))
                and abs(msg.latitude) <= 90.0 and abs(msg.longitude) <= 180.0):
            self.nsm.guard.count("gnss_bad_value")
            return
        if self.plane is None:
            self.set_datum(msg.latitude, msg.longitude, msg.altitude, msg.header.stamp)
        t = to_sec(msg.header.stamp)
        enu = np.array(self.plane.to_enu(msg.latitude, msg.longitude, msg.altitude), dtype=float)
        if msg.position_covariance_type == NavSatFix.COVARIANCE_TYPE_UNKNOWN:
            cov = np.eye(3) * self.unknown_fix_sigma ** 2
        else:
            cov = np.array(msg.position_covariance, dtype=float).reshape(3, 3)
        self.pending_fixes.append((t, enu, cov, self.last_imu_t + self.velocity_wait))
        waits = self.velocities and self.velocity_wait > 0 and self.velocity_at(t) is None
        if not waits:
            self.submit_fixes(lambda fix: True)

    # ---- outputs ----------------------------------------------------------------------------------------
    def publish(self, s):
        stamp = to_stamp(s.t)
        quat = quaternion_from_euler(*s.rpy)
        odom = Odometry()
        odom.header.stamp = stamp
        odom.header.frame_id = self.frames["map"]
        odom.child_frame_id = self.frames["base"]
        pose = odom.pose.pose
        pose.position.x, pose.position.y, pose.position.z = (float(v) for v in s.position)
        pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = quat
        odom.pose.covariance = [float(v) for v in s.pose_cov.ravel()]
        tw = odom.twist.twist
        tw.linear.x = float(s.speed)
        tw.angular.x, tw.angular.y, tw.angular.z = (float(v) for v in s.rates)
        odom.twist.covariance = [float(v) for v in s.twist_cov.ravel()]
        self.odom_pub.publish(odom)
        self.imu_pub.publish(imu_message(s, self.frames["base"]))
        if self.publish_tf:
            self.tf_out.send(pose_transforms(self.frames, stamp, s.position, quat))

    def check_inputs(self):
        """Rejections over the guard's recent window (IMU time) and IMU staleness (node time): the present."""
        recent = self.nsm.guard.recent()
        bad = {k: v for k, v in recent.items() if k not in ("imu", "gnss", "wheel")}  # the rest are rejections
        values = dict(self.nsm.counters, **{f"recent_{k}": v for k, v in recent.items()})
        if self.last_imu_arrival is not None and self.node_time() - self.last_imu_arrival > self.imu_timeout:
            return WARN, f"no IMU message for {self.node_time() - self.last_imu_arrival:.1f} s", values
        message = ", ".join(f"{v} {k}" for k, v in sorted(bad.items())) or "inputs OK"
        return (WARN if bad or self.imu_rotation is None else OK), message, values

    def check_state(self):
        s = self.nsm.state()
        if s is None:
            return WARN, "no IMU yet", {}
        if not self.ready(s):
            return WARN, "initialising", {"heading_valid": s.heading_valid, "position_valid": s.position_valid}
        values = {"published": self.published, "dead_reckoning": s.dead_reckoning, "heading_valid": s.heading_valid,
                  "position_sigma_m": float(np.sqrt(s.pose_cov[0, 0] + s.pose_cov[1, 1]))}
        ok = s.heading_valid and s.position_valid and not s.dead_reckoning
        return (OK if ok else WARN), ("tracking" if ok else "degraded"), values


main = main_for(NavSensorModuleNode)
