"""Pluggable EKF measurement models: loosely coupled GNSS position and velocity (SPEC §7.6).

A model turns a measurement and the INS solution at its epoch into a `Linearized` observation
z = H x + n about the closed-loop point x = 0 (so z is also the innovation). Models fill the
columns of the 16 core states only, so the filter state may grow (ambiguities, clock drift).
"""
import math
from dataclasses import dataclass

import numpy as np
from agnav_common.frames import cross

from . import earth, error_model as em
from .lever_arm import antenna_to_imu_position, lever_velocity
from .mechanization import T, c_cbar_ned, skew

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
        lat_g, lon_g, h_g = antenna_to_imu_position(gnss.lat, gnss.lon, gnss.alt, self.lever, snap.c_b_ned)
        a = c_axes(alpha)
        rm, rn = earth.radii(snap.lat)
        d_lat, d_lon = snap.lat - lat_g, snap.lon - lon_g
        r_x, r_y = a.T @ np.array([d_lon * math.cos(snap.lat), d_lat])
        h = np.zeros((3, n_states))
        h[0, [em.RX, em.GAMMA, em.BETA]] = 1.0, r_y, r_x
        h[1, [em.RY, em.GAMMA, em.BETA]] = 1.0, -r_x, r_y
        h[2, em.H] = 1.0
        d = snap.c_b_ned @ self.lever                   # antenna offset (NED): d(computed) - d(corrected) per state
        cn = c_cbar_ned(alpha)
        dd = np.zeros((3, n_states))
        dd[:2, em.GAMMA] = d[1], -d[0]
        dd[:2, em.BETA] = -d[:2]
        dd[:, em.TX], dd[:, em.TY] = cross(d, cn[:, 0]), -cross(d, cn[:, 1])
        scale = np.diag([1.0 / (rn + snap.h), 1.0 / (rm + snap.h)])
        h[:2] += a.T @ scale @ dd[[1, 0]]
        h[2] -= dd[2]
        r = np.zeros((3, 3))
        cov_en = gnss.pos_cov_enu[:2, :2] + heading_var * float(np.sum(d[:2] ** 2)) * np.eye(2)   # (see above)
        r[:2, :2] = a.T @ scale @ cov_en @ scale @ a
        r[2, 2] = gnss.pos_cov_enu[2, 2]
        return Linearized(self.name, np.array([r_x, r_y, snap.h - h_g]), h, r)


class GnssVelocity:
    """Velocity rows (5-6-16..23) with the ω x l lever-arm term (5-5-4); as in `GnssPosition` its attitude error is
    modelled: in C the lever velocity T C_B^Cbar (ω x l) turns with the tilt, not with the azimuth (only the
    antenna's velocity does), and ω carries the gyro bias error (else the position's γ' l, a heading rate seen
    through the lever, is not matched by the velocity and pulls the gyro bias)."""

    name = "velocity"

    def __init__(self, lever_frd):
        self.lever = np.asarray(lever_frd, dtype=float)

    def linearize(self, snap, alpha, gnss, n_states):
        m = ned_to_c(alpha)
        va = m @ ENU_TO_NED @ gnss.vel_enu                           # antenna velocity in C
        u = c_cbar_ned(alpha).T @ lever_velocity(self.lever, snap.c_b_ned, snap.omega_b)   # C-bar
        h = np.zeros((3, n_states))
        h[0, [em.VX, em.GAMMA, em.BETA]] = 1.0, -va[1], -va[0]
        h[1, [em.VY, em.GAMMA, em.BETA]] = 1.0, va[0], -va[1]
        h[2, em.VZ] = 1.0
        h[:, em.TX], h[:, em.TY] = T @ cross(u, (1.0, 0.0, 0.0)), -T @ cross(u, (0.0, 1.0, 0.0))
        h[:, em.BG] = -T @ c_cbar_ned(alpha).T @ snap.c_b_ned @ skew(self.lever)    # ω = gyro - bias
        cov = ENU_TO_NED @ gnss.vel_cov_enu @ ENU_TO_NED.T
        return Linearized(self.name, m @ snap.v_ned - va + T @ u, h, m @ cov @ m.T)
