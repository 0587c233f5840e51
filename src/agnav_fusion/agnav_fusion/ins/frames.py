"""REP-103 edge of the INS: sensor mounts into the FRD body (= base_link axes) and the base_link output state.

The INS body frame B is base_link with FRD axes; the IMU point (origin of the mechanization) is the
imu_link origin. Mount translations and rotations come from TF (base_link -> imu_link / gnss_link).
"""
import math
from dataclasses import dataclass

import numpy as np

from agnav_common.frames import wrap_angle

from .lever_arm import imu_to_point_position, lever_velocity
from .measurements import ENU_TO_NED
from .mechanization import skew

FLU_TO_FRD = np.diag([1.0, -1.0, -1.0])
FRD = FLU_TO_FRD.diagonal().copy()   # FLU <-> FRD sign flips: x * FRD == x @ FLU_TO_FRD (per-sample paths)
NED_TO_ENU = ENU_TO_NED.T.copy()
_DIAG3 = np.arange(3, 6)


@dataclass
class Mounts:
    """imu_link (FLU) -> body FRD rotation, IMU -> antenna and base_link -> IMU levers in body FRD [m]."""

    imu_to_frd: np.ndarray
    lever_gnss_frd: np.ndarray
    lever_imu_frd: np.ndarray

    @classmethod
    def from_tf(cls, imu_xyz, imu_rotation, gnss_xyz):
        """From base_link->imu_link (translation, 3x3 rotation imu_link->base_link) and base_link->gnss_link."""
        lever_imu = FLU_TO_FRD @ np.asarray(imu_xyz, dtype=float)
        return cls(FLU_TO_FRD @ np.asarray(imu_rotation, dtype=float),
                   FLU_TO_FRD @ np.asarray(gnss_xyz, dtype=float) - lever_imu, lever_imu)


@dataclass
class BaseLinkState:
    """base_link in the map ENU plane (REP-103): pose, body FLU twist, 6x6 covariances."""

    t: float
    position: np.ndarray      # map ENU [m]
    rpy: np.ndarray           # roll, pitch (nose down), yaw (CCW from east) [rad]
    pose_cov: np.ndarray      # x, y, z, roll, pitch, yaw
    velocity: np.ndarray      # base_link FLU [m/s]
    rates: np.ndarray         # bias-corrected body rates, FLU [rad/s]
    twist_cov: np.ndarray     # vx, vy, vz, wx, wy, wz

    def finite(self):
        """No NaN or inf anywhere (one sum: NaN and inf propagate)."""
        return math.isfinite(float(self.position.sum() + self.rpy.sum() + self.pose_cov.sum() + self.velocity.sum()
                                   + self.rates.sum() + self.twist_cov.sum()))

    def positive_definite(self):
        """Both covariances positive-definite (symmetric by construction; the attitude and rate blocks are diagonal
        and uncorrelated with the position and velocity blocks: Sylvester's criterion on those)."""
        return all(positive_definite3(c[:3, :3].tolist()) and c[3:, 3:].diagonal().min() > 0
                   for c in (self.pose_cov, self.twist_cov))


def positive_definite3(c):
    """Sylvester's criterion for a symmetric 3x3 matrix (nested lists): all leading principal minors positive."""
    (a, b, d), (_, e, f), (_, _, g) = c
    m2 = a * e - b * b
    return a > 0 and m2 > 0 and a * (e * g - f * f) - b * (b * g - f * d) + d * (b * f - e * d) > 0


class FastPlane:
    """LocalTangentPlane.to_enu for one point in plain floats: pymap3d's WGS-84 formulas (geodetic -> ECEF, the
    difference to the datum's -> ENU) without its per-call overhead (the INS converts every sample)."""

    A2, B_A2 = 6378137.0 ** 2, (6356752.31424518 / 6378137.0) ** 2   # pymap3d's wgs84 semi-axes

    def __init__(self, plane):
        lat0, lon0 = math.radians(plane.lat_deg), math.radians(plane.lon_deg)
        self.origin = self._ecef(lat0, lon0, plane.alt_m)
        self.sl, self.cl, self.so, self.co = math.sin(lat0), math.cos(lat0), math.sin(lon0), math.cos(lon0)

    @classmethod
    def _ecef(cls, lat, lon, alt):
        cl, sl = math.cos(lat), math.sin(lat)
        n = cls.A2 / math.hypot(6378137.0 * cl, 6356752.31424518 * sl)
        return (n + alt) * cl * math.cos(lon), (n + alt) * cl * math.sin(lon), (n * cls.B_A2 + alt) * sl

    def to_enu(self, lat_deg, lon_deg, alt_m):
        x, y, z = self._ecef(math.radians(lat_deg), math.radians(lon_deg), alt_m)
        u, v, w = x - self.origin[0], y - self.origin[1], z - self.origin[2]
        t = self.co * u + self.so * v
        return -self.so * u + self.co * v, -self.sl * t + self.cl * w, self.cl * t + self.sl * w


def base_link_state(sol, mounts, plane, rate_var=(0.0, 0.0, 0.0)):
    """BaseLinkState from an IMU-point NavSolution: moved to base_link by the mount (5-5-3, ω x l), attitude and
    covariances rotated to REP-103. plane: agnav_common LocalTangentPlane; rate_var: gyro white-noise variance."""
    c, lever = sol.c_b_ned, -mounts.lever_imu_frd
    lat, lon, h = imu_to_point_position(sol.lat, sol.lon, sol.h, lever, c)
    position = np.array(plane.to_enu(math.degrees(lat), math.degrees(lon), h), dtype=float)
    r_body_enu = NED_TO_ENU @ (c * FRD)                  # base_link FLU -> ENU
    v_ned = sol.v_ned + lever_velocity(lever, c, sol.omega_b)
    # the mount lever turned by an attitude error moves base_link: δp = φ x (C l), φ ~ N(0, diag(att_var))
    arm = NED_TO_ENU @ skew(c @ lever)
    pose_cov = np.zeros((6, 6))
    pose_cov[:3, :3] = sol.pos_cov_enu + (arm * sol.att_var) @ arm.T
    pose_cov[_DIAG3, _DIAG3] = sol.att_var
    twist_cov = np.zeros((6, 6))
    twist_cov[:3, :3] = r_body_enu.T @ sol.vel_cov_enu @ r_body_enu
    twist_cov[_DIAG3, _DIAG3] = sol.gyro_bias_var + np.asarray(rate_var, dtype=float)
    return BaseLinkState(sol.t, position, np.array([sol.roll, -sol.pitch, wrap_angle(math.pi / 2 - sol.heading)]),
                         symmetric(pose_cov), r_body_enu.T @ (NED_TO_ENU @ v_ned), FRD * sol.omega_b,
                         symmetric(twist_cov))


def symmetric(cov):
    """Exactly symmetric copy (rotated covariances are only symmetric up to rounding)."""
    return (cov + cov.T) / 2
