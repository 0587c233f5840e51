"""Pluggable EKF measurement models: loosely coupled GNSS position and velocity (SPEC §7.6).

A model turns a measurement and the INS solution at its epoch into a `Linearized` observation
z = H x + n about the closed-loop point x = 0 (so z is also the innovation). Models fill the
columns of the 16 core states only, so the filter state may grow (ambiguities, clock drift).
"""
import math
from dataclasses import dataclass

import numpy as np

from . import earth, error_model as em
from .mechanization import T, c_cbar_ned, mat3

ENU_TO_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


@dataclass
class GnssSample:
    """One receiver epoch at the antenna: stamp = measurement epoch, ENU covariances."""

    t: float
    lat: float                 # rad
    lon: float                 # rad
    alt: float                 # m, ellipsoidal
    pos_cov_enu: np.ndarray    # 3x3 m^2
    vel_enu: np.ndarray = None  # m/s, or None
    vel_cov_enu: np.ndarray = None
    fix_type: int = 4
    vel_from_fixes: bool = False  # velocity differenced from fixes (lags; repeats the fixes' information)


@dataclass
class Snapshot:
    """INS solution at one IMU epoch, kept for latency compensation."""

    t: float
    lat: float
    lon: float
    h: float
    v_ned: np.ndarray
    c_b_ned: np.ndarray
    omega_b: np.ndarray


@dataclass
class Linearized:
    """z = H x + n, n ~ N(0, R); `name` keys the health statistics."""

    name: str
    z: np.ndarray
    h: np.ndarray
    r: np.ndarray


def c_axes(alpha):
    """A with [dE, dN] = A [ΔE-angle, ΔN-angle]: C-horizontal error rotation for wander angle alpha."""
    ca, sa = math.cos(alpha), math.sin(alpha)
    return np.array([[ca, -sa], [sa, ca]])


def ned_to_c(alpha):
    """v^C = T C_NED^Cbar v^NED."""
    return T @ c_cbar_ned(alpha).T


class GnssPosition:
    """Position rows (5-6-4..15) with the lever arm moved to the IMU (5-5-3) by the computed attitude.

    [IMPL] The lever term's attitude error is modelled, not noise: a heading error δα moves the IMU point derived
    from the antenna by (R(δα) - I) C l, exactly linear in γ = sin δα and β = 1 - cos δα; a tilt by δθ x C l. As
    white noise (variance γ² |l|²) it was averaged down over 10 Hz fixes while it moves with the heading estimate:
    each heading correction shifted the derived track sideways, the NHC turned that into course, and the heading
    ran off by tens of degrees with a shrinking sigma (no receiver velocity, slow, tall antenna). The noise is kept
    on top while the heading is uncertain (heading_var |l|^2, gone once aligned): a Gaussian γ, β tens of degrees
    wide is a poor model of the azimuth, and without it an alignment from fix differences at 4 m/s locked 13 deg off
    with a 2.4 deg sigma (campaign seed 9)."""

    name = "position"

    def __init__(self, lever_frd):
        self.lever = np.asarray(lever_frd, dtype=float)

    def linearize(self, snap, alpha, gnss, n_states, heading_var=0.0):
        """Rows on Python floats (the matrix form is in test/ins/test_scalar_paths.py)."""
        (c0, c1, c2), (c3, c4, c5), (c6, c7, c8) = snap.c_b_ned.tolist()
        l0, l1, l2 = self.lever.tolist()
        d0, d1, d2 = c0 * l0 + c1 * l1 + c2 * l2, c3 * l0 + c4 * l1 + c5 * l2, c6 * l0 + c7 * l1 + c8 * l2   # NED
        rm, rn = earth.radii(gnss.lat)            # the IMU point derived from the antenna (5-5-3)
        lat_g, lon_g = gnss.lat - d0 / (rm + gnss.alt), gnss.lon - d1 / ((rn + gnss.alt) * math.cos(gnss.lat))
        ca, sa = math.cos(alpha), math.sin(alpha)                                # c_axes(alpha) = [[ca, -sa], [sa, ca]]
        rm, rn = earth.radii(snap.lat)
        d_lat, e = snap.lat - lat_g, (snap.lon - lon_g) * math.cos(snap.lat)
        r_x, r_y = ca * e + sa * d_lat, -sa * e + ca * d_lat
        # d(computed) - d(corrected) of the antenna offset per state, columns GAMMA, BETA, TX, TY (C-bar axes of
        # c_cbar_ned(alpha): x = (ca, -sa, 0), y = (sa, ca, 0)), north and east rows scaled to angles
        s0, s1 = 1.0 / (rn + snap.h), 1.0 / (rm + snap.h)
        b0 = (s0 * -d0, s0 * -d1, s0 * (d2 * ca), s0 * -(d2 * sa))              # east row (dd[1]) / (R_N + h)
        b1 = (s1 * d1, s1 * -d0, s1 * (d2 * sa), s1 * (d2 * ca))                # north row (dd[0]) / (R_M + h)
        h = np.zeros(3 * n_states)
        h[_POS_COLS[n_states]] = (1.0, r_y + (ca * b0[0] + sa * b1[0]), r_x + (ca * b0[1] + sa * b1[1]),
                                  ca * b0[2] + sa * b1[2], ca * b0[3] + sa * b1[3],
                                  1.0, -r_x + (-sa * b0[0] + ca * b1[0]), r_y + (-sa * b0[1] + ca * b1[1]),
                                  -sa * b0[2] + ca * b1[2], -sa * b0[3] + ca * b1[3],
                                  1.0, -(-(d0 * sa) - d1 * ca), d0 * ca - d1 * sa)
        if n_states > em.MOUNT_YAW:      # body axes turned by δm off base_link's: the lever is R_z(δm) l there
            n0, n1, n2 = c1 * l0 - c0 * l1, c4 * l0 - c3 * l1, c7 * l0 - c6 * l1          # C (z x l), NED
            m = em.MOUNT_YAW
            h[m], h[n_states + m] = -(ca * s0 * n1 + sa * s1 * n0), sa * s0 * n1 - ca * s1 * n0
            h[2 * n_states + m] = n2
        # R: a^T diag(s) (P_en + heading_var |d_en|^2 I) diag(s) a (see above)
        (p00, p01, _), (p10, p11, _), (_, _, p22) = gnss.pos_cov_enu.tolist()
        extra = heading_var * (d0 * d0 + d1 * d1)
        p00, p11 = p00 + extra, p11 + extra
        m00, m01, m10, m11 = ca * s0, sa * s1, -sa * s0, ca * s1
        q00, q01, q10, q11 = m00 * p00 + m01 * p10, m00 * p01 + m01 * p11, m10 * p00 + m11 * p10, m10 * p01 + m11 * p11
        r = np.array(((q00 * m00 + q01 * m01, q00 * m10 + q01 * m11, 0.0),
                      (q10 * m00 + q11 * m01, q10 * m10 + q11 * m11, 0.0), (0.0, 0.0, p22)))
        return Linearized(self.name, np.array((r_x, r_y, snap.h - (gnss.alt + d2))), h.reshape(3, n_states), r)


class GnssVelocity:
    """Velocity rows (5-6-16..23) with the ω x l lever-arm term (5-5-4); as in `GnssPosition` its attitude error is
    modelled: in C the lever velocity T C_B^Cbar (ω x l) turns with the tilt, not with the azimuth (only the
    antenna's velocity does), and ω carries the gyro bias error (else the position's γ' l, a heading rate seen
    through the lever, is not matched by the velocity and pulls the gyro bias)."""

    name = "velocity"

    def __init__(self, lever_frd):
        self.lever = np.asarray(lever_frd, dtype=float)

    def linearize(self, snap, alpha, gnss, n_states):
        """Rows on Python floats (the matrix form is in test/ins/test_scalar_paths.py)."""
        ca, sa = math.cos(alpha), math.sin(alpha)
        (n0, n1, n2), (n3, n4, n5), (n6, n7, n8) = snap.c_b_ned.tolist()
        k = ((ca * n0 - sa * n3, ca * n1 - sa * n4, ca * n2 - sa * n5),       # C_NED^Cbar C_B^NED
             (sa * n0 + ca * n3, sa * n1 + ca * n4, sa * n2 + ca * n5), (n6, n7, n8))
        l0, l1, l2 = self.lever.tolist()
        w0, w1, w2 = snap.omega_b.tolist()
        x0, x1, x2 = w1 * l2 - w2 * l1, w2 * l0 - w0 * l2, w0 * l1 - w1 * l0    # ω x l
        u0, u1, u2 = (r[0] * x0 + r[1] * x1 + r[2] * x2 for r in k)          # lever velocity in C-bar
        e0, e1, e2 = gnss.vel_enu.tolist()
        va0, va1, va2 = -sa * e0 + ca * e1, -ca * e0 - sa * e1, e2           # antenna velocity in C
        b0, b1, b2 = ((r[1] * l2 - r[2] * l1, r[2] * l0 - r[0] * l2, r[0] * l1 - r[1] * l0) for r in k)  # K [l x]
        h = np.zeros(3 * n_states)                        # ω = gyro - bias: BG columns -T K [l x]
        h[_VEL_COLS[n_states]] = (1.0, -va1, -va0, 0.0, u2, -b0[0], -b0[1], -b0[2],
                                  1.0, va0, -va1, -u2, 0.0, b1[0], b1[1], b1[2],
                                  1.0, u1, u0, b2[0], b2[1], b2[2])
        v0, v1, v2 = snap.v_ned.tolist()
        z = (ca * v0 - sa * v1 - va0 + u0, -sa * v0 - ca * v1 - va1 - u1, -v2 - va2 - u2)
        m = ((-sa, ca, 0.0), (-ca, -sa, 0.0), (0.0, 0.0, 1.0))                # ENU -> C
        r = mat3(mat3(m, gnss.vel_cov_enu.tolist()), ((-sa, -ca, 0.0), (ca, -sa, 0.0), (0.0, 0.0, 1.0)))
        return Linearized(self.name, np.array(z), h.reshape(3, n_states), np.array(r))


class _Columns(dict):
    """n_states -> flat indices of the (row, column) entries in a matrix of n_states columns."""

    def __init__(self, entries):
        super().__init__()
        self.entries = entries

    def __missing__(self, n):
        self[n] = np.array([i * n + j for i, j in self.entries])
        return self[n]


_BG = [em.BG.start + i for i in range(3)]
_POS_COLS = _Columns([(0, em.RX), (0, em.GAMMA), (0, em.BETA), (0, em.TX), (0, em.TY),
                      (1, em.RY), (1, em.GAMMA), (1, em.BETA), (1, em.TX), (1, em.TY), (2, em.H), (2, em.TX), (2, em.TY)])
_VEL_COLS = _Columns([(0, j) for j in (em.VX, em.GAMMA, em.BETA, em.TX, em.TY, *_BG)]
                     + [(1, j) for j in (em.VY, em.GAMMA, em.BETA, em.TX, em.TY, *_BG)]
                     + [(2, j) for j in (em.VZ, em.TX, em.TY, *_BG)])
