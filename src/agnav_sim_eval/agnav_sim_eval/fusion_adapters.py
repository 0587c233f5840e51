"""The fusion graph offline: TractorSimulator samples fed to agnav_fusion exactly as its nodes are fed (never truth),
reduced to what the steering node reads. RTK runs: the simulator's ROS messages, in the order its bags and live
node publish them, through nav_sensor_module_node's own NavigationPipeline (SPEC §6.3); GDS runs: the
variable-target VWA (SPEC §3.6) on the gyro, fluxgate and attitude samples."""
import math
from dataclasses import dataclass, field

import numpy as np
from agnav_common.frames import euler_from_quaternion, rotation_matrix
from agnav_common.variance_weighted_average import VariableTargetVwa, VwaSettings
from agnav_control.watchdog import OdometrySample, odometry_sample
from agnav_fusion.attitude_kf import AttitudeKFSettings
from agnav_fusion.gds_drift_lsm import Unwrapper
from agnav_fusion.gds_heading import magnetic_heading, tilt_compensate
from agnav_fusion.nav_ekf import NavEKFSettings
from agnav_fusion.nav_sensor_module import NavSensorModule, NavSensorModuleSettings
from agnav_fusion.nav_sensor_module_node import odometry_message
from agnav_fusion.pipeline import FrontEndSettings, NavigationPipeline

from agnav_sim_eval.sim.messages import START_EPOCH_S, MessageFactory


@dataclass
class Pose:
    """One /odometry/filtered reduced to the controller's needs (map ENU, REP-103 yaw), at stamp t."""

    t: float
    sample: OdometrySample


FOG_ANGLE_NOISE_RAD = math.radians(0.06)  # JCS-7401A / JG-108FD angle noise per sample (SPEC §11.2)


def rtk_fog_settings(lever_flu, incl_lever_flu, imu_rate_hz: float) -> NavSensorModuleSettings:
    """NavSensorModule settings for the RTK + FOG-IMU sensor set (R4-7/8): the FOG IMU's roll/pitch output on
    /inclinometer has no lag and is not fooled by acceleration, the yaw gyro is FOG-grade. A still FOG's rate per
    sample is its differentiated angle noise (0.06 deg * sqrt 2 * 100 Hz ~ 0.15 rad/s, not the module's 0.01 rad/s
    vibratory-gyro default): with that the standstill zero-rate update learns the bias instead of the last samples,
    and the 3 m chord heading start holds. These are the nav_sensor_module_node parameters of config/steer.yaml."""
    attitude = AttitudeKFSettings(tau=1.0 / imu_rate_hz, gyro_noise=5e-4, bias_walk=1e-5, incl_noise=2e-3)
    return NavSensorModuleSettings(
        estimator="agnav", lever_flu=tuple(lever_flu), incl_lever_flu=tuple(incl_lever_flu),
        roll_kf=attitude, pitch_kf=attitude, accel_compensation=False,
        still_rate_sigma=round(FOG_ANGLE_NOISE_RAD * math.sqrt(2.0) * imu_rate_hz, 3),
        ekf=NavEKFSettings(rate_noise=5e-4, bias_walk=2e-5))


class NsmEstimator:
    """nav_sensor_module_node's pipeline fed the simulator's messages (MessageFactory: /imu/data_raw, /inclinometer,
    /gnss/fix, /gnss/vel as published, mounts of its /tf_static). tilt=False: a level attitude source and a
    yaw-only gyro (the lever arm corrected at zero tilt: the thesis' uncorrected run)."""

    METHODS = {"/imu/data_raw": "on_imu", "/inclinometer": "on_inclinometer", "/gnss/fix": "on_fix",
               "/gnss/vel": "on_velocity"}

    def __init__(self, sim, tilt: bool = True, settings: NavSensorModuleSettings | None = None):
        sc = sim.scenario
        (gnss_xyz, _), (incl_xyz, _) = sc.mounts["gnss_link"], sc.mounts["inclinometer_link"]
        self.nsm = NavSensorModule(settings or rtk_fog_settings(gnss_xyz, incl_xyz, sc.imu_rate_hz))
        self.pipeline = NavigationPipeline(self.nsm, FrontEndSettings(datum=tuple(sc.datum)))  # = config steer
        imu_rotation = rotation_matrix(*sc.mounts["imu_link"][1])
        self.pipeline.set_mounts(imu_rotation, gnss_xyz, incl_xyz)
        self.factory = MessageFactory(sim)
        # the no-tilt run keeps only the gyro's yaw axis in base_link
        self.gyro_filter = None if tilt else imu_rotation.T @ np.diag([0.0, 0.0, 1.0]) @ imu_rotation
        self.tilt = tilt

    @staticmethod
    def feed_order(sample):
        """Samples of one tick in the simulator's order: its bags' and live node's publishing order."""
        return 0

    def feed(self, kind: str, stamp: float, data: dict):
        for topic, _, msg in self.factory.convert(kind, stamp, data):
            if topic == "/inclinometer" and not self.tilt:
                msg.roll = msg.pitch = 0.0
            elif topic == "/imu/data_raw" and self.gyro_filter is not None:
                w = msg.angular_velocity
                w.x, w.y, w.z = (float(v) for v in self.gyro_filter @ np.array([w.x, w.y, w.z]))
            if topic in self.METHODS:
                getattr(self.pipeline, self.METHODS[topic])(msg)

    def pose(self) -> Pose | None:
        """The latest output once heading and position are valid, read as the steering node reads the node's
        /odometry/filtered (pose, twist incl. the lateral speed linear.y, covariances)."""
        s = self.nsm.state()
        if s is None or not (s.heading_valid and s.position_valid):
            return None
        msg = odometry_message(s, {"map": "map", "base": "base_link"})
        p, q, v = msg.pose.pose.position, msg.pose.pose.orientation, msg.twist.twist.linear
        sample, problem = odometry_sample(p.x, p.y, euler_from_quaternion(q.x, q.y, q.z, q.w)[2], v.x,
                                          msg.pose.covariance, msg.twist.covariance, lateral_speed=v.y)
        if sample is None:
            raise ValueError(f"invalid odometry: {problem}")
        return Pose(s.t - START_EPOCH_S, sample)


@dataclass
class GdsSettings:
    vwa: VwaSettings = field(default_factory=VwaSettings)   # Table 2.5: T 10 s, ΔT 2 s
    speed: float = 0.5        # m/s: the GDS system has no odometer; (2.7) runs at the nominal speed


class GdsVwaEstimator:
    """The thesis GDS system (SPEC §3.6): tilt-compensated GDS heading (hard iron left in: a constant offset on a
    straight run that the variable target cancels) and the integrated gyro through agnav_fusion's
    VariableTargetVwa, giving the deviation Δφ (2.52) from the moving target. The pose is expressed with the target
    along target_yaw: yaw = target_yaw - Δφ, position dead-reckoned at the nominal speed, so that the cross-track
    to a line along target_yaw is -ε of (2.7)."""

    def __init__(self, scenario, target_yaw: float, settings: GdsSettings | None = None):
        self.settings = s = settings or GdsSettings()
        self.vwa = VariableTargetVwa(s.vwa)
        self.target_yaw = target_yaw
        self.roll = self.pitch = 0.0
        self.gyro_heading = 0.0   # thesis heading from the integrated clockwise rate
        self.gds = Unwrapper()
        self.t = None
        self.yaw = None
        self.xy = np.zeros(2)

    @staticmethod
    def feed_order(sample):
        """Within one tick: attitude, then the gyro sample that uses it, then the GDS headings it brackets."""
        return {"incl": 0, "imu": 1}.get(sample[0], 2)

    def feed(self, kind: str, stamp: float, data: dict):
        if kind == "incl":
            self.roll, self.pitch = data["roll"], data["pitch"]
        elif kind == "mag":
            self.gds(float(magnetic_heading(tilt_compensate(data["field"], self.roll, -self.pitch))))
        elif kind == "imu":
            g = data["gyro"]
            rate = (math.sin(self.roll) * g[1] + math.cos(self.roll) * g[2]) / math.cos(self.pitch)  # ENU yaw rate
            dt = 0.0 if self.t is None else stamp - self.t
            self.t = stamp
            self.gyro_heading -= rate * dt
            out = None if self.gds.value is None else self.vwa.update(stamp, self.gds.value, self.gyro_heading)
            if out is not None:
                self.yaw = self.target_yaw - out[0]
                self.xy += self.settings.speed * dt * np.array([math.cos(self.yaw), math.sin(self.yaw)])

    def pose(self) -> Pose | None:
        if self.yaw is None:
            return None
        return Pose(self.t, OdometrySample(self.xy[0], self.xy[1], self.yaw, self.settings.speed, 0.0, 0.0))
