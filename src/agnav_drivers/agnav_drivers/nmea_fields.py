"""NMEA 0183 field helpers of the NMEA core: value parsing with range checks, epoch ordering, THS (no ROS)."""
from __future__ import annotations

import datetime as dt

import pynmea2
from pynmea2.nmea_utils import dm_to_sd

from .gnss_types import finite

KNOT = 1852.0 / 3600.0  # m/s
DAY = 86400.0


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


def seconds(t: dt.time | None) -> float | None:
    """Time of day (s) of a pynmea2 timestamp."""
    if t is None:
        return None
    if not isinstance(t, dt.time):
        raise ValueError(f"malformed time {t!r}")
    return t.hour * 3600.0 + t.minute * 60.0 + t.second + t.microsecond * 1e-6


def tod_gap(a: float, b: float) -> float:
    """Distance (s) of two times of day across midnight."""
    gap = abs(a - b) % DAY
    return min(gap, DAY - gap)


def degrees(value: str, hemisphere: str, limit: float, positive: str, negative: str) -> float:
    whole, _, _ = value.partition(".")
    if len(whole) < 3 or float(value[len(whole) - 2:]) >= 60.0:
        raise Rejected(f"malformed coordinate {value!r}")
    if hemisphere not in (positive, negative):
        raise Rejected(f"bad hemisphere {hemisphere!r}")
    deg = dm_to_sd(value) * (1.0 if hemisphere == positive else -1.0)
    if not finite(deg) or abs(deg) > limit:
        raise Rejected(f"coordinate out of range {deg}")
    return deg


def lat_lon(msg) -> tuple[float, float]:
    """Latitude, longitude (deg) of a sentence with lat, lat_dir, lon, lon_dir fields."""
    return degrees(msg.lat, msg.lat_dir, 90.0, "N", "S"), degrees(msg.lon, msg.lon_dir, 180.0, "E", "W")


def optional_float(raw, low: float, high: float, name: str) -> float | None:
    """Field (text or already converted by pynmea2) as float; None when empty."""
    if raw is None or raw == "":
        return None
    value = float(raw)
    if not finite(value) or not low <= value <= high:
        raise Rejected(f"{name} out of range: {raw}")
    return value
