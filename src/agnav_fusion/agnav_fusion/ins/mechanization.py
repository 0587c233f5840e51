"""Strapdown mechanization in the wander-azimuth frame C (SPEC §7.2, report 5-3-1 … 5-3-30).

Body B = FRD (IMU axes after the mount rotation), C = NWU rotated by the wander angle alpha
(positive toward west) about up, C-bar = (X_C, -Y_C, -Z_C) so that the quaternion is identity at
zero attitude (C_B^C = T C_B^Cbar, T = diag(1, -1, -1)). Heading psi (clockwise from true north)
= yaw-in-C minus alpha.
"""
import math
from dataclasses import dataclass, field

import numpy as np

from . import earth, quaternion

T = np.diag([1.0, -1.0, -1.0])
TD = T.diagonal().copy()   # x * TD == T @ x (per-sample paths)


def skew(v):
    """[v x] cross-product matrix."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def rotation(phi):
    """exp([phi x]) (Rodrigues)."""
    return np.array(rotation_rows(float(phi[0]), float(phi[1]), float(phi[2])))


def rotation_rows(x, y, z):
    """exp([phi x]) of phi = (x, y, z) as three row tuples of Python floats."""
    a2 = x * x + y * y + z * z
    a = math.sqrt(a2)
    sa, ca = (1.0, 0.5) if a < 1e-9 else (math.sin(a) / a, (1.0 - math.cos(a)) / a2)
    d = 1.0 - ca * a2                     # [phi x]^2 = phi phi^T - a^2 I
    return ((d + ca * x * x, ca * x * y - sa * z, ca * x * z + sa * y),
            (ca * x * y + sa * z, d + ca * y * y, ca * y * z - sa * x),
            (ca * x * z - sa * y, ca * y * z + sa * x, d + ca * z * z))


def _floats(x):
    """A 3-vector as Python floats (a tuple passes as it is)."""
    return x if type(x) is tuple else x.tolist() if isinstance(x, np.ndarray) else [float(v) for v in x]


def orthonormalize(c):
    """Nearest rotation matrix (the orthogonal polar factor): for a matrix within 1e-6 of a rotation (the INS's
    C_E^C after a correction or rounding drift) Newton-Schulz steps on Python floats, X <- X (3 I - X^T X) / 2,
    which converge quadratically (two steps at most); else the SVD."""
    x = c.tolist() if isinstance(c, np.ndarray) else c
    for _ in range(4):
        (a0, a1, a2), (a3, a4, a5), (a6, a7, a8) = x
        g00, g11, g22 = a0 * a0 + a3 * a3 + a6 * a6, a1 * a1 + a4 * a4 + a7 * a7, a2 * a2 + a5 * a5 + a8 * a8
        g01, g02, g12 = a0 * a1 + a3 * a4 + a6 * a7, a0 * a2 + a3 * a5 + a6 * a8, a1 * a2 + a4 * a5 + a7 * a8
        err = max(abs(g00 - 1.0), abs(g11 - 1.0), abs(g22 - 1.0), abs(g01), abs(g02), abs(g12))
        if err > 1e-6:
            break
        if err == 0.0:
            return np.array(x)
        m = ((1.5 - 0.5 * g00, -0.5 * g01, -0.5 * g02), (-0.5 * g01, 1.5 - 0.5 * g11, -0.5 * g12),
             (-0.5 * g02, -0.5 * g12, 1.5 - 0.5 * g22))
        x = mat3(x, m)
        if err < 1e-12:        # the next step's change (~err^2) is below rounding
            return np.array(x)
    u, _, vt = np.linalg.svd(np.asarray(c, dtype=float))
    return u @ vt


def mat3(a, b):
    """a @ b of 3x3 row tuples (Python floats)."""
    (a0, a1, a2), (a3, a4, a5), (a6, a7, a8) = a
    (b0, b1, b2), (b3, b4, b5), (b6, b7, b8) = b
    return ((a0 * b0 + a1 * b3 + a2 * b6, a0 * b1 + a1 * b4 + a2 * b7, a0 * b2 + a1 * b5 + a2 * b8),
            (a3 * b0 + a4 * b3 + a5 * b6, a3 * b1 + a4 * b4 + a5 * b7, a3 * b2 + a4 * b5 + a5 * b8),
            (a6 * b0 + a7 * b3 + a8 * b6, a6 * b1 + a7 * b4 + a8 * b7, a6 * b2 + a7 * b5 + a8 * b8))


def geo_of(c02, c12, c20, c21, c22):
    """(lat, lon, alpha) from the elements of C_E^C (5-3-20..22)."""
    return math.asin(max(-1.0, min(1.0, c22))), math.atan2(c21, c20), math.atan2(-c12, c02)


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
    _dcm_of = None              # the q (object) whose C_B^Cbar rows are cached in _dcm: q is replaced, never modified
    _geo_of = None              # the c_ec (object) whose (lat, lon, alpha) are cached in _geo: likewise

    @classmethod
    def from_geodetic(cls, lat, lon, h, roll, pitch, heading, v_ned=(0.0, 0.0, 0.0)):
        """Initialise (5-3-1..6): yaw in C is zero, the heading is carried by alpha0 = -heading."""
        alpha = -heading
        v_c = T @ c_cbar_ned(alpha).T @ np.asarray(v_ned, dtype=float)
        return cls(c_e_c(lat, lon, alpha), float(h), v_c, quaternion.from_roll_pitch_yaw(roll, pitch))

    @property
    def lat(self):
        """Latitude [rad] (5-3-20)."""
        return self.geo()[0]

    @property
    def lon(self):
        """Longitude [rad] (5-3-21)."""
        return self.geo()[1]

    @property
    def alpha(self):
        """Wander angle [rad] (5-3-22)."""
        return self.geo()[2]

    def geo(self):
        """(lat, lon, alpha) [rad] of C_E^C (5-3-20..22), cached for the current c_ec."""
        if self._geo_of is not self.c_ec:
            (_, _, c02), (_, _, c12), (c20, c21, c22) = self.c_ec.tolist()
            self._geo, self._geo_of = geo_of(c02, c12, c20, c21, c22), self.c_ec
        return self._geo

    def c_b_cbar(self):
        """Body -> C-bar DCM (5-3-5)."""
        return np.array(self.dcm_rows())

    def dcm_rows(self):
        """C_B^Cbar as three row tuples of Python floats (cached for the current q)."""
        if self._dcm_of is not self.q:
            self._dcm, self._dcm_of = quaternion.dcm_rows(self.q.tolist()), self.q
        return self._dcm

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

    def v_ned_floats(self):
        """v_ned() as a tuple of Python floats."""
        alpha = self.alpha
        ca, sa = math.cos(alpha), math.sin(alpha)
        v0, v1, v2 = self.v.tolist()
        return ca * v0 - sa * v1, -sa * v0 - ca * v1, -v2


@dataclass
class Mechanization:
    """Steps 3–12 of §7.2 once per IMU sample; sensor-error compensation subtracted first."""

    state: InsState
    accel_bias: np.ndarray = field(default_factory=lambda: np.zeros(3))
    gyro_bias: np.ndarray = field(default_factory=lambda: np.zeros(3))
    gyro_scale: float = 0.0     # z gyro scale-factor error: rate = (gyro - bias) (1 - gyro_scale) about z

    def step(self, gyro_frd, accel_frd, dt):
        """Advance by dt with rate [rad/s] and specific force [m/s^2] in B (FRD); returns the transport
        rate, earth rate, specific force in C and C_B^Cbar used by the error model (tuples of floats; C_B^Cbar as
        rows). Python floats throughout: 3-vectors and 3x3 products cost less in scalars than in numpy."""
        s = self.state
        (c0, c1, c2), (c3, c4, c5), (c6, c7, c8) = s.c_ec.tolist()
        h = s.h
        v0, v1, v2 = s.v.tolist()
        gx, gy, gz = _floats(gyro_frd)
        ax, ay, az = _floats(accel_frd)
        bgx, bgy, bgz = self.gyro_bias.tolist()
        bax, bay, baz = self.accel_bias.tolist()
        lat, _, alpha = s.geo()
        sl, cl, sa, ca = math.sin(lat), math.cos(lat), math.sin(alpha), math.cos(alpha)
        irx, iry, itau, gravity = earth.local_terms(lat, h, sl, sa, ca)
        r0, r1 = -v1 * iry + v0 * itau, v0 * irx - v1 * itau                  # transport rate, rho_z = 0
        o0, o1, o2 = earth.OMEGA * (cl * ca), earth.OMEGA * (-cl * sa), earth.OMEGA * sl   # earth rate in C
        # steps 3-5: body rotation relative to C, quaternion update (5-3-7..10)
        (d0, d1, d2), (d3, d4, d5), (d6, d7, d8) = s.dcm_rows()
        w0, w1, w2 = (r0 + o0) * dt, -((r1 + o1) * dt), -((0.0 + o2) * dt)
        self.rate = rx, ry, rz = gx - bgx, gy - bgy, (gz - bgz) * (1.0 - self.gyro_scale)   # corrected body rate
        q = quaternion.increment(rx * dt - (d0 * w0 + d3 * w1 + d6 * w2), ry * dt - (d1 * w0 + d4 * w1 + d7 * w2),
                                 rz * dt - (d2 * w0 + d5 * w1 + d8 * w2), *s.q.tolist())
        s.q = np.array(q)
        s._dcm, s._dcm_of = quaternion.dcm_rows(q), s.q
        # steps 6-7: specific force into C, velocity with Coriolis and gravity (5-3-14, 5-3-15)
        c_bc = s._dcm
        (d0, d1, d2), (d3, d4, d5), (d6, d7, d8) = c_bc
        fx, fy, fz = ax - bax, ay - bay, az - baz
        a_c = (d0 * fx + d1 * fy + d2 * fz, -(d3 * fx + d4 * fy + d5 * fz), -(d6 * fx + d7 * fy + d8 * fz))
        p0, p1, p2 = r0 + 2.0 * o0, r1 + 2.0 * o1, 0.0 + 2.0 * o2
        g_n = -8.08e-9 * h * math.sin(2.0 * lat)
        gc = (g_n * ca, -g_n * sa, -gravity)
        n0 = v0 + (a_c[0] - (p1 * v2 - p2 * v1) + gc[0]) * dt
        n1 = v1 + (a_c[1] - (p2 * v0 - p0 * v2) + gc[1]) * dt
        n2 = v2 + (a_c[2] - (p0 * v1 - p1 * v0) + gc[2]) * dt
        s.v = np.array((n0, n1, n2))
        # steps 8-9: transport rate at mid-interval velocity, C_E^C and height (5-3-16..22)
        m0, m1, m2 = 0.5 * (v0 + n0), 0.5 * (v1 + n1), 0.5 * (v2 + n2)
        rho_mid = (-m1 * iry + m0 * itau, m0 * irx - m1 * itau, 0.0)
        (e0, e1, e2), (e3, e4, e5), (e6, e7, e8) = rotation_rows(-rho_mid[0] * dt, -rho_mid[1] * dt, -0.0 * dt)
        n02, n12 = e0 * c2 + e1 * c5 + e2 * c8, e3 * c2 + e4 * c5 + e5 * c8
        n20, n21, n22 = e6 * c0 + e7 * c3 + e8 * c6, e6 * c1 + e7 * c4 + e8 * c7, e6 * c2 + e7 * c5 + e8 * c8
        s.c_ec = np.array(((e0 * c0 + e1 * c3 + e2 * c6, e0 * c1 + e1 * c4 + e2 * c7, n02),
                           (e3 * c0 + e4 * c3 + e5 * c6, e3 * c1 + e4 * c4 + e5 * c7, n12), (n20, n21, n22)))
        s._geo, s._geo_of = geo_of(n02, n12, n20, n21, n22), s.c_ec
        s.h = h + m2 * dt
        return rho_mid, (o0, o1, o2), a_c, c_bc

    def renormalize(self):
        """Re-orthonormalise C_E^C ([IMPL] of step 9)."""
        self.state.c_ec = orthonormalize(self.state.c_ec)
