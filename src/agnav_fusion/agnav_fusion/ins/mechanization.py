"""Strapdown mechanization in the wander-azimuth frame C (SPEC §7.2, report 5-3-1 … 5-3-30).

Body B = FRD (IMU axes after the mount rotation), C = NWU rotated by the wander angle alpha
(positive toward west) about up, C-bar = (X_C, -Y_C, -Z_C) so that the quaternion is identity at
zero attitude (C_B^C = T C_B^Cbar, T = diag(1, -1, -1)). Heading psi (clockwise from true north)
= yaw-in-C minus alpha.
"""
import math
from dataclasses import dataclass, field

import numpy as np
from agnav_common.frames import cross

from . import earth, quaternion

T = np.diag([1.0, -1.0, -1.0])
TD = T.diagonal().copy()   # x * TD == T @ x (per-sample paths)


def skew(v):
    """[v x] cross-product matrix."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def rotation(phi):
    """exp([phi x]) (Rodrigues)."""
    x, y, z = float(phi[0]), float(phi[1]), float(phi[2])
    a2 = x * x + y * y + z * z
    a = math.sqrt(a2)
    sa, ca = (1.0, 0.5) if a < 1e-9 else (math.sin(a) / a, (1.0 - math.cos(a)) / a2)
    d = 1.0 - ca * a2                     # [phi x]^2 = phi phi^T - a^2 I
    return np.array([[d + ca * x * x, ca * x * y - sa * z, ca * x * z + sa * y],
                     [ca * x * y + sa * z, d + ca * y * y, ca * y * z - sa * x],
                     [ca * x * z - sa * y, ca * y * z + sa * x, d + ca * z * z]])


def orthonormalize(c):
    """Nearest rotation matrix (SVD)."""
    u, _, vt = np.linalg.svd(c)
    return u @ vt


def c_e_c(lat, lon, alpha):
    """E -> C direction cosine matrix, rows = C axes in ECEF (5-3-6)."""
    sl, cl, sp, cp, sa, ca = (math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon),
                              math.sin(alpha), math.cos(alpha))
    return np.array([
        [-ca * sl * cp + sa * sp, -ca * sl * sp - sa * cp, ca * cl],
        [sa * sl * cp + ca * sp, sa * sl * sp - ca * cp, -sa * cl],
        [cl * cp, cl * sp, sl],
    ])


def c_cbar_ned(alpha):
    """C-bar -> NED: rotation about down by the heading of X_C, which is -alpha."""
    ca, sa = math.cos(alpha), math.sin(alpha)
    return np.array([[ca, sa, 0.0], [-sa, ca, 0.0], [0.0, 0.0, 1.0]])


def roll_pitch_from_accel(f_frd):
    """Initial roll and pitch from the accelerometers at rest (FRD, level f_z = -g) [rad]."""
    fx, fy, fz = f_frd
    return math.atan2(-fy, -fz), math.atan2(fx, math.hypot(fy, fz))


@dataclass
class InsState:
    """Navigation state: C_E^C, height, velocity in C, attitude quaternion B relative to C-bar."""

    c_ec: np.ndarray
    h: float
    v: np.ndarray
    q: np.ndarray

    @classmethod
    def from_geodetic(cls, lat, lon, h, roll, pitch, heading, v_ned=(0.0, 0.0, 0.0)):
        """Initialise (5-3-1..6): yaw in C is zero, the heading is carried by alpha0 = -heading."""
        alpha = -heading
        v_c = T @ c_cbar_ned(alpha).T @ np.asarray(v_ned, dtype=float)
        return cls(c_e_c(lat, lon, alpha), float(h), v_c, quaternion.from_roll_pitch_yaw(roll, pitch))

    @property
    def lat(self):
        """Latitude [rad] (5-3-20)."""
        return math.asin(max(-1.0, min(1.0, self.c_ec[2, 2])))

    @property
    def lon(self):
        """Longitude [rad] (5-3-21)."""
        return math.atan2(self.c_ec[2, 1], self.c_ec[2, 0])

    @property
    def alpha(self):
        """Wander angle [rad] (5-3-22)."""
        return math.atan2(-self.c_ec[1, 2], self.c_ec[0, 2])

    def c_b_cbar(self):
        """Body -> C-bar DCM (5-3-5)."""
        return quaternion.to_dcm(self.q)

    def c_b_ned(self):
        """Body (FRD) -> local level NED DCM."""
        return c_cbar_ned(self.alpha) @ self.c_b_cbar()

    def euler(self):
        """(roll, pitch nose-up, true heading clockwise from north) [rad] (5-3-11..13, psi = Psi - alpha)."""
        roll, pitch, yaw_c = quaternion.euler(self.c_b_cbar())
        return roll, pitch, math.remainder(yaw_c - self.alpha, 2.0 * math.pi)

    def v_ned(self):
        """Velocity in NED [m/s]."""
        return c_cbar_ned(self.alpha) @ (T @ self.v)


@dataclass
class Mechanization:
    """Steps 3–12 of §7.2 once per IMU sample; sensor-error compensation subtracted first."""

    state: InsState
    accel_bias: np.ndarray = field(default_factory=lambda: np.zeros(3))
    gyro_bias: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def step(self, gyro_frd, accel_frd, dt):
        """Advance by dt with rate [rad/s] and specific force [m/s^2] in B (FRD); returns the transport
        rate, earth rate, specific force in C and C_B^Cbar used by the error model."""
        s = self.state
        lat, alpha = s.lat, s.alpha
        rho = earth.transport_rate(s.v, lat, s.h, alpha)
        omega = earth.earth_rate_c(lat, alpha)
        c_bc = s.c_b_cbar()
        # steps 3-5: body rotation relative to C, quaternion update (5-3-7..10)
        theta_b = c_bc.T @ (TD * ((rho + omega) * dt))
        s.q = quaternion.rotate_increment(s.q, (np.asarray(gyro_frd) - self.gyro_bias) * dt - theta_b)
        # steps 6-7: specific force into C, velocity with Coriolis and gravity (5-3-14, 5-3-15)
        c_bc = quaternion.to_dcm(s.q)
        a_c = TD * (c_bc @ (np.asarray(accel_frd) - self.accel_bias))
        v_old = s.v
        s.v = v_old + (a_c - cross(rho + 2.0 * omega, v_old) + earth.gravity_c(lat, s.h, alpha)) * dt
        # steps 8-9: transport rate at mid-interval velocity, C_E^C and height (5-3-16..22)
        v_mid = 0.5 * (v_old + s.v)
        rho_mid = earth.transport_rate(v_mid, lat, s.h, alpha)
        s.c_ec = rotation(-rho_mid * dt) @ s.c_ec
        s.h += v_mid[2] * dt
        return rho_mid, omega, a_c, c_bc

    def renormalize(self):
        """Re-orthonormalise C_E^C ([IMPL] of step 9)."""
        self.state.c_ec = orthonormalize(self.state.c_ec)
