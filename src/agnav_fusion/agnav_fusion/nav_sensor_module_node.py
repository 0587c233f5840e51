"""Navigation sensor module node (SPEC §6.3): /imu/data_raw + /inclinometer + /gnss/fix (+ /gnss/vel, + wheel or
radar speed on /wheel/odometry: nav_msgs/Odometry twist.linear.x with its covariance)
-> /odometry/filtered at the IMU rate (frame map, child base_link, pose + twist covariance), TF map->odom->base_link
(REP-105: odom->base_link dead-reckoned and continuous, the fixes' corrections in map->odom), /map_datum (latched),
/gnss/fix_corrected (each fix moved to base_link with the published attitude of its epoch: agnav_fusion.fix_correction).

A thin wrapper: every message goes unchanged to agnav_fusion.pipeline.NavigationPipeline (front end + the backend
its `estimator` parameter selects in agnav_fusion.backends: NavSensorModule for `agnav`/`thesis`, the GNSS/INS
InsNavigation for `ins` (gyro + accelerometer; /inclinometer unused), its loose / tight / INS-only switching
InsTightNavigation for `ins_tight`, each with its own settings as parameters), which the offline replay and the
benchmarks drive the same way. `ins_tight` also subscribes to the raw GNSS topics of the drivers: gnss/status
(RTK fixed or not), gnss/raw_observations and gnss/base/observations (agnav_msgs/GnssObservations), gnss/nav_data
(agnav_msgs/GnssNavData: the broadcast ephemerides) and gnss/base/position (PointStamped ECEF, latched); its coupling
mode and switches are on /diagnostics. The node owns topics, parameters, TF (mounts in:
base_link->imu_link rotation and translation, ->gnss_link and ->inclinometer_link lever arms; poses out),
diagnostics and time. Nothing is published on /odometry/filtered or TF until heading and position are initialised
(diagnostic "initialising"); rejected inputs are counted on /diagnostics over a recent window; outputs never hold NaN.
"""
from dataclasses import dataclass, field

import numpy as np
from agnav_common.diagnostics import ERROR, OK, WARN, Diagnostics
from agnav_common.frames import matrix_from_quaternion, quaternion_from_euler
from agnav_common.message_factory import new_message
from agnav_common.node_main import main_for
from agnav_common.parameters import declare, descriptor, leaves
from agnav_common.qos import LATCHED_QOS, PUBLISHER_QOS, create_output, subscribe_input
from agnav_common.stamps import to_stamp
from agnav_common.tf import TfBuffer, TransformBroadcaster
from agnav_msgs.msg import GnssNavData, GnssObservations, GnssStatus, Inclination
from geometry_msgs.msg import PointStamped, TwistWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from sensor_msgs.msg import Imu, NavSatFix

from agnav_fusion.backends import ESTIMATOR_DOC, make_backend, settings_for
from agnav_fusion.fix_correction import FixCorrection, FixCorrectionSettings
from agnav_fusion.navigation_output import body_velocity, map_datum_message, pose_transforms
from agnav_fusion.odom_frame import OdomFrame
from agnav_fusion.front_end import Urgent
from agnav_fusion.pipeline import NavigationPipeline


def imu_message(s, frame_id, max_yaw_variance=None, stamp=None, quat=None):
    """sensor_msgs/Imu of a module state: orientation + covariance, bias-corrected rates, no acceleration. stamp,
    quat: the state's, when already computed."""
    msg = new_message(Imu)
    msg.header.stamp = to_stamp(s.t) if stamp is None else stamp
    msg.header.frame_id = frame_id
    q = msg.orientation
    q.x, q.y, q.z, q.w = quaternion_from_euler(*s.rpy) if quat is None else quat
    cov = s.pose_cov[3:, 3:]
    if max_yaw_variance is not None:
        cov = cov.copy()
        cov[2, 2] = min(cov[2, 2], max_yaw_variance)
    msg.orientation_covariance = cov.ravel()  # a copy: the block is not contiguous
    w = msg.angular_velocity
    w.x, w.y, w.z = s.rates.tolist()
    msg.angular_velocity_covariance = s.twist_cov[3:, 3:].ravel()
    msg.linear_acceleration_covariance[0] = -1.0
    return msg


def odometry_message(s, frames, stamp=None, quat=None):
    """nav_msgs/Odometry of a module state: pose in map, twist in base_link (side slip in linear.y), both with
    covariance. stamp, quat: the state's, when already computed."""
    odom = new_message(Odometry)
    odom.header.stamp = to_stamp(s.t) if stamp is None else stamp
    odom.header.frame_id = frames["map"]
    odom.child_frame_id = frames["base"]
    pose = odom.pose.pose
    pose.position.x, pose.position.y, pose.position.z = s.position.tolist()
    q = pose.orientation
    q.x, q.y, q.z, q.w = quaternion_from_euler(*s.rpy) if quat is None else quat
    odom.pose.covariance = s.pose_cov.ravel()
    tw = odom.twist.twist
    tw.linear.x, tw.linear.y, twist_cov = body_velocity(s)
    tw.angular.x, tw.angular.y, tw.angular.z = s.rates.tolist()
    odom.twist.covariance = twist_cov.ravel()
    return odom


@dataclass
class NavNodeSettings:
    map_frame: str = "map"                # world frame: ENU at the datum (REP-105)
    odom_frame: str = "odom"              # continuous frame (REP-105)
    base_frame: str = "base_link"         # vehicle reference point on the ground, FLU
    imu_frame: str = "imu_link"           # frame of /imu/data_raw (rotation from TF)
    gnss_frame: str = "gnss_link"         # GNSS antenna (lever arm from TF)
    inclinometer_frame: str = "inclinometer_link"  # inclinometer (lever arm from TF; else the IMU's)
    frame_prefix: str = ""                # put before every frame but map, e.g. "tractor1/" (several vehicles, one TF)
    publish_tf: bool = True               # publish map->odom->base_link
    publish_fix_corrected: bool = True    # publish /gnss/fix_corrected (each fix at base_link, no gnss_correction_node)
    fix_correction: FixCorrectionSettings = field(default_factory=FixCorrectionSettings)
    imu_timeout: float = 0.5              # s of node time without an IMU message: diagnostics say stale


def _settings(estimator):
    """(settings, fields left out) behind the node's parameters: node, front end, the estimator's backend."""
    return [(NavNodeSettings(), ())] + settings_for(estimator)


def declare_all(node, estimator="agnav"):
    """Declare `estimator` (default given) and then the node, front-end and backend settings (descriptors,
    read-only); returns the backend built from its settings, and the node and front-end settings."""
    estimator = node.declare_parameter("estimator", estimator, descriptor("estimator", estimator, ESTIMATOR_DOC)).value
    node_settings, front, backend = (declare(node, obj, skip=skip) for obj, skip in _settings(estimator))
    return make_backend(estimator, backend), node_settings, front


def parameter_entries(estimator="agnav"):
    """[(name, default, description)] of every parameter (tools/gen_params.py writes the params files from it)."""
    return [("estimator", estimator, ESTIMATOR_DOC)] + [
        entry for obj, skip in _settings(estimator) for entry in leaves(obj, skip=skip)]


class NavSensorModuleNode(Node):
    uses_gnss = True
    estimator = "agnav"     # the default of the `estimator` parameter

    def __init__(self, name="nav_sensor_module_node", **kwargs):
        super().__init__(name, **kwargs)
        self.backend, node_settings, front = declare_all(self, self.estimator)
        prefix = node_settings.frame_prefix
        self.frames = {k: prefix + getattr(node_settings, f"{k}_frame") for k in ("odom", "imu", "gnss", "inclinometer")}
        self.frames.update(map=node_settings.map_frame, base=prefix + node_settings.base_frame)
        self.publish_tf = node_settings.publish_tf
        self.imu_timeout = node_settings.imu_timeout
        self.pipeline = NavigationPipeline(self.backend, front, on_datum=self.publish_datum if self.uses_gnss else None)
        self.tf = TfBuffer(self)
        self.tf_out = TransformBroadcaster(self)
        self.odom_frame = OdomFrame()
        subscribe_input(self, Imu, "imu/data_raw", self.on_imu)
        if front.tilt_source == "inclinometer" and not self.pipeline.strapdown:
            subscribe_input(self, Inclination, "inclinometer", self.pipeline.on_inclinometer)
        self.fix_correction = None
        if self.uses_gnss:
            self.odom_pub = create_output(self, Odometry, "odometry/filtered", PUBLISHER_QOS)
            self.imu_pub = create_output(self, Imu, "imu/data", PUBLISHER_QOS)  # the fused attitude
            self.datum_pub = self.create_publisher(NavSatFix, "map_datum", LATCHED_QOS)
            if node_settings.publish_fix_corrected:
                self.fix_correction = self.correct_fixes(node_settings)
            subscribe_input(self, NavSatFix, "gnss/fix", self.on_fix)
            subscribe_input(self, TwistWithCovarianceStamped, "gnss/vel", self.pipeline.on_velocity)
            subscribe_input(self, Odometry, "wheel/odometry", self.pipeline.on_wheel)
            if self.pipeline.raw is not None:
                self.subscribe_raw()
            self.pipeline.start()
        self.last_imu_arrival = None  # node time of the latest /imu/data_raw message
        self.published = 0
        self.diag = Diagnostics(self, "nav_sensor_module")
        self.diag.add("inputs", self.check_inputs)
        self.diag.add("state", self.check_state)
        self.urgent = Urgent()
        self.backend.guard.on_problem = self.on_problem

    def correct_fixes(self, node_settings):
        """/gnss/fix_corrected from the attitude of the published states (what gnss_correction_node does with a
        second subscription to them). Its counts stay out of the diagnostics: a fix it leaves uncorrected is one the
        pipeline counts already (bad fix or stamp, missing TF), one before the state is published (initialising),
        or one in an IMU gap (stale IMU)."""
        pub = create_output(self, NavSatFix, "gnss/fix_corrected", PUBLISHER_QOS)
        correction = FixCorrection(node_settings.fix_correction, self.frames["base"], self.gnss_lever, pub.publish,
                                   lambda event: None, self.node_time)
        self.create_timer(1.0, correction.process)  # fixes that waited attitude_wait s in vain
        return correction

    def gnss_lever(self):
        mount = self.tf.lookup(self.frames["base"], self.frames["gnss"])
        return None if mount is None else mount[0]

    def on_fix(self, msg):
        self.pipeline.on_fix(msg)
        if self.fix_correction is not None:
            self.fix_correction.add_fix(msg)

    def subscribe_raw(self):
        """The raw GNSS inputs of a raw_gnss backend, with the QoS their drivers publish with."""
        p = self.pipeline
        subscribe_input(self, GnssStatus, "gnss/status", p.on_status)
        subscribe_input(self, GnssObservations, "gnss/raw_observations", p.on_raw_observations)
        subscribe_input(self, GnssObservations, "gnss/base/observations", p.on_base_observations)
        subscribe_input(self, GnssNavData, "gnss/nav_data", p.on_nav_data)
        self.create_subscription(PointStamped, "gnss/base/position", p.on_base_position, LATCHED_QOS)

    def on_problem(self, event):
        """A new input problem is on /diagnostics at once (rate-limited), not at the next tick."""
        if self.urgent.due(self.node_time()):
            self.diag.publish()

    def node_time(self):
        return self.get_clock().now().nanoseconds * 1e-9

    def mounts_ready(self):
        if self.pipeline.imu_rotation is not None:
            return True
        mounts = self.tf.lookup_mounts(self.frames["base"], self.frames["imu"], self.frames["gnss"])
        if mounts is None:
            return False
        imu, gnss = mounts
        incl = self.tf.lookup(self.frames["base"], self.frames["inclinometer"])
        self.pipeline.set_mounts(matrix_from_quaternion(imu[1]), gnss[0], imu[0] if incl is None else incl[0],
                                 imu[0])
        return True

    def publish_datum(self, lat, lon, alt, stamp):
        self.datum_pub.publish(map_datum_message(lat, lon, alt, self.frames["map"],
                                                 stamp or self.get_clock().now().to_msg()))

    def on_imu(self, msg):
        self.last_imu_arrival = self.node_time()
        self.mounts_ready()
        state = self.pipeline.on_imu(msg)
        if state is not None and self.ready(state):
            self.publish(state)
            self.published += 1

    def ready(self, state):
        return self.pipeline.ready(state)

    def publish(self, s):
        stamp, quat = to_stamp(s.t), quaternion_from_euler(*s.rpy)   # shared by the outputs (read-only)
        self.odom_pub.publish(odometry_message(s, self.frames, stamp, quat))
        self.imu_pub.publish(imu_message(s, self.frames["base"], stamp=stamp, quat=quat))
        if self.publish_tf:  # REP-105: odom->base_link continuous, the fixes' corrections in map->odom
            xyz, odom_quat, map_xyz, map_quat = self.odom_frame.update(s.t, s.position, s.rpy, s.speed, s.rates[2])
            self.tf_out.send(pose_transforms(self.frames, stamp, xyz, odom_quat, (map_xyz, map_quat)))
        if self.fix_correction is not None:
            c = s.pose_cov
            self.fix_correction.add_attitude(s.t, quat, (c[3, 3], c[4, 4], c[5, 5]))

    def check_inputs(self):
        """Rejections over the guard's recent window (IMU time) and IMU staleness (node time): the present."""
        recent = self.backend.guard.recent()
        bad = {k: v for k, v in recent.items() if k not in ("imu", "gnss", "wheel")}  # the rest are rejections
        values = dict(self.backend.counters, **{f"recent_{k}": v for k, v in recent.items()})
        if recent.get("imu_no_accel"):
            return ERROR, "/imu/data_raw has no accelerometer (linear_acceleration_covariance[0] == -1): " \
                          f"estimator {self.get_parameter('estimator').value} needs it", values
        if self.last_imu_arrival is not None and self.node_time() - self.last_imu_arrival > self.imu_timeout:
            return WARN, f"no IMU message for {self.node_time() - self.last_imu_arrival:.1f} s", values
        message = ", ".join(f"{v} {k}" for k, v in sorted(bad.items())) or "inputs OK"
        return (WARN if bad or self.pipeline.imu_rotation is None else OK), message, values

    def check_state(self):
        """Initialised, tracking or dead reckoning (INS: outage), with the backend's health (INS: alignment)."""
        s = self.backend.state()
        health = self.backend.health() if hasattr(self.backend, "health") else {}
        if s is None or not self.ready(s):
            return WARN, "no IMU yet" if s is None else "initialising", dict(health, **({} if s is None else {
                "heading_valid": s.heading_valid, "position_valid": s.position_valid}))
        sigma = float(np.sqrt(s.pose_cov[0, 0] + s.pose_cov[1, 1]))
        values = dict(health, published=self.published, dead_reckoning=s.dead_reckoning,
                      heading_valid=s.heading_valid, position_sigma_m=sigma)
        problems = [text for text, bad in (("dead reckoning", s.dead_reckoning),
                                           (health.get("alignment"), health.get("alignment", "aligned") != "aligned"))
                    if bad]
        return (WARN if problems else OK), ", ".join(problems) or "tracking", values


main = main_for(NavSensorModuleNode)
