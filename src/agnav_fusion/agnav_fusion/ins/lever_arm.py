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


def antenna_to_imu_velocity(v_ned, lever_frd, c_b_ned, omega_b):
    """IMU velocity (NED) from the antenna's with the ω x l term (5-5-4)."""
    return np.asarray(v_ned) - c_b_ned @ cross(omega_b, lever_frd)


def imu_to_point_position(lat, lon, h, lever_frd, c_b_ned):
    """Geodetic position of the point at l^B (FRD) from the IMU (inverse of 5-5-3)."""
    return antenna_to_imu_position(lat, lon, h, -np.asarray(lever_frd), c_b_ned)
