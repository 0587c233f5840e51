"""GNSS antenna <-> IMU offset (SPEC §7.5, report 5-5-1 … 5-5-4)."""
import math

import numpy as np
from agnav_common.frames import cross

from . import earth


def antenna_to_imu_position(lat, lon, h, lever_frd, c_b_ned):
    """IMU (lat, lon, h) from the antenna's, IMU->antenna lever l^B (FRD) and attitude (5-5-1..3)."""
    d = c_b_ned @ lever_frd                         # antenna offset in NED
    rm, rn = earth.radii(lat)
    return lat - d[0] / (rm + h), lon - d[1] / ((rn + h) * math.cos(lat)), h + d[2]


def lever_velocity(lever_frd, c_b_ned, omega_b):
    """NED velocity of the point at l^B (FRD) relative to the IMU, turning with the body rates: C (ω x l) (5-5-4)."""
    return c_b_ned @ cross(omega_b, lever_frd)


def antenna_to_imu_velocity(v_ned, lever_frd, c_b_ned, omega_b):
    """IMU velocity (NED) from the antenna's with the ω x l term (5-5-4)."""
    return np.asarray(v_ned) - lever_velocity(lever_frd, c_b_ned, omega_b)


def imu_to_point_position(lat, lon, h, lever_frd, c_b_ned):
    """Geodetic position of the point at l^B (FRD) from the IMU (inverse of 5-5-3)."""
    return antenna_to_imu_position(lat, lon, h, -np.asarray(lever_frd), c_b_ned)


def heading_from_course(v_ned_antenna, lever_frd, omega_b, roll, pitch):
    """Heading [rad] of a body moving along its x axis from its antenna's velocity (NED) and the antenna's offset
    from that moving point (FRD) turning with the body rates: the ω x l sway of a high antenna removed from the
    course; None when the horizontal speed is all sway."""
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    w = cross(omega_b, np.asarray(lever_frd, dtype=float))
    w0 = cp * w[0] + sp * sr * w[1] + sp * cr * w[2]        # levelled (heading-free) x, y of ω x l
    w1 = cr * w[1] - sr * w[2]
    speed2 = v_ned_antenna[0] ** 2 + v_ned_antenna[1] ** 2
    if speed2 <= w1 * w1:
        return None
    return math.atan2(v_ned_antenna[1], v_ned_antenna[0]) - math.atan2(w1, math.sqrt(speed2 - w1 * w1))
