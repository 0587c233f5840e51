"""Plain GNSS driver outputs shared by the NMEA and UBX cores, their physical limits and the geoid (no ROS).

Fix-type codes equal agnav_msgs/GnssStatus FIX_*; covariance-type codes equal
sensor_msgs/NavSatFix COVARIANCE_TYPE_*; covariances are row-major 3x3 in ENU (m^2).
Angles in the cores use the receiver's convention: heading clockwise from true north (deg).

Limits (`Limits`, applied by `Screen` to every event a parser emits, one place for both drivers):
|lat| <= 90, |lon| <= 180, altitude -1000..20000 m (ellipsoidal), speed <= 100 m/s (a land vehicle),
finite values, finite non-negative PSD covariances. A message with an implausible value is dropped
whole (counted); a standard deviation below the floor (e.g. an accuracy of 0) is raised to it
(0.01 m, 0.01 m/s, 0.01 deg: the best a GNSS receiver achieves), never published as a known zero.
A fix without a position solution never carries a position: `Screen` turns it into NaN
lat/lon/alt with COV_UNKNOWN (sensor_msgs/NavSatFix convention).

Geoid (`geoid_height`): EGM96 undulation from RTKLIB's embedded 1x1 deg table (PyPI pyrtklib), used when
an NMEA GGA gives MSL altitude without the geoid separation. Without pyrtklib it returns None and the
altitude is published as unknown (vertical variance UNKNOWN_VARIANCE).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from agnav_common.input_guard import covariance as checked_covariance

FIX_NONE, FIX_SINGLE, FIX_DGPS, FIX_RTK_FLOAT, FIX_RTK_FIXED, FIX_DEAD_RECKONING = range(6)
FIX_NAMES = {FIX_NONE: "none", FIX_SINGLE: "single", FIX_DGPS: "dgps", FIX_RTK_FLOAT: "rtk_float",
             FIX_RTK_FIXED: "rtk_fixed", FIX_DEAD_RECKONING: "dead_reckoning"}
# Fix types that carry a usable position (dead reckoning only reaches /gnss/status).
POSITION_FIX_TYPES = (FIX_SINGLE, FIX_DGPS, FIX_RTK_FLOAT, FIX_RTK_FIXED)

COV_UNKNOWN, COV_APPROXIMATED, COV_DIAGONAL_KNOWN, COV_KNOWN = range(4)
UNKNOWN_VARIANCE = 99999.0  # variance of an axis the receiver does not give (INTERFACES): m^2, (m/s)^2, rad^2
GPS_EPOCH_UNIX = 315964800.0  # 1980-01-06T00:00:00Z
WEEK = 604800.0               # s in a GPS week
GEOID_MODEL_STD = 2.0       # m, 1x1 deg EGM96 table vs the true geoid (receivers' own tables differ by <= 8 m)


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


@dataclass
class Limits:
    """Physical plausibility of published GNSS quantities (a land vehicle's receiver)."""
    min_altitude: float = -1000.0    # m, ellipsoidal (Dead Sea shore -430 m MSL, geoid -107..+85 m)
    max_altitude: float = 20000.0    # m
    max_speed: float = 100.0         # m/s (360 km/h), 3D norm
    min_position_std: float = 0.01   # m, floor of a position accuracy (RTK fixed ~1 cm)
    min_velocity_std: float = 0.01   # m/s
    min_angle_std: float = 0.01      # deg


def position_problem(lat, lon, alt, limits: Limits) -> str | None:
    if not finite(lat, lon, alt):
        return "non-finite position"
    if abs(lat) > 90.0 or abs(lon) > 180.0:
        return f"position out of range {lat} {lon}"
    if not limits.min_altitude <= alt <= limits.max_altitude:
        return f"altitude {alt} m"
    return None


class Screen:
    """Applies `Limits` to the events of one message: `screen(events) -> (events, problem)`.

    Returns ([], reason) when any value is implausible (the message is dropped whole), else the events with
    covariances floored ("floored_accuracy" as problem) or (events, None)."""

    def __init__(self, limits: Limits | None = None):
        self.limits = limits or Limits()

    def __call__(self, events: list) -> tuple[list, str | None]:
        out, floored = [], False
        for e in events:
            check = {GnssFix: self._fix, GnssVelocity: self._velocity, GnssAttitude: self._attitude}.get(type(e))
            if check is None:
                out.append(e)
                continue
            e, problem = check(e)
            if e is None:
                return [], problem
            floored |= problem is not None
            out.append(e)
        return out, "floored_accuracy" if floored else None

    def _covariance(self, cov, min_std):
        c, problem = checked_covariance(np.reshape(cov, (3, 3)), min_std ** 2)
        if c is None:
            return None, problem
        return tuple(float(v) for v in c.ravel()), problem

    def _fix(self, e: GnssFix):
        if e.fix_type not in POSITION_FIX_TYPES:  # no position solution: NavSatFix NO_FIX convention
            nan = math.nan
            return GnssFix(e.host_time, e.receiver_time, nan, nan, nan, e.fix_type, (0.0,) * 9, COV_UNKNOWN), None
        problem = position_problem(e.latitude, e.longitude, e.altitude, self.limits)
        if problem is not None:
            return None, problem
        if e.covariance_type == COV_UNKNOWN:
            return e, None
        cov, problem = self._covariance(e.covariance, self.limits.min_position_std)
        if cov is None:
            return None, f"position {problem}"
        e.covariance = cov
        return e, problem

    def _velocity(self, e: GnssVelocity):
        if not finite(e.east, e.north, e.up):
            return None, "non-finite velocity"
        speed = math.hypot(e.east, e.north, e.up)
        if speed > self.limits.max_speed:
            return None, f"speed {speed:.1f} m/s"
        cov, problem = self._covariance(e.covariance, self.limits.min_velocity_std)
        if cov is None:
            return None, f"velocity {problem}"
        e.covariance = cov
        return e, problem

    def _attitude(self, e: GnssAttitude):
        angles = [a for a in (e.heading, e.roll, e.pitch) if a is not None]
        if not finite(*angles) or not 0.0 <= e.heading < 360.0 or any(abs(a) > 180.0 for a in angles[1:]):
            return None, f"attitude out of range {e.heading} {e.roll} {e.pitch}"
        floor, problem = self.limits.min_angle_std, None
        for name in ("heading_std", "roll_std", "pitch_std"):
            std = getattr(e, name)
            if std is None:
                continue
            if not finite(std) or std < 0:
                return None, f"{name} {std}"
            if std < floor:
                setattr(e, name, floor)
                problem = "floored_covariance"
        return e, problem


_GEOID = []  # [geoidh function or None], loaded on first use


def geoid_height(lat: float, lon: float) -> float | None:
    """EGM96 geoid undulation N (m, ellipsoidal = MSL + N) at lat/lon (deg), or None without a model."""
    if not _GEOID:
        try:
            import pyrtklib
            _GEOID.append(pyrtklib)
        except ImportError:
            _GEOID.append(None)
    rtk = _GEOID[0]
    if rtk is None:
        return None
    pos = rtk.Arr1Ddouble(3)
    pos[0], pos[1], pos[2] = math.radians(lat), math.radians(lon), 0.0
    return float(rtk.geoidh(pos))
