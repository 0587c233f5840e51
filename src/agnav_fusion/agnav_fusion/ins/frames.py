"""REP-103 edge of the INS: sensor mounts into the FRD body (= base_link axes) and the base_link output state.

The INS body frame B is base_link with FRD axes; the IMU point (origin of the mechanization) is the
imu_link origin. Mount translations and rotations come from TF (base_link -> imu_link / gnss_link).
"""
import math
from dataclasses import dataclass, field

import numpy as np

from agnav_common.frames import wrap_angle

from .earth import radii
from .measurements import ENU_TO_NED
from . import error_model as em
from .constraints import CRAB
from .solution import TWO_PI, congruence3

FLU_TO_FRD = np.diag([1.0, -1.0, -1.0])
FRD = FLU_TO_FRD.diagonal().copy()   # FLU <-> FRD sign flips: x * FRD == x @ FLU_TO_FRD (per-sample paths)
NED_TO_ENU = ENU_TO_NED.T.copy()
_ZEROS36 = np.zeros(36)


@dataclass
class Mounts:
    """imu_link (FLU) -> body FRD rotation, IMU -> antenna and base_link -> IMU levers in body FRD [m]."""

    imu_to_frd: np.ndarray
    lever_gnss_frd: np.ndarray
    lever_imu_frd: np.ndarray
    tilt_var: float = 0.0     # rad^2, IMU roll/pitch mount error beyond TF: the filter levels the IMU, not base_link

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
    checks: tuple = field(default=None, repr=False, compare=False)   # (finite, positive_definite) when known

    def finite(self):
        """No NaN or inf anywhere (one sum: NaN and inf propagate)."""
        if self.checks is not None:
            return self.checks[0]
        return math.isfinite(float(self.position.sum() + self.rpy.sum() + self.pose_cov.sum() + self.velocity.sum()
                                   + self.rates.sum() + self.twist_cov.sum()))

    def positive_definite(self):
        """Both covariances positive-definite (symmetric by construction; the attitude and rate blocks are diagonal
        and uncorrelated with the position and velocity blocks: Sylvester's criterion on those)."""
        if self.checks is not None:
            return self.checks[1]
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

    A, B = 6378137.0, 6356752.31424518                                # pymap3d's wgs84 semi-axes
    A2, B_A2 = A ** 2, (B / A) ** 2

    def __init__(self, plane):
        lat0, lon0 = math.radians(plane.lat_deg), math.radians(plane.lon_deg)
        self.origin = self._ecef(lat0, lon0, plane.alt_m)
        self.sl, self.cl, self.so, self.co = math.sin(lat0), math.cos(lat0), math.sin(lon0), math.cos(lon0)

    @classmethod
    def _ecef(cls, lat, lon, alt):
        cl, sl = math.cos(lat), math.sin(lat)
        n = cls.A2 / math.hypot(6378137.0 * cl, 6356752.31424518 * sl)
        return (n + alt) * cl * math.cos(lon), (n + alt) * cl * math.sin(lon), (n * cls.B_A2 + alt) * sl

    def to_geodetic(self, east, north, up):
        """LocalTangentPlane.to_geodetic of one point (deg, deg, m): pymap3d's enu2ecef and its closed-form
        ecef2geodetic (You 2000) on floats."""
        t, w = self.cl * up - self.sl * north, self.sl * up + self.cl * north
        x = self.origin[0] + (self.co * t - self.so * east)
        y = self.origin[1] + (self.so * t + self.co * east)
        z = self.origin[2] + w
        a, b = self.A, self.B
        r, e2 = math.sqrt(x * x + y * y + z * z), a * a - b * b
        e = math.sqrt(e2)
        u = math.sqrt(0.5 * (r * r - e * e) + 0.5 * math.hypot(r * r - e * e, 2 * e * z))
        hxy, hue = math.hypot(x, y), math.hypot(u, e)
        if math.isclose(u, 0.0, abs_tol=1e-8) or math.isclose(hxy, 0.0, abs_tol=1e-8):    # numpy.isclose's atol
            beta = 0.0 if math.isclose(z, 0.0, abs_tol=1e-8) else math.copysign(math.pi / 2, z)
        else:
            beta = math.atan(hue / u * z / hxy)
            beta += ((b * u - a * hue + e * e) * math.sin(beta)) / (a * hue * 1 / math.cos(beta) - e * e * math.cos(beta))
        lat = math.atan(a / b * math.tan(beta))
        lim = math.pi / 2 - 2.220446049250313e-16
        cos_beta = 0.0 if abs(beta) >= lim else math.cos(beta)
        if abs(beta) >= lim:
            lat = math.copysign(math.pi / 2, beta)
        alt = math.hypot(z - b * math.sin(beta), hxy - a * cos_beta)
        if x * x / a ** 2 + y * y / a ** 2 + z * z / b ** 2 < 1:     # inside the ellipsoid
            alt = -alt
        return math.degrees(lat), math.degrees(math.atan2(y, x)), alt

    def to_enu(self, lat_deg, lon_deg, alt_m):
        x, y, z = self._ecef(math.radians(lat_deg), math.radians(lon_deg), alt_m)
        u, v, w = x - self.origin[0], y - self.origin[1], z - self.origin[2]
        t = self.co * u + self.so * v
        return -self.so * u + self.co * v, -self.sl * t + self.cl * w, self.cl * t + self.sl * w


def base_link_state(sol, mounts, plane, rate_var=(0.0, 0.0, 0.0)):
    """BaseLinkState from an IMU-point NavSolution: moved to base_link by the mount (5-5-3, ω x l), attitude and
    covariances rotated to REP-103. plane: agnav_common LocalTangentPlane; rate_var: gyro white-noise variance.
    Once per IMU sample: Python floats throughout (the matrix form is in test/ins/test_scalar_paths.py)."""
    c = sol.c_b_ned.tolist()
    (c0, c1, c2), (c3, c4, c5), (c6, c7, c8) = c
    att = sol.att_var.tolist()
    att = [att[0] + mounts.tilt_var, att[1] + mounts.tilt_var, att[2]]
    position, velocity, pose3 = _moved(sol.lat, sol.lon, sol.h, c, sol.v_ned.tolist(), sol.omega_b.tolist(), mounts,
                                       plane, sol.pos_cov_enu.tolist(), att)
    # velocity covariance: R^T V R, R = NED_TO_ENU C diag(FRD) (base_link FLU -> ENU)
    twist3 = _upper(congruence3(((c3, c0, -c6), (-c4, -c1, c7), (-c5, -c2, c8)), sol.vel_cov_enu.tolist()))
    gyro = tuple(b + r for b, r in zip(sol.gyro_bias_var.tolist(), rate_var))
    w0, w1, w2 = sol.omega_b.tolist()
    return _state(sol.t, position, (sol.roll, -sol.pitch, wrap_angle(math.pi / 2 - sol.heading)), velocity,
                  (w0, -w1, -w2), pose3, att, twist3, gyro)


def ekf_base_link_state(ekf, mounts, plane, rate_var=(0.0, 0.0, 0.0)):
    """(base_link_state(ekf.solution(), ...), crab, crab variance) of an initialised InsEkf, once per IMU sample:
    straight from the filter state on Python floats, without the NavSolution (the same values up to rounding:
    the twist covariance is rotated from C to the body in one step, T C_B^Cbar^T T, instead of via ENU)."""
    st, p = ekf.mech.state, ekf.p
    (lat, lon, alpha), h = st.geo(), st.h
    (c0, c1, c2), (c3, c4, c5), (c6, c7, c8) = st.dcm_rows()     # C_B^Cbar
    ca, sa = math.cos(alpha), math.sin(alpha)
    c_ned = ((ca * c0 + sa * c3, ca * c1 + sa * c4, ca * c2 + sa * c5),
             (-sa * c0 + ca * c3, -sa * c1 + ca * c4, -sa * c2 + ca * c5), (c6, c7, c8))
    v0, v1, v2 = st.v.tolist()
    w0, w1, w2 = ekf.omega_b.tolist()
    # position covariance: A P[:2, :2] A^T (A = c_axes(alpha) (R + h)) + P_hh (the receiver's slow error is in P)
    rm, rn = radii(lat)
    big_r = math.sqrt(rm * rn) + h
    a00, a01, a10, a11 = ca * big_r, -sa * big_r, sa * big_r, ca * big_r
    (p00, p01), (p10, p11) = p[:2, :2].tolist()
    b00, b01, b10, b11 = a00 * p00 + a01 * p10, a00 * p01 + a01 * p11, a10 * p00 + a11 * p10, a10 * p01 + a11 * p11
    d = p.diagonal().tolist()        # Python floats: numpy scalars cost more in every operation below
    pos = ((b00 * a00 + b01 * a01, b00 * a10 + b01 * a11, 0.0),
           (b10 * a00 + b11 * a01, b10 * a10 + b11 * a11, 0.0), (0.0, 0.0, d[em.H]))
    tx, ty, txy, tc = d[em.TX], d[em.TY], p.item(em.TX, em.TY), em.vehicle_heading_var(p)
    ta = 0.5 * (tx + ty) + math.hypot(0.5 * (tx - ty), txy) + mounts.tilt_var   # largest C-axis tilt + mount
    position, velocity, pose3 = _moved(lat, lon, h, c_ned, (ca * v0 - sa * v1, -sa * v0 - ca * v1, -v2),
                                       (w0, w1, w2), mounts, plane, pos, (ta, ta, tc))
    # twist: M P_v M^T, M = T C_B^Cbar^T T (C -> body FLU)
    rx, ry, *_, rz = p[em.VX:em.VZ + 1, em.VX:em.VZ + 1].tolist()      # rows VX, VY, .., VZ
    twist3 = _upper(congruence3(((c0, -c3, -c6), (-c1, c4, c7), (-c2, c5, c8)),
                                ((rx[0], rx[1], rx[-1]), (ry[0], ry[1], ry[-1]), (rz[0], rz[1], rz[-1]))))
    bg = em.BG.start
    gyro = (d[bg] + rate_var[0], d[bg + 1] + rate_var[1], d[bg + 2] + rate_var[2])
    heading = math.remainder(math.atan2(c3, c0) - alpha, TWO_PI)
    rpy = (math.atan2(c7, c8), math.asin(max(-1.0, min(1.0, c6))), wrap_angle(math.pi / 2 - heading))
    state = _state(ekf.t, position, rpy, velocity, (w0, -w1, -w2), pose3, (ta, ta, tc), twist3, gyro)
    return state, ekf.crab, p[CRAB, CRAB] if ekf.nhc is not None else math.inf


def _moved(lat, lon, h, c, v_ned, omega_b, mounts, plane, pos_cov, att_var):
    """The IMU point's solution moved to base_link (5-5-3, ω x l) on floats: (map ENU position, body FLU velocity,
    upper triangle of the position covariance with the mount lever turned by the attitude error). c: C_B^NED rows;
    pos_cov: ENU 3x3 rows; att_var: roll, pitch, heading variances."""
    (c0, c1, c2), (c3, c4, c5), (c6, c7, c8) = c
    l0, l1, l2 = mounts.lever_imu_frd.tolist()                      # base_link -> IMU; the lever is its negative
    d0, d1, d2 = c0 * l0 + c1 * l1 + c2 * l2, c3 * l0 + c4 * l1 + c5 * l2, c6 * l0 + c7 * l1 + c8 * l2
    rm, rn = radii(lat)
    position = plane.to_enu(math.degrees(lat - d0 / (rm + h)), math.degrees(lon - d1 / ((rn + h) * math.cos(lat))),
                            h + d2)
    w0, w1, w2 = omega_b
    k0, k1, k2 = -(w1 * l2 - w2 * l1), -(w2 * l0 - w0 * l2), -(w0 * l1 - w1 * l0)     # ω x lever
    n0, n1, n2 = v_ned
    n0, n1, n2 = n0 + (c0 * k0 + c1 * k1 + c2 * k2), n1 + (c3 * k0 + c4 * k1 + c5 * k2), n2 + (c6 * k0 + c7 * k1 + c8 * k2)
    velocity = (c0 * n0 + c3 * n1 + c6 * n2, -(c1 * n0 + c4 * n1 + c7 * n2), -(c2 * n0 + c5 * n1 + c8 * n2))
    # δp = φ x (C l), φ ~ N(0, diag(att_var)): arm = NED_TO_ENU [C l x] with C l = -d
    ta, tb, tc = att_var
    (e00, e01, e02), (e10, e11, e12), (e20, e21, e22) = pos_cov
    s01, s02, s12 = -(d0 * tc * d1), d2 * ta * d1, d2 * tb * d0
    return position, velocity, (e00 + (d2 * ta * d2 + d0 * tc * d0), ((e01 + s01) + (e10 + s01)) / 2,
                                ((e02 + s02) + (e20 + s02)) / 2, e11 + (d2 * tb * d2 + d1 * tc * d1),
                                ((e12 + s12) + (e21 + s12)) / 2, e22 + (d1 * ta * d1 + d0 * tb * d0))


def _upper(m):
    """Upper triangle (00, 01, 02, 11, 12, 22) of the symmetric part of 3x3 rows."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = m
    return m00, (m01 + m10) / 2, (m02 + m20) / 2, m11, (m12 + m21) / 2, m22


def _state(t, position, rpy, velocity, rates, pose3, att, twist3, gyro):
    """BaseLinkState of floats; pose3 / twist3: upper triangles of the position and velocity covariances, att / gyro:
    the attitude and rate variances; with its finite and positive-definite checks."""
    p00, p01, p02, p11, p12, p22 = pose3
    v00, v01, v02, v11, v12, v22 = twist3
    total = sum(position) + sum(rpy) + sum(velocity) + sum(rates) + sum(pose3) + sum(att) + sum(twist3) + sum(gyro)
    pd = (positive_definite3(((p00, p01, p02), (p01, p11, p12), (p02, p12, p22))) and min(att) > 0
          and positive_definite3(((v00, v01, v02), (v01, v11, v12), (v02, v12, v22))) and min(gyro) > 0)
    return BaseLinkState(t, np.array(position, dtype=float), np.array(rpy), _cov6(pose3, att), np.array(velocity),
                         np.array(rates), _cov6(twist3, gyro), (math.isfinite(total), pd))


def _cov6(upper, diagonal):
    """6x6 covariance: a symmetric 3x3 block (upper triangle) and a diagonal one (written into a copy of zeros:
    cheaper than an array from 36 values)."""
    a00, a01, a02, a11, a12, a22 = upper
    c = _ZEROS36.copy()
    c[0], c[1], c[2], c[6], c[7], c[8], c[12], c[13], c[14] = a00, a01, a02, a01, a11, a12, a02, a12, a22
    c[21], c[28], c[35] = diagonal
    return c.reshape(6, 6)


def symmetric(cov):
    """Exactly symmetric copy (rotated covariances are only symmetric up to rounding)."""
    return (cov + cov.T) / 2
