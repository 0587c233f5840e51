"""Estimators for the offline closed loop, fed ONLY with simulated sensor samples (never truth), built from
agnav_fusion cores. RtkEstimator is a documented stand-in for part A's agnav_fusion.nav_sensor_module:
gyro + tilt-corrected, latency-compensated RTK fixes in NavEKF (SPEC §5.3, §6.3). GdsVwaEstimator is the
thesis GDS chain: tilt-compensated GDS heading + FOG heading through the VWA variable target (SPEC §3.6)."""
import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from agnav_common.frames import rotation_matrix, yaw_from_heading
from agnav_common.geodesy import LocalTangentPlane
from agnav_fusion import tilt_correction
from agnav_fusion.gds_heading import magnetic_heading, tilt_compensate
from agnav_fusion.nav_ekf import IPHI, IV, IX, IY, NavEKF, NavEKFSettings
from agnav_fusion.variance_weighted_average import VariableTargetVwa, VwaSettings


@dataclass(frozen=True)
class Odometry:
    """What /odometry/filtered carries, reduced to the controller's needs (map ENU, REP-103 yaw)."""

    t: float
    x: float
    y: float
    yaw: float
    speed: float
    position_var: float
    yaw_var: float


def yaw_rate(gyro, roll, pitch):
    """ENU yaw rate (rad/s) from FLU body rates and REP-103 roll/pitch."""
    return (math.sin(roll) * gyro[1] + math.cos(roll) * gyro[2]) / math.cos(pitch)


class RtkEstimator:
    """NavEKF predicted with the gyro yaw rate at the IMU rate; each GNSS fix is tilt-corrected with the
    attitude at its epoch (or only lever-arm corrected at zero tilt when tilt=False), shifted by the
    dead-reckoned motion since its epoch (latency), and fused with the antenna velocity minus the lever-arm
    velocity R (w x r) (the roof antenna sways with roll), w averaged over the GNSS interval: FOG samples carry
    differentiated angle noise that only vanishes when integrated."""

    EKF = NavEKFSettings(rate_noise=0.0005, bias_walk=2e-5)  # FOG-grade yaw gyro of the RTK scenarios

    def __init__(self, datum, gnss_lever_flu, gnss_interval: float, tilt: bool = True, min_init_speed: float = 0.5):
        self.plane = LocalTangentPlane(*datum)
        self.lever = tilt_correction.lever_from_flu(gnss_lever_flu)
        self.tilt = tilt
        self.min_init_speed = min_init_speed
        self.ekf = NavEKF(self.EKF)
        self.lever_flu = np.asarray(gnss_lever_flu, dtype=float)
        self.gyro = np.zeros(3)
        self.gnss_interval = gnss_interval
        self.roll = self.pitch = 0.0
        self._history = deque(maxlen=200)  # (t, roll, pitch, x, y, gyro) per IMU tick
        self.t = None

    @property
    def ready(self) -> bool:
        return self.ekf.x is not None

    def feed(self, kind: str, stamp: float, data: dict):
        if kind == "incl":
            self.roll, self.pitch = data["roll"], data["pitch"]
        elif kind == "imu":
            self.gyro = np.asarray(data["gyro"], dtype=float)
            dt = 0.0 if self.t is None else stamp - self.t
            self.t = stamp
            if self.ready and dt > 0.0:
                self.ekf.predict(-yaw_rate(data["gyro"], self.roll, self.pitch), dt)  # thesis r: clockwise +
            x, y = (self.ekf.x[IX], self.ekf.x[IY]) if self.ready else (math.nan, math.nan)
            self._history.append((stamp, self.roll, self.pitch, x, y, self.gyro))
        elif kind == "gnss":
            self._fix(stamp, data)

    def _at(self, epoch):
        return min(self._history, key=lambda h: abs(h[0] - epoch)) if self._history else None

    def _fix(self, epoch, data):
        past = self._at(epoch)
        if past is None:
            return
        _, roll, pitch, x_then, y_then, _ = past
        gyro = np.mean([h[5] for h in self._history if epoch - self.gnss_interval < h[0] <= epoch], axis=0)
        e, n, u = self.plane.to_enu(data["lat"], data["lon"], data["alt"])
        heading = self.ekf.x[IPHI] if self.ready else math.atan2(data["vel"][0], data["vel"][1])
        r = rotation_matrix(roll, pitch, float(yaw_from_heading(heading)))
        ve, vn, _ = np.asarray(data["vel"], dtype=float) - r @ np.cross(gyro, self.lever_flu)
        if not self.ready:
            if math.hypot(ve, vn) < self.min_init_speed:
                return
            xy = tilt_correction.correct((e, n, u), self.lever, heading, -pitch, roll)[:2]
            self.ekf.initialise(xy, np.asarray(data["cov"])[:2, :2], heading, math.hypot(ve, vn))
            return
        tilt = (-pitch, roll) if self.tilt else (0.0, 0.0)
        xy = tilt_correction.correct((e, n, u), self.lever, heading, *tilt)[:2]
        if math.isfinite(x_then):  # latency: move the epoch fix by the motion since its epoch
            xy = xy + np.array([self.ekf.x[IX] - x_then, self.ekf.x[IY] - y_then])
        R_p = np.asarray(data["cov"])[:2, :2]
        y, S, _, H = self.ekf.position_innovation(xy, R_p)
        self.ekf.update(y, S, H, R_p)
        R_v = np.asarray(data["vel_cov"])[:2, :2]
        y, S, _, H = self.ekf.velocity_innovation((ve, vn), R_v)
        self.ekf.update(y, S, H, R_v)

    def odometry(self) -> Odometry:
        x, P = self.ekf.x, self.ekf.P
        return Odometry(self.t, x[IX], x[IY], float(yaw_from_heading(x[IPHI])), x[IV],
                        max(P[IX, IX], P[IY, IY]), P[IPHI, IPHI])



class GdsVwaEstimator:
    """Thesis GDS system (SPEC §3.6): GDS heading (tilt-compensated fluxgate, hard iron left in: it is a
    constant offset on a straight run and cancels in (2.52)) and gyro-integrated heading, combined by
    agnav_fusion's variable-target VWA into the heading deviation from the moving target."""

    def __init__(self, settings: VwaSettings | None = None):
        self.vwa = VariableTargetVwa(settings)
        self.roll = self.pitch = 0.0
        self.gyro_heading = 0.0  # thesis heading, unwrapped, from integrated clockwise rate
        self.gds_heading = None
        self.deviation = None    # Δφ_est (2.52), rad clockwise
        self.t = None

    @property
    def ready(self) -> bool:
        return self.deviation is not None

    def feed(self, kind: str, stamp: float, data: dict):
        if kind == "incl":
            self.roll, self.pitch = data["roll"], data["pitch"]
        elif kind == "mag":
            level = tilt_compensate(np.asarray(data["field"]), self.roll, -self.pitch)
            h = float(magnetic_heading(level))
            self.gds_heading = h if self.gds_heading is None else self.gds_heading + math.remainder(h - self.gds_heading, 2 * math.pi)
        elif kind == "imu":
            if self.t is not None:
                self.gyro_heading -= yaw_rate(data["gyro"], self.roll, self.pitch) * (stamp - self.t)
            self.t = stamp
            if self.gds_heading is not None:
                out = self.vwa.update(stamp, self.gds_heading, self.gyro_heading)
                if out is not None:
                    self.deviation = out[0]

    @property
    def target_yaw(self) -> float:
        return float(yaw_from_heading(self.vwa.target)) if self.vwa.target is not None else math.nan
