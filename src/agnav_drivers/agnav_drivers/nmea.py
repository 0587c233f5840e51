"""NMEA 0183 GNSS core: byte stream -> plain fix / velocity / status / heading / time events (no ROS).

Sentences are parsed by pynmea2 (GGA, RMC, VTG, GST, GSA, HDT, THS, ZDA; any talker: GP GN GL GA GB ...).
Policy (documented in config/nmea_gnss.yaml):
* GGA emits a GnssFixStatus every time and a GnssFix when the quality carries a position.
  Altitude = MSL altitude + geoid separation (ellipsoidal, as NavSatFix requires).
  Covariance: GST of the same or previous epoch (full ellipse if semi-major/minor/orientation are
  given, else lat/lon sigmas), otherwise HDOP x per-fix-type sigma table (vertical from VDOP of GSA
  or vertical_factor x horizontal), otherwise unknown.
* VTG or RMC emit one GnssVelocity per epoch (ENU from true course and speed), only while a valid
  fix is recent (GGA with a position or RMC status A within fix_timeout host seconds).
* HDT / THS emit a GnssAttitude (heading only); RMC / ZDA emit ReceiverTime (full UTC date+time).
Bad input is counted, never raised: checksum failures, parse errors (truncated, binary, malformed
fields), rejected values (NaN, out of range, time going backwards), noise (non-NMEA bytes/lines).
"""
from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass, field

import pynmea2
from pynmea2.nmea_utils import dm_to_sd

from .framing import LineSplitter
from .gnss_types import (COV_APPROXIMATED, COV_DIAGONAL_KNOWN, COV_KNOWN, COV_UNKNOWN, FIX_DEAD_RECKONING,
                         FIX_DGPS, FIX_NONE, FIX_RTK_FIXED, FIX_RTK_FLOAT, FIX_SINGLE, POSITION_FIX_TYPES,
                         GnssAttitude, GnssFix, GnssFixStatus, GnssVelocity, ReceiverTime, diag3, finite)

KNOT = 1852.0 / 3600.0  # m/s
DAY = 86400.0

# GGA quality indicator -> GnssStatus fix type (NMEA 0183 v4.11; 9 = SBAS on some receivers).
GGA_QUALITY = {0: FIX_NONE, 1: FIX_SINGLE, 2: FIX_DGPS, 3: FIX_SINGLE, 4: FIX_RTK_FIXED, 5: FIX_RTK_FLOAT,
               6: FIX_DEAD_RECKONING, 7: FIX_NONE, 8: FIX_NONE, 9: FIX_DGPS}


class THS(pynmea2.TalkerSentence):
    """True heading and status (NMEA 0183 v4), registered with pynmea2 by its class name."""
    fields = (("Heading", "heading", float), ("Mode indicator", "mode"))


class Rejected(ValueError):
    """A well-formed sentence with a value that must not be published; `events` still go out."""

    def __init__(self, reason: str, events: list | None = None):
        super().__init__(reason)
        self.events = events or []


class Duplicate(Exception):
    """A second sentence for an epoch already handled (e.g. GPGGA and GLGGA of one epoch)."""


@dataclass
class NmeaSettings:
    # 1-sigma horizontal error per axis for HDOP = 1 (m), by fix type.
    sigma_per_hdop: dict = field(default_factory=lambda: {
        FIX_SINGLE: 4.0, FIX_DGPS: 1.0, FIX_RTK_FLOAT: 0.5, FIX_RTK_FIXED: 0.02})
    vertical_factor: float = 2.0     # sigma_up / sigma_horizontal when GSA gives no VDOP
    velocity_std: float = 0.1        # m/s per horizontal axis (NMEA carries no speed accuracy)
    require_checksum: bool = True    # a missing '*hh' is a truncated or corrupt sentence
    gst_max_age: float = 1.5         # s of receiver time between a GST and the GGA that uses it
    fix_timeout: float = 2.0         # s of host time a valid fix keeps enabling velocity output
    max_speed: float = 515.0         # m/s (1000 kn): faster is absurd
    resync_after: int = 5            # consecutive backwards epochs that mean the receiver clock reset
    max_line: int = 256


@dataclass
class NmeaCounters:
    lines: int = 0
    accepted: int = 0
    ignored: int = 0                 # well-formed but unused (GSV, proprietary, AIS, unknown types)
    checksum_failures: int = 0
    parse_errors: int = 0
    rejected: int = 0
    time_backwards: int = 0          # part of `rejected`
    noise_lines: int = 0
    noise_bytes: int = 0
    last_problem: str = ""
    by_type: dict = field(default_factory=dict)


class Monotonic:
    """Accepts strictly increasing times; equal -> Duplicate, earlier -> Rejected, except that
    `resync` consecutive earlier times adopt the new timeline (receiver reset, spliced stream).
    With `day_wrap`, times are times of day and a drop of more than half a day is midnight."""

    def __init__(self, resync: int, day_wrap: bool = False):
        self.resync, self.day_wrap = resync, day_wrap
        self.last: float | None = None
        self._backwards = 0

    def check(self, t: float | None) -> None:
        last = self.last
        if t is None:
            return
        if last is not None and t == last:
            raise Duplicate()
        if last is not None and t < last and not (self.day_wrap and last - t > DAY / 2):
            self._backwards += 1
            if self._backwards < self.resync:
                raise Rejected(f"time backwards {last} -> {t}")
        self._backwards = 0
        self.last = t


def _seconds(t: dt.time | None) -> float | None:
    if t is None:
        return None
    if not isinstance(t, dt.time):
        raise ValueError(f"malformed time {t!r}")
    return t.hour * 3600.0 + t.minute * 60.0 + t.second + t.microsecond * 1e-6


def _degrees(value: str, hemisphere: str, limit: float, positive: str, negative: str) -> float:
    whole, _, _ = value.partition(".")
    if len(whole) < 3 or float(value[len(whole) - 2:]) >= 60.0:
        raise Rejected(f"malformed coordinate {value!r}")
    if hemisphere not in (positive, negative):
        raise Rejected(f"bad hemisphere {hemisphere!r}")
    deg = dm_to_sd(value) * (1.0 if hemisphere == positive else -1.0)
    if not finite(deg) or abs(deg) > limit:
        raise Rejected(f"coordinate out of range {deg}")
    return deg


def _optional_float(raw, low: float, high: float, name: str) -> float | None:
    """Field (text or already converted by pynmea2) as float; None when empty."""
    if raw is None or raw == "":
        return None
    value = float(raw)
    if not finite(value) or not low <= value <= high:
        raise Rejected(f"{name} out of range: {raw}")
    return value


class NmeaParser:
    """Incremental NMEA state machine: feed(bytes, host_time) -> list of gnss_types events."""

    def __init__(self, settings: NmeaSettings | None = None):
        self.settings = settings or NmeaSettings()
        self.counters = NmeaCounters()
        self._lines = LineSplitter(self.settings.max_line)
        self._handlers = {"GGA": self._gga, "RMC": self._rmc, "VTG": self._vtg, "GST": self._gst,
                          "GSA": self._gsa, "HDT": self._hdt, "THS": self._ths, "ZDA": self._zda}
        self._date: dt.date | None = None
        self._epoch_tod: float | None = None     # time of day of the latest timed sentence
        self._fix_order = {True: Monotonic(self.settings.resync_after, day_wrap=True),
                           False: Monotonic(self.settings.resync_after)}
        self._last_time_ref: float | None = None
        self._time_by_source: dict[str, Monotonic] = {}
        self._gst: tuple | None = None           # (time of day, covariance, covariance type)
        self._vdop: float | None = None
        self._fix_valid_until = -math.inf
        self._velocity_epoch: float | None = None
        self._prefix_noise = 0

    # ---- framing -------------------------------------------------------------------------------
    def feed(self, data: bytes, host_time: float) -> list:
        events = []
        for raw in self._lines.feed(data):
            events += self.parse_line(raw, host_time)
        self.counters.noise_bytes = self._lines.dropped_bytes + self._prefix_noise
        return events

    def parse_line(self, raw: bytes, host_time: float) -> list:
        c = self.counters
        c.lines += 1
        start = raw.rfind(b"$")
        if start < 0:
            if raw.startswith(b"!"):
                c.ignored += 1  # AIS / encapsulated sentences
            else:
                c.noise_lines += 1
            return []
        truncated = raw.count(b"$", 0, start)
        if truncated:
            c.parse_errors += truncated
            c.last_problem = "truncated sentence"
        self._prefix_noise += start
        try:
            text = raw[start:].decode("ascii").strip()
            msg = pynmea2.parse(text, check=self.settings.require_checksum)
        except pynmea2.ChecksumError:
            c.checksum_failures += 1
            c.last_problem = "checksum"
            return []
        except pynmea2.SentenceTypeError:
            c.ignored += 1
            return []
        except (pynmea2.ParseError, ValueError):
            c.parse_errors += 1
            c.last_problem = "unparseable sentence"
            return []
        handler = self._handlers.get(getattr(msg, "sentence_type", None))
        if handler is None:
            c.ignored += 1
            return []
        try:
            events = handler(msg, host_time)
        except Rejected as exc:
            c.rejected += 1
            c.last_problem = f"{msg.sentence_type}: {exc}"
            if "backwards" in str(exc):
                c.time_backwards += 1
            return exc.events
        except Duplicate:
            c.ignored += 1
            return []
        except (ValueError, TypeError, IndexError, AttributeError) as exc:
            c.parse_errors += 1
            c.last_problem = f"{msg.sentence_type}: {exc}"
            return []
        c.accepted += 1
        c.by_type[msg.sentence_type] = c.by_type.get(msg.sentence_type, 0) + 1
        return events

    # ---- time ----------------------------------------------------------------------------------
    def _timed(self, t: dt.time | None) -> tuple[float | None, float | None]:
        """(time of day, Unix receiver time or None) of a sentence timestamp."""
        tod = _seconds(t)
        if tod is None:
            return None, None
        self._epoch_tod = tod
        return tod, self._receiver_time(tod)

    def _receiver_time(self, tod: float | None) -> float | None:
        if tod is None or self._date is None:
            return None
        midnight = dt.datetime.combine(self._date, dt.time(), dt.timezone.utc).timestamp()
        t = midnight + tod
        if self._last_time_ref is not None and t < self._last_time_ref - DAY / 2:
            t += DAY  # GGA after midnight before the next RMC/ZDA date
        return t

    def _time_reference(self, t: float, host_time: float, source: str) -> list:
        """Monotonic per source (some receivers' ZDA runs seconds ahead of RMC); published once per time."""
        order = self._time_by_source.setdefault(source, Monotonic(self.settings.resync_after))
        try:
            order.check(t)
        except Duplicate:
            return []
        if self._last_time_ref is not None and t <= self._last_time_ref:
            return []
        self._last_time_ref = t
        return [ReceiverTime(host_time, t, source)]

    # ---- sentences -----------------------------------------------------------------------------
    def _gga(self, msg, host_time: float) -> list:
        quality = 0 if msg.gps_qual is None else msg.gps_qual  # empty field: no fix
        if quality not in GGA_QUALITY:
            raise Rejected(f"unknown quality {quality!r}")
        fix_type = GGA_QUALITY[quality]
        tod, rt = self._timed(msg.timestamp)
        sats = int(msg.num_sats) if msg.num_sats else 0
        if not 0 <= sats <= 255:
            raise Rejected(f"satellites {sats}")
        hdop = _optional_float(msg.horizontal_dil, 0.0, 100.0, "hdop")
        age = _optional_float(msg.age_gps_data, 0.0, 3600.0, "correction age")
        if fix_type not in POSITION_FIX_TYPES:
            self._fix_valid_until = -math.inf
        else:
            self._fix_order[rt is None].check(rt if rt is not None else tod)
        status = GnssFixStatus(host_time, rt, fix_type, sats,
                               -1.0 if hdop is None else hdop, -1.0 if age is None else age)
        if fix_type not in POSITION_FIX_TYPES:
            return [status]
        try:
            lat = _degrees(msg.lat, msg.lat_dir, 90.0, "N", "S")
            lon = _degrees(msg.lon, msg.lon_dir, 180.0, "E", "W")
            alt_msl = _optional_float(msg.altitude, -1000.0, 1e5, "altitude")
            if alt_msl is None:
                raise Rejected("no altitude (2D fix)")
        except Rejected as exc:
            raise Rejected(str(exc), [status]) from None
        separation = _optional_float(msg.geo_sep, -200.0, 200.0, "geoid separation") or 0.0
        cov, cov_type = self._covariance(fix_type, hdop, tod)
        self._fix_valid_until = host_time + self.settings.fix_timeout
        return [status, GnssFix(host_time, rt, lat, lon, alt_msl + separation, fix_type, cov, cov_type)]

    def _covariance(self, fix_type: int, hdop: float | None, tod: float | None) -> tuple[tuple, int]:
        s = self.settings
        if self._gst is not None and tod is not None:
            gst_tod, cov, cov_type = self._gst
            gap = abs(tod - gst_tod)
            if min(gap, DAY - gap) <= s.gst_max_age:
                return cov, cov_type
        sigma_per_hdop = s.sigma_per_hdop.get(fix_type)
        if hdop is None or hdop <= 0.0 or sigma_per_hdop is None:
            return (0.0,) * 9, COV_UNKNOWN
        sigma_h = hdop * sigma_per_hdop
        sigma_v = self._vdop * sigma_per_hdop if self._vdop else s.vertical_factor * sigma_h
        return diag3(sigma_h ** 2, sigma_h ** 2, sigma_v ** 2), COV_APPROXIMATED

    def _gst(self, msg, host_time: float) -> list:
        tod, _ = self._timed(msg.timestamp)
        if tod is None:
            raise Rejected("GST without time")
        sig = {name: _optional_float(getattr(msg, name), 0.0, 1e5, name) for name in (
            "std_dev_major", "std_dev_minor", "std_dev_latitude", "std_dev_longitude",
            "std_dev_altitude")}
        major, minor = sig["std_dev_major"], sig["std_dev_minor"]
        orient = _optional_float(msg.orientation, -360.0, 360.0, "orientation")
        s_lat, s_lon, s_alt = sig["std_dev_latitude"], sig["std_dev_longitude"], sig["std_dev_altitude"]
        if major and minor is not None and orient is not None:
            th = math.radians(orient)  # semi-major axis azimuth, clockwise from north
            u, v = (math.sin(th), math.cos(th)), (math.cos(th), -math.sin(th))
            ee = (major * u[0]) ** 2 + (minor * v[0]) ** 2
            nn = (major * u[1]) ** 2 + (minor * v[1]) ** 2
            en = major ** 2 * u[0] * u[1] + minor ** 2 * v[0] * v[1]
            cov_type = COV_KNOWN
        elif s_lat and s_lon:
            ee, nn, en = s_lon ** 2, s_lat ** 2, 0.0
            cov_type = COV_DIAGONAL_KNOWN
        else:
            self._gst = None
            return []
        uu = s_alt ** 2 if s_alt else self.settings.vertical_factor ** 2 * max(ee, nn)
        self._gst = (tod, (ee, en, 0.0, en, nn, 0.0, 0.0, 0.0, uu), cov_type)
        return []

    def _gsa(self, msg, host_time: float) -> list:
        self._vdop = _optional_float(msg.vdop, 0.0, 100.0, "vdop") or None
        _optional_float(msg.pdop, 0.0, 100.0, "pdop")
        return []

    def _velocity(self, host_time: float, speed: float | None, course: float | None) -> list:
        s = self.settings
        if speed is None or host_time > self._fix_valid_until:
            return []
        if self._velocity_epoch is not None and self._velocity_epoch == self._epoch_tod:
            return []  # RMC and VTG of one epoch: publish once
        var = s.velocity_std ** 2
        if course is None:
            if speed > 2.0 * s.velocity_std:
                return []  # moving with no direction: nothing honest to publish
            east = north = 0.0
            var = max(var, speed ** 2)
        else:
            east, north = speed * math.sin(math.radians(course)), speed * math.cos(math.radians(course))
        self._velocity_epoch = self._epoch_tod
        return [GnssVelocity(host_time, self._receiver_time(self._epoch_tod), east, north, 0.0,
                             diag3(var, var, 99999.0))]

    def _speed_course(self, knots, course, kmh=None):
        top = self.settings.max_speed
        speed_kn = _optional_float(knots, 0.0, top / KNOT, "speed")
        if speed_kn is None and kmh:
            speed_kn = _optional_float(kmh, 0.0, top * 3.6, "speed") / 3.6 / KNOT
        return (None if speed_kn is None else speed_kn * KNOT), _optional_float(course, 0.0, 360.0, "course")

    def _rmc(self, msg, host_time: float) -> list:
        date = msg.datestamp
        if date is not None and not isinstance(date, dt.date):
            raise ValueError(f"malformed date {date!r}")
        tod, _ = self._timed(msg.timestamp)
        speed, course = self._speed_course(msg.spd_over_grnd, msg.true_course)
        events = []
        if date is not None and tod is not None:
            self._date = date
            events += self._time_reference(self._receiver_time(tod), host_time, msg.talker + "RMC")
        mode = getattr(msg, "mode_indicator", "") or ""
        if msg.status == "A" and mode != "N":
            self._fix_valid_until = max(self._fix_valid_until, host_time + self.settings.fix_timeout)
            events += self._velocity(host_time, speed, course)
        return events

    def _vtg(self, msg, host_time: float) -> list:
        if (msg.faa_mode or "") == "N":
            return []
        speed, course = self._speed_course(msg.spd_over_grnd_kts, msg.true_track, msg.spd_over_grnd_kmph)
        return self._velocity(host_time, speed, course)

    def _heading(self, value, host_time: float) -> list:
        heading = _optional_float(value, 0.0, 360.0, "heading")
        if heading is None:
            return []
        return [GnssAttitude(host_time, self._receiver_time(self._epoch_tod), heading % 360.0)]

    def _hdt(self, msg, host_time: float) -> list:
        return self._heading(msg.heading, host_time)

    def _ths(self, msg, host_time: float) -> list:
        if msg.mode not in ("A", "E"):
            return []  # manual, simulator or invalid
        return self._heading(msg.heading, host_time)

    def _zda(self, msg, host_time: float) -> list:
        if not (msg.year and msg.month and msg.day) or msg.timestamp is None:
            return []
        date = dt.date(int(msg.year), int(msg.month), int(msg.day))
        if not 1980 <= date.year <= 2100:
            raise Rejected(f"year {date.year}")
        self._date = date
        tod, rt = self._timed(msg.timestamp)
        return self._time_reference(rt, host_time, msg.talker + "ZDA")
