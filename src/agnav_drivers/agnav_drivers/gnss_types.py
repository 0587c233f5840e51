"""Plain GNSS driver outputs shared by the NMEA and UBX cores (no ROS import).

Fix-type codes equal agnav_msgs/GnssStatus FIX_*; covariance-type codes equal
sensor_msgs/NavSatFix COVARIANCE_TYPE_*; covariances are row-major 3x3 in ENU (m^2).
Angles in the cores use the receiver's convention: heading clockwise from true north (deg).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

FIX_NONE, FIX_SINGLE, FIX_DGPS, FIX_RTK_FLOAT, FIX_RTK_FIXED, FIX_DEAD_RECKONING = range(6)
FIX_NAMES = {FIX_NONE: "none", FIX_SINGLE: "single", FIX_DGPS: "dgps", FIX_RTK_FLOAT: "rtk_float",
             FIX_RTK_FIXED: "rtk_fixed", FIX_DEAD_RECKONING: "dead_reckoning"}
# Fix types that carry a usable position (dead reckoning only reaches /gnss/status).
POSITION_FIX_TYPES = (FIX_SINGLE, FIX_DGPS, FIX_RTK_FLOAT, FIX_RTK_FIXED)

COV_UNKNOWN, COV_APPROXIMATED, COV_DIAGONAL_KNOWN, COV_KNOWN = range(4)


def diag3(ve: float, vn: float, vu: float) -> tuple:
    """Row-major 3x3 diagonal covariance."""
    return (ve, 0.0, 0.0, 0.0, vn, 0.0, 0.0, 0.0, vu)


def finite(*values) -> bool:
    return all(v is not None and math.isfinite(v) for v in values)


@dataclass
class GnssFix:
    """Antenna position, ellipsoidal altitude (WGS-84)."""
    host_time: float
    receiver_time: float | None      # Unix seconds (UTC) when the receiver gave a full date+time
    latitude: float                  # deg
    longitude: float                 # deg
    altitude: float                  # m above the WGS-84 ellipsoid
    fix_type: int
    covariance: tuple = field(default_factory=lambda: (0.0,) * 9)
    covariance_type: int = COV_UNKNOWN


@dataclass
class GnssVelocity:
    """Antenna velocity, ENU (m/s); variances in (m/s)^2."""
    host_time: float
    receiver_time: float | None
    east: float
    north: float
    up: float
    covariance: tuple


@dataclass
class GnssFixStatus:
    host_time: float
    receiver_time: float | None
    fix_type: int
    satellites_used: int
    hdop: float                      # -1 if unknown
    correction_age: float            # s, -1 if none


@dataclass
class GnssAttitude:
    """Receiver attitude: heading clockwise from true north, pitch nose up, roll right side down (deg).

    Missing axes are None; standard deviations (deg) are None when the receiver gives none.
    """
    host_time: float
    receiver_time: float | None
    heading: float
    heading_std: float | None = None
    roll: float | None = None
    pitch: float | None = None
    roll_std: float | None = None
    pitch_std: float | None = None


@dataclass
class ReceiverTime:
    host_time: float
    receiver_time: float             # Unix seconds (UTC)
    source: str                      # sentence/message that carried it
