"""GNSS/INS node (SPEC §7, loosely coupled): /imu/data_raw (gyro + accelerometer) + /gnss/fix + /gnss/vel
(+ /gnss/status) -> /odometry/filtered at the IMU rate (frame map, child base_link, pose + twist covariance from the
EKF), /imu/data (attitude + covariance, bias-corrected rates), TF map->odom->base_link (odom = map), /map_datum.

The wander-azimuth strapdown INS with the 16-state error EKF (`agnav_fusion.ins`) runs on the base_link axes at
the imu_link origin; mounts come from TF (base_link->imu_link, base_link->gnss_link) and the filter starts once
both are known. The heading may be unknown: the filter initialises when driving and aligns in motion. GNSS
messages are stamped at their epoch and arrive late: the core applies them against its history. A fix and the
/gnss/vel of the same epoch are fused together.

Input checks are the navigation front end's (agnav_fusion.front_end.InputGuard, shared with the navigation sensor
module): finite values, one clock per stream (imu, gnss = fix, vel; lone future stamps never move a clock, GNSS stamps
within [IMU time - history, IMU time + max_gnss_lead]), fix covariances (NaN/negative/indefinite: rejected; zero or
tiny: the receiver's last good one, else floored; all zero before any good one: the default), velocity covariances,
a stuck IMU (stuck_samples bit-identical gyro + accelerometer readings: dropped from there, bridged as a gap).
INS-specific here: NO_FIX fixes are never used, a fix and its velocity are paired by epoch, IMU gaps are bridged by
the core with covariance growth. /diagnostics describe the present (rejections of the guard's recent window, IMU
time; the IMU age) and are published at once (at most every 0.25 s) on a new problem, e.g. a fix overdue for
gnss_overdue_periods fix periods or no IMU sample for imu_overdue_periods IMU periods at a fix's epoch.
"""
import dataclasses
import math

import numpy as np
from agnav_common.diagnostics import ERROR, OK, WARN, Diagnostics
from agnav_common.frames import quaternion_from_euler
from agnav_common.geodesy import LocalTangentPlane
from agnav_common.input_guard import StreamClockSettings, finite
from agnav_common.node_main import main_for
from agnav_common.qos import LATCHED_QOS, PUBLISHER_QOS, SENSOR_QOS
from agnav_common.stamps import to_sec, to_stamp
from agnav_common.tf import TfBuffer, TransformBroadcaster
from agnav_msgs.msg import GnssStatus
from geometry_msgs.msg import TwistWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import Imu, NavSatFix, NavSatStatus

from agnav_fusion.front_end import InputGuard, InputGuardSettings, Overdue, Urgent
from agnav_fusion.ins import GnssSample, InsEkf, InsEkfSettings
from agnav_fusion.ins.frames import Mounts, base_link_state
from agnav_fusion.navigation_output import map_datum_message, pose_transforms

EPOCH_MATCH_S = 0.005   # a /gnss/vel within this of a fix epoch belongs to it
NOT_PARAMETERS = {"lever_gnss_frd", "initial_heading", "initial_heading_sigma"}  # from TF / REP-103 parameters


def declare_ins_settings(node, obj, prefix=""):
    """Declare every (nested) InsEkfSettings field as a parameter named by its path, SPEC/[IMPL] defaults."""
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if f.name in NOT_PARAMETERS:
            continue
        if dataclasses.is_dataclass(value):
            declare_ins_settings(node, value, f"{prefix}{f.name}.")
        else:
            setattr(obj, f.name, type(value)(node.declare_parameter(prefix + f.name, value).value))
    return obj


class InsNode(Node):
    def __init__(self, **kwargs):
        super().__init__("ins_node", **kwargs)
        p = lambda n, d: self.declare_parameter(n, d).value  # noqa: E731
        self.frames = {k: p(f"{k}_frame", d) for k, d in (("map", "map"), ("odom", "odom"), ("base", "base_link"),
                                                           ("imu", "imu_link"), ("gnss", "gnss_link"))}
        datum = p("datum", [0.0])           # [lat, lon, alt]; anything shorter: the first good fix
        self.publish_tf = p("publish_tf", True)
        initial_yaw = p("initial_yaw", 0.0)               # rad, REP-103 (CCW from east): best guess
        initial_yaw_sigma = p("initial_yaw_sigma", 0.0)   # rad; <= 0: unknown heading (in-motion alignment)
        self.gnss_timeout = p("gnss_timeout", 1.5)        # s without an accepted fix -> INS-only (outage) mode
        self.imu_timeout = p("imu_timeout", 0.5)          # s without a usable IMU sample -> WARN
        self.default_fix_sigma = p("default_fix_sigma", 1.0)   # m, fixes without a covariance (unknown / all zero)
        self.default_vel_sigma = p("default_vel_sigma", 0.05)  # m/s, velocities without a covariance (all zero)
        min_fix_sigma = p("min_fix_sigma", 0.01)          # m, a smaller fix sigma is not believed (see InputGuard)
        self.min_vel_sigma = p("min_vel_sigma", 0.01)     # m/s, smaller velocity variances are raised to this
        imu_jump, gnss_jump = p("imu_max_jump", 0.5), p("gnss_max_jump", 1.0)  # s, lone larger steps rejected
        window = p("diagnostic_window", 5.0)              # s (IMU time) of rejections the diagnostics describe
        stuck = p("stuck_samples", 10)                    # bit-identical IMU readings in a row: stuck (0: off)
        self.gnss_overdue = Overdue(p("gnss_overdue_periods", 1.5))   # fix periods without a fix: gnss_overdue
        self.imu_overdue = Overdue(p("imu_overdue_periods", 20.0))    # IMU periods behind a fix epoch: imu_overdue
        self.settings = declare_ins_settings(self, InsEkfSettings())
        self.settings.initial_heading = math.pi / 2 - initial_yaw
        self.settings.initial_heading_sigma = initial_yaw_sigma if initial_yaw_sigma > 0 else math.inf
        # GNSS epochs are checked against the IMU time: at most `max_gnss_lead` ahead, within the history behind
        gnss_clock = StreamClockSettings(max_jump=gnss_jump, max_lag=self.settings.history,
                                         max_lead=self.settings.max_gnss_lead)
        self.guard = InputGuard(InputGuardSettings(min_fix_sigma=min_fix_sigma, diagnostic_window=window,
                                                   stuck_samples=stuck),
                                clocks={"imu": StreamClockSettings(max_jump=imu_jump), "gnss": gnss_clock,
                                        "vel": gnss_clock})
        self.ekf = None
        self.mounts = None
        self.plane = None
        self.pending_fix = None
        self.velocities = []
        self.fix_type = None
        self.imu_time = None                # node time of the last usable IMU sample
        self.rate_var = np.zeros(3)
        self.filter_seen = {}               # EKF rejection counts already turned into events
        self.counters = {"imu": 0, "gnss": 0, "published": 0, "missing_tf": 0, "no_accel": 0}
        self.tf = TfBuffer(self)
        self.tf_out = TransformBroadcaster(self)
        self.odom_pub = self.create_publisher(Odometry, "/odometry/filtered", PUBLISHER_QOS)
        self.imu_pub = self.create_publisher(Imu, "/imu/data", PUBLISHER_QOS)
        self.datum_pub = self.create_publisher(NavSatFix, "/map_datum", LATCHED_QOS)
        self.create_subscription(Imu, "/imu/data_raw", self.on_imu, SENSOR_QOS)
        self.create_subscription(NavSatFix, "/gnss/fix", self.on_fix, SENSOR_QOS)
        self.create_subscription(TwistWithCovarianceStamped, "/gnss/vel", self.on_vel, SENSOR_QOS)
        self.create_subscription(GnssStatus, "/gnss/status", self.on_status, SENSOR_QOS)
        if len(datum) >= 3:
            self.set_datum(*datum[:3])
        self.diag = Diagnostics(self, "ins")
        self.diag.add("inputs", self.check_inputs)
        self.diag.add("filter", self.check_filter)
        self.urgent = Urgent()
        self.guard.on_problem = self.on_problem

    # ---- mounts and datum ---------------------------------------------------------------------------
    def ready(self):
        """True once the mounts are known from TF and the filter exists."""
        if self.ekf is not None:
            return True
        mounts = self.tf.lookup_mounts(self.frames["base"], self.frames["imu"], self.frames["gnss"])
        if mounts is None:
            self.counters["missing_tf"] += 1
            return False
        imu, gnss = mounts
        self.mounts = Mounts.from_tf(imu[0], Rotation.from_quat(imu[1]).as_matrix(), gnss[0])
        self.settings.lever_gnss_frd = tuple(self.mounts.lever_gnss_frd)
        self.ekf = InsEkf(self.settings)
        return True

    def set_datum(self, lat, lon, alt):
        self.plane = LocalTangentPlane(float(lat), float(lon), float(alt))
        self.datum_pub.publish(map_datum_message(lat, lon, alt, self.frames["map"], self.get_clock().now().to_msg()))

    # ---- input guards -------------------------------------------------------------------------------
    def now(self):
        """Node time [s] (the bag's /clock in a replay): IMU age and the rate limit of urgent diagnostics."""
        return self.get_clock().now().nanoseconds * 1e-9

    def on_problem(self, event):
        """A new input problem is on /diagnostics at once (at most every 0.25 s of node time)."""
        if self.urgent.due(self.now()):
            self.diag.publish()

    def imu_clock(self):
        """The IMU time GNSS stamps are checked against (None before the first IMU sample)."""
        return self.guard.clocks["imu"].last

    def gnss_arrived(self, t):
        """A GNSS message of epoch t passed the stamp checks: is the IMU overdue at that epoch?"""
        if self.imu_overdue.check(t):
            self.guard.count("imu_overdue")

    def filter_events(self):
        """EKF rejections since the last call -> events: stale epochs (inputs), gating (filter_*)."""
        for name, count in self.ekf.stats["rejected"].items():
            for _ in range(count - self.filter_seen.get(name, 0)):     # input-level ones keep their name
                self.guard.count(name if name.startswith(("imu_", "gnss_")) else f"filter_{name}")
            self.filter_seen[name] = count

    # ---- inputs ---------------------------------------------------------------------------------------
    def on_imu(self, msg):
        if msg.linear_acceleration_covariance[0] == -1.0:
            self.counters["no_accel"] += 1
            return
        t = to_sec(msg.header.stamp)
        w, a = msg.angular_velocity, msg.linear_acceleration
        gyro, accel = np.array([w.x, w.y, w.z]), np.array([a.x, a.y, a.z])
        if not self.guard.accept("imu", t, gyro, accel):    # a stuck IMU is dropped here: bridged as a gap
            return
        self.imu_overdue.arrived(t)
        if self.gnss_overdue.check(t):
            self.guard.count("gnss_overdue")
        if not self.ready():
            return
        self.counters["imu"] += 1
        r = self.mounts.imu_to_frd
        reason = self.ekf.add_imu(t, r @ gyro, r @ accel)
        self.filter_events()
        if reason is not None:
            return
        self.imu_time = self.now()
        if self.ekf.last_gap > 0.0:
            self.guard.count("imu_gap_bridged")
        var = np.diag(np.array(msg.angular_velocity_covariance).reshape(3, 3))
        if finite(var) and np.all(var >= 0):
            self.rate_var = np.diag(r @ np.diag(var) @ r.T)
        if self.pending_fix is not None and t - self.pending_fix.t > self.settings.history / 2:
            self.submit(None)           # its velocity never came: fuse the position alone
        self.publish()

    def on_status(self, msg):
        self.fix_type = msg.fix_type

    def on_vel(self, msg):
        t = to_sec(msg.header.stamp)
        v = msg.twist.twist.linear
        vel = np.array([v.x, v.y, v.z])
        if not self.guard.accept("vel", t, vel, ref=self.imu_clock()):
            return
        self.gnss_arrived(t)
        cov = self.guard.velocity_covariance(np.array(msg.twist.covariance).reshape(6, 6)[:3, :3],
                                             self.min_vel_sigma ** 2, self.default_vel_sigma ** 2)
        if cov is None:
            return
        self.velocities = (self.velocities + [(t, vel, cov)])[-10:]
        if self.pending_fix is not None and abs(self.pending_fix.t - t) <= EPOCH_MATCH_S:
            self.submit(self.velocities[-1])

    def on_fix(self, msg):
        t = to_sec(msg.header.stamp)
        if not self.guard.accept("gnss", t, msg.latitude, msg.longitude, msg.altitude, ref=self.imu_clock()):
            return                      # (a NO_FIX message still marks the stream time)
        self.gnss_arrived(t)
        if msg.status.status < NavSatStatus.STATUS_FIX or msg.latitude == msg.longitude == 0.0:
            self.guard.count("gnss_no_fix")     # never a position, never the datum
            return
        default = np.eye(3) * self.default_fix_sigma ** 2
        cov = np.array(msg.position_covariance).reshape(3, 3)
        if msg.position_covariance_type == NavSatFix.COVARIANCE_TYPE_UNKNOWN:
            cov = default
        elif msg.position_covariance_type == NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN:
            cov = np.diag(np.diag(cov))
        cov = self.guard.fix_covariance(cov, default)
        if cov is None or not self.ready():
            return
        self.gnss_overdue.arrived(t, self.imu_clock())
        if self.plane is None:
            self.set_datum(msg.latitude, msg.longitude, msg.altitude)
        if self.pending_fix is not None:
            self.submit(None)
        self.pending_fix = GnssSample(t, math.radians(msg.latitude), math.radians(msg.longitude), msg.altitude, cov,
                                      fix_type=self.fix_type if self.fix_type is not None else -1)
        vel = next((v for v in self.velocities if abs(v[0] - t) <= EPOCH_MATCH_S), None)
        if vel is not None:
            self.submit(vel)

    def submit(self, vel):
        """Hand the pending fix (with the velocity of its epoch, if any) to the filter."""
        g, self.pending_fix = self.pending_fix, None
        if vel is not None:
            g.vel_enu, g.vel_cov_enu = vel[1], vel[2]
        self.counters["gnss"] += 1
        self.ekf.add_gnss(g)
        self.filter_events()

    # ---- outputs ----------------------------------------------------------------------------------------
    def publish(self):
        sol = self.ekf.solution()
        if sol is None or self.plane is None:
            return
        s = base_link_state(sol, self.mounts, self.plane, self.rate_var)
        if not (s.finite() and positive_definite(s.pose_cov) and positive_definite(s.twist_cov)):
            self.guard.count("output_invalid")
            return
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
        tw.linear.x, tw.linear.y, tw.linear.z = (float(v) for v in s.velocity)
        tw.angular.x, tw.angular.y, tw.angular.z = (float(v) for v in s.rates)
        odom.twist.covariance = [float(v) for v in s.twist_cov.ravel()]
        self.odom_pub.publish(odom)
        imu = Imu()
        imu.header.stamp = stamp
        imu.header.frame_id = self.frames["base"]
        imu.orientation = pose.orientation
        imu.orientation_covariance = [float(v) for v in s.pose_cov[3:, 3:].ravel()]
        imu.angular_velocity = tw.angular
        imu.angular_velocity_covariance = [float(v) for v in s.twist_cov[3:, 3:].ravel()]
        imu.linear_acceleration_covariance[0] = -1.0
        self.imu_pub.publish(imu)
        if self.publish_tf:
            self.tf_out.send(pose_transforms(self.frames, stamp, s.position, quat))
        self.counters["published"] += 1

    def check_inputs(self):
        """Stream health now: rejections of the last `diagnostic_window` s (totals as values), IMU age."""
        now = self.now()
        recent = {k: v for k, v in self.guard.recent().items() if not k.startswith("filter_")}
        values = dict(self.counters, **{f"total_{k}": v for k, v in self.guard.totals.items()},
                      **{f"recent_{k}": v for k, v in recent.items()})
        if self.counters["no_accel"]:
            return ERROR, "/imu/data_raw has no accelerometers (linear_acceleration_covariance[0] == -1): " \
                          "the INS needs them", values
        if self.ekf is None:
            return WARN, f"waiting for TF {self.frames['base']}->{self.frames['imu']}/{self.frames['gnss']}", values
        problems = [f"{sum(recent.values())} input problems in the last {self.guard.events.window:g} s ("
                    + ", ".join(f"{k} {v}" for k, v in sorted(recent.items())) + ")"] if recent else []
        age = now - self.imu_time if self.imu_time is not None else math.inf
        values["imu_age_s"] = age
        if age > self.imu_timeout:
            problems.insert(0, f"no usable IMU sample for {age:.1f} s")
        return (WARN if problems else OK), "; ".join(problems) or "inputs ok", values

    def check_filter(self):
        if self.ekf is None:
            return WARN, "not started (mounts)", {}
        h = self.ekf.health()
        h["fix_type"] = self.fix_type
        age = h.get("gnss_age_s", math.inf)
        h["mode"] = "uninitialized" if self.ekf.mech is None else (
            "ins_only_outage" if age > self.gnss_timeout else "gnss_aided")
        recent = {k[len("filter_"):]: v for k, v in self.guard.recent().items() if k.startswith("filter_")}
        h.update({f"recent_rejected_{k}": v for k, v in recent.items()})
        level = OK if h["alignment"] == "aligned" and h["mode"] == "gnss_aided" and not recent else WARN
        message = f"{h['alignment']}, {h['mode']}"
        if recent:
            message += f", rejected in the last {self.guard.events.window:g} s: " + \
                ", ".join(f"{k} {v}" for k, v in sorted(recent.items()))
        return level, message, h


def positive_definite(cov):
    """True for a symmetric positive-definite matrix (published covariances must be)."""
    if not np.array_equal(cov, cov.T):
        return False
    try:
        np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        return False
    return True


main = main_for(InsNode)
