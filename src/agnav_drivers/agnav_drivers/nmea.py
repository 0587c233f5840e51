"""NMEA 0183 GNSS core: byte stream -> plain fix / velocity / status / heading / time events (no ROS).

Sentences are parsed by pynmea2 (GGA, RMC, GLL, VTG, GST, GSA, HDT, THS, ZDA; any talker: GP GN GL GA GB ...).
Policy (documented in config/nmea_gnss.yaml):
* GGA emits a GnssFixStatus every time and a GnssFix when the quality carries a position.
  Altitude = MSL altitude + geoid separation (ellipsoidal, as NavSatFix requires); an empty separation
  field is replaced by the EGM96 model (gnss_types.geoid_height, vertical variance + GEOID_MODEL_STD^2),
  or, without a model, the altitude is marked unknown (vertical variance UNKNOWN_VARIANCE).
  Covariance: GST of the same or previous epoch (full ellipse if semi-major/minor/orientation are
  given, else lat/lon sigmas), otherwise HDOP x per-fix-type sigma table (vertical from VDOP of GSA
  or vertical_factor x horizontal), otherwise unknown.
* RMC / GLL with status A (mode not E/M/S/N) emit a GnssFix (single) when the stream has no GGA: none
  within gga_timeout receiver seconds, and not at the first such epoch (a GGA may still follow it).
  They carry no accuracy and no altitude: covariance from GST, else sigma_no_accuracy per horizontal
  axis (APPROXIMATED); altitude = mean sea level (the geoid, 0 without a model) with vertical variance
  UNKNOWN_VARIANCE (consumers reject a NaN altitude).
* VTG or RMC emit one GnssVelocity per epoch (ENU from true course and speed), only while a valid
  fix is recent (GGA with a position or RMC status A within fix_timeout host seconds).
* HDT / THS emit a GnssAttitude (heading only); RMC / ZDA emit ReceiverTime (full UTC date+time).
* Every event passes gnss_types.Screen (physical limits, accuracy floors).
Bad input is counted, never raised: checksum failures, parse errors (truncated, binary, malformed
fields), rejected values (NaN, out of range, implausible, time going backwards), noise (non-NMEA bytes/lines).
"""
from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass, field

import pynmea2

from .framing import LineSplitter
from .gnss_types import (COV_APPROXIMATED, COV_DIAGONAL_KNOWN, COV_KNOWN, COV_UNKNOWN, FIX_DEAD_RECKONING,
                         FIX_DGPS, FIX_NONE, FIX_RTK_FIXED, FIX_RTK_FLOAT, FIX_SINGLE, GEOID_MODEL_STD,
                         POSITION_FIX_TYPES, UNKNOWN_VARIANCE, GnssAttitude, GnssFix, GnssFixStatus, GnssVelocity,
                         Limits, ReceiverTime, Screen, diag3, geoid_height)
from .nmea_fields import (DAY, KNOT, THS, Duplicate, Monotonic, Rejected, lat_lon, optional_float, seconds,
                          tod_gap)

__all__ = ["KNOT", "THS", "NmeaParser", "NmeaSettings", "NmeaCounters"]

# GGA quality indicator -> GnssStatus fix type (NMEA 0183 v4.11; 9 = SBAS on some receivers).
GGA_QUALITY = {0: FIX_NONE, 1: FIX_SINGLE, 2: FIX_DGPS, 3: FIX_SINGLE, 4: FIX_RTK_FIXED, 5: FIX_RTK_FLOAT,
               6: FIX_DEAD_RECKONING, 7: FIX_NONE, 8: FIX_NONE, 9: FIX_DGPS}
NO_POSITION_MODES = ("E", "M", "S", "N")  # FAA mode: estimated (dead reckoning), manual, simulator, invalid


@dataclass
class NmeaSettings:
    # 1-sigma horizontal error per axis for HDOP = 1 (m), by fix type.
    sigma_per_hdop: dict = field(default_factory=lambda: {
        FIX_SINGLE: 4.0, FIX_DGPS: 1.0, FIX_RTK_FLOAT: 0.5, FIX_RTK_FIXED: 0.02})
    vertical_factor: float = 2.0     # sigma_up / sigma_horizontal when GSA gives no VDOP
    velocity_std: float = 0.1        # m/s per horizontal axis (NMEA carries no speed accuracy)
    sigma_no_accuracy: float = 10.0  # m per horizontal axis of an RMC/GLL fix (no HDOP, no GST)
    gga_timeout: float = 2.0         # receiver s without GGA after which RMC/GLL give the fixes
    require_checksum: bool = True    # a missing '*hh' is a truncated or corrupt sentence
    gst_max_age: float = 1.5         # s of receiver time between a GST and the GGA that uses it
    fix_timeout: float = 2.0         # s of host time a valid fix keeps enabling velocity output
    resync_after: int = 5            # consecutive backwards epochs that mean the receiver clock reset
    max_line: int = 256
    limits: Limits = field(default_factory=Limits)  # physical plausibility (shared with the UBX driver)


@dataclass
class NmeaCounters:
    lines: int = 0
    accepted: int = 0
    ignored: int = 0                 # well-formed but unused (GSV, proprietary, AIS, unknown types)
    checksum_failures: int = 0
    parse_errors: int = 0
    rejected: int = 0
    time_backwards: int = 0          # part of `rejected`
    implausible: int = 0             # values outside gnss_types.Limits (part of `rejected`)
    floored_accuracy: int = 0        # sentences with an accuracy raised to the floor (published)
    geoid_model: int = 0             # fixes whose geoid separation came from the model (or is unknown)
    noise_lines: int = 0
    noise_bytes: int = 0
    last_problem: str = ""
    by_type: dict = field(default_factory=dict)


class NmeaParser:
    """Incremental NMEA state machine: feed(bytes, host_time) -> list of gnss_types events."""

    def __init__(self, settings: NmeaSettings | None = None):
        self.settings = settings or NmeaSettings()
        self.counters = NmeaCounters()
        self._lines = LineSplitter(self.settings.max_line)
        self._handlers = {"GGA": self._gga, "RMC": self._rmc, "GLL": self._gll, "VTG": self._vtg, "GST": self._gst,
                          "GSA": self._gsa, "HDT": self._hdt, "THS": self._ths, "ZDA": self._zda}
        self._screen = Screen(self.settings.limits)
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
        self._gga_seen = False
        self._gga_tod: float | None = None       # time of day of the latest GGA
        self._first_fallback_tod: float | None = None  # first RMC/GLL epoch with a position
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
        events, problem = self._screen(events)
        if problem is not None:
            c.last_problem = f"{msg.sentence_type}: {problem}"
            if not events:
                c.rejected += 1
                c.implausible += 1
                return []
            c.floored_accuracy += 1
        c.accepted += 1
        c.by_type[msg.sentence_type] = c.by_type.get(msg.sentence_type, 0) + 1
        return events

    # ---- time ----------------------------------------------------------------------------------
    def _timed(self, t: dt.time | None) -> tuple[float | None, float | None]:
        """(time of day, Unix receiver time or None) of a sentence timestamp."""
        tod = seconds(t)
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
        quality = 0 if msg.gps_qual is None else msg.gps_qual  # empty field: no fix (myguide-3100 capture)
        if quality not in GGA_QUALITY:
            raise Rejected(f"unknown quality {quality!r}")
        fix_type = GGA_QUALITY[quality]
        tod, rt = self._timed(msg.timestamp)
        self._gga_seen, self._gga_tod = True, self._epoch_tod
        sats = int(msg.num_sats) if msg.num_sats else 0
        if not 0 <= sats <= 255:
            raise Rejected(f"satellites {sats}")
        hdop = optional_float(msg.horizontal_dil, 0.0, 100.0, "hdop")
        age = optional_float(msg.age_gps_data, 0.0, 3600.0, "correction age")
        if fix_type not in POSITION_FIX_TYPES:
            self._fix_valid_until = -math.inf
        else:
            self._fix_order[rt is None].check(rt if rt is not None else tod)
        status = GnssFixStatus(host_time, rt, fix_type, sats,
                               -1.0 if hdop is None else hdop, -1.0 if age is None else age)
        if fix_type not in POSITION_FIX_TYPES:
            return [status]
        try:
            lat, lon = lat_lon(msg)
            alt_msl = optional_float(msg.altitude, -math.inf, math.inf, "altitude")
            if alt_msl is None:
                raise Rejected("no altitude (2D fix)")
        except Rejected as exc:
            raise Rejected(str(exc), [status]) from None
        separation = optional_float(msg.geo_sep, -200.0, 200.0, "geoid separation")
        cov, cov_type = self._covariance(fix_type, hdop, tod)
        if separation is None:  # MSL altitude without the separation: the geoid model, else unknown
            self.counters.geoid_model += 1
            separation = geoid_height(lat, lon)
            extra = UNKNOWN_VARIANCE if separation is None else GEOID_MODEL_STD ** 2
            cov = cov[:8] + (cov[8] + extra,) if cov_type != COV_UNKNOWN else cov
        self._fix_valid_until = host_time + self.settings.fix_timeout
        return [status, GnssFix(host_time, rt, lat, lon, alt_msl + (separation or 0.0), fix_type, cov, cov_type)]

    def _fallback_fix(self, msg, tod: float | None, mode: str, host_time: float) -> list:
        """RMC / GLL position (status A) when the stream gives no GGA; [] otherwise."""
        if msg.status != "A" or mode in NO_POSITION_MODES or not (msg.lat and msg.lon) or tod is None:
            return []
        if self._gga_seen and (self._gga_tod is None or tod_gap(tod, self._gga_tod) <= self.settings.gga_timeout):
            return []  # GGA is the fix source
        if self._first_fallback_tod is None:
            self._first_fallback_tod = tod  # a GGA of this epoch may still follow
        if tod_gap(tod, self._first_fallback_tod) == 0.0:
            return []
        lat, lon = lat_lon(msg)
        rt = self._receiver_time(tod)
        try:
            self._fix_order[rt is None].check(rt if rt is not None else tod)
        except Duplicate:
            return []  # RMC and GLL of one epoch
        cov, cov_type = self._covariance(FIX_SINGLE, None, tod)
        if cov_type == COV_UNKNOWN:
            sigma = self.settings.sigma_no_accuracy
            cov, cov_type = diag3(sigma ** 2, sigma ** 2, 0.0), COV_APPROXIMATED
        sea_level = geoid_height(lat, lon)
        self._fix_valid_until = max(self._fix_valid_until, host_time + self.settings.fix_timeout)
        return [GnssFix(host_time, rt, lat, lon, sea_level or 0.0, FIX_SINGLE, cov[:8] + (UNKNOWN_VARIANCE,),
                        cov_type)]

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
        sig = {name: optional_float(getattr(msg, name), 0.0, 1e5, name) for name in (
            "std_dev_major", "std_dev_minor", "std_dev_latitude", "std_dev_longitude",
            "std_dev_altitude")}
        major, minor = sig["std_dev_major"], sig["std_dev_minor"]
        orient = optional_float(msg.orientation, -360.0, 360.0, "orientation")
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
        self._vdop = optional_float(msg.vdop, 0.0, 100.0, "vdop") or None
        optional_float(msg.pdop, 0.0, 100.0, "pdop")
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
        """Speed (m/s) and course (deg) fields; a speed beyond the limits is left to Screen (implausible)."""
        speed_kn = optional_float(knots, 0.0, math.inf, "speed")
        if speed_kn is None and kmh:
            speed_kn = optional_float(kmh, 0.0, math.inf, "speed") / 3.6 / KNOT
        return (None if speed_kn is None else speed_kn * KNOT), optional_float(course, 0.0, 360.0, "course")

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
        try:
            events += self._fallback_fix(msg, tod, mode, host_time)
        except Rejected as exc:
            raise Rejected(str(exc), events) from None
        if msg.status == "A" and mode != "N":
            self._fix_valid_until = max(self._fix_valid_until, host_time + self.settings.fix_timeout)
            events += self._velocity(host_time, speed, course)
        return events

    def _gll(self, msg, host_time: float) -> list:
        tod, _ = self._timed(msg.timestamp)
        return self._fallback_fix(msg, tod, getattr(msg, "faa_mode", "") or "", host_time)

    def _vtg(self, msg, host_time: float) -> list:
        if (msg.faa_mode or "") == "N":
            return []
        speed, course = self._speed_course(msg.spd_over_grnd_kts, msg.true_track, msg.spd_over_grnd_kmph)
        return self._velocity(host_time, speed, course)

    def _heading(self, value, host_time: float) -> list:
        heading = optional_float(value, 0.0, 360.0, "heading")
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
