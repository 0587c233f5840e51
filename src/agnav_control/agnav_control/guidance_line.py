"""Straight AB guidance lines in the `map` frame: geometry, parallel passes, teaching and the variable target
heading (SPEC §3.4 teaching, §3.6 variable target; signs per INTERFACES GuidanceState)."""
import math
from dataclasses import dataclass, replace

import numpy as np
from agnav_common.frames import heading_from_yaw, wrap_angle, yaw_from_heading
from agnav_common.variance_weighted_average import VariableTargetVwa, VwaSettings


@dataclass(frozen=True)
class TrackingError:
    """Vehicle state relative to the followed line (INTERFACES GuidanceState signs)."""

    cross_track: float    # m, positive = vehicle left of the line
    heading_error: float  # rad, vehicle yaw minus line yaw, wrapped to (-pi, pi]
    line_yaw: float       # rad, ENU yaw of the followed direction
    speed: float          # m/s along the followed direction
    along_track: float    # m from the line origin along line_yaw
    crab: float = 0.0     # rad, side slip: course over ground minus yaw (+ sliding left)

    @property
    def course_error(self) -> float:
        """Course over ground minus line yaw (rad): the heading error the controllers steer, so that a crabbing
        vehicle holds the line with its body turned into the slope (feed-forward of the crab)."""
        return wrap_angle(self.heading_error + self.crab)


MAX_CRAB = 0.2  # rad, default clamp of the crab angle taken from the twist (11 deg: far beyond a slope's slide)


def crab_angle(speed: float, lateral_speed: float, max_crab: float = MAX_CRAB, min_speed: float = 0.3) -> float:
    """Side-slip angle (rad, + left) from the base_link twist: atan(linear.y / linear.x), 0 below min_speed (m/s),
    clamped to +-max_crab."""
    if abs(speed) < min_speed:
        return 0.0
    return min(max(math.atan(lateral_speed / speed), -max_crab), max_crab)


@dataclass(frozen=True)
class GuidanceLine:
    """Infinite straight line through (x, y) with ENU direction yaw."""

    x: float
    y: float
    yaw: float

    @classmethod
    def from_points(cls, a, b) -> "GuidanceLine":
        """AB line from map points a -> b (m); raises ValueError if they coincide."""
        dx, dy = float(b[0]) - float(a[0]), float(b[1]) - float(a[1])
        if math.hypot(dx, dy) < 1e-6:
            raise ValueError("A and B coincide")
        return cls(float(a[0]), float(a[1]), math.atan2(dy, dx))

    @classmethod
    def from_latlon(cls, plane, a_latlon, b_latlon) -> "GuidanceLine":
        """AB line from (lat_deg, lon_deg) points, projected on a geodesy.LocalTangentPlane."""
        ea, na, _ = plane.to_enu(a_latlon[0], a_latlon[1], plane.alt_m)
        eb, nb, _ = plane.to_enu(b_latlon[0], b_latlon[1], plane.alt_m)
        return cls.from_points((float(ea), float(na)), (float(eb), float(nb)))

    def offset(self, distance: float) -> "GuidanceLine":
        """The parallel line `distance` m to the left (negative: right) of this direction."""
        return replace(self, x=self.x - distance * math.sin(self.yaw), y=self.y + distance * math.cos(self.yaw))

    def reversed(self) -> "GuidanceLine":
        return replace(self, yaw=wrap_angle(self.yaw + math.pi))

    def rotated_about(self, x: float, y: float, yaw: float) -> "GuidanceLine":
        """Line with direction `yaw` on which (x, y) keeps its present cross-track (continuous re-targeting)."""
        e = self.error(x, y, self.yaw, 0.0, bidirectional=False).cross_track
        return GuidanceLine(x + e * math.sin(yaw), y - e * math.cos(yaw), wrap_angle(yaw))

    def error(self, x: float, y: float, yaw: float, speed: float, bidirectional: bool = True,
              crab: float = 0.0) -> TrackingError:
        """Cross-track and heading error; with bidirectional the direction nearer the vehicle yaw is followed;
        crab (rad) is carried to the controllers (TrackingError.course_error)."""
        line = self
        if bidirectional and abs(wrap_angle(yaw - self.yaw)) > math.pi / 2:
            line = self.reversed()
        c, s = math.cos(line.yaw), math.sin(line.yaw)
        dx, dy = x - line.x, y - line.y
        he = wrap_angle(yaw - line.yaw)
        return TrackingError(cross_track=-s * dx + c * dy, heading_error=he, line_yaw=line.yaw,
                             speed=speed * math.cos(he), along_track=c * dx + s * dy, crab=crab)


@dataclass(frozen=True)
class ParallelPasses:
    """Passes k = ..., -1, 0, 1, ... offset k*width to the left of the base line."""

    base: GuidanceLine
    width: float  # m, implement working width

    def line(self, index: int) -> GuidanceLine:
        return self.base.offset(index * self.width)

    def nearest(self, x: float, y: float) -> int:
        """Index of the pass closest to (x, y)."""
        e = self.base.error(x, y, self.base.yaw, 0.0, bidirectional=False).cross_track
        return int(round(e / self.width))

    def next_index(self, current: int, x: float, y: float) -> int:
        """After a headland turn: the neighbour of `current` on the side the vehicle now is."""
        e = self.base.error(x, y, self.base.yaw, 0.0, bidirectional=False).cross_track
        return current + (1 if e >= current * self.width else -1)


class LineTeacher:
    """Teaching (SPEC §3.4): drive the desired line manually; the line passes through the centroid of the
    taught positions with the circular-mean yaw ('yaw') or the start-to-end track direction ('track')."""

    def __init__(self, min_distance: float = 3.0, heading_source: str = "yaw"):
        if heading_source not in ("yaw", "track"):
            raise ValueError(f"heading_source must be 'yaw' or 'track', not {heading_source!r}")
        self.min_distance = min_distance
        self.heading_source = heading_source
        self._xy, self._yaw = [], []

    def add(self, x: float, y: float, yaw: float):
        self._xy.append((x, y))
        self._yaw.append(yaw)

    @property
    def distance(self) -> float:
        """Straight distance from the first to the last taught position (m)."""
        if len(self._xy) < 2:
            return 0.0
        return math.dist(self._xy[0], self._xy[-1])

    def line(self) -> GuidanceLine | None:
        """The taught line, or None while shorter than min_distance."""
        if self.distance < self.min_distance:
            return None
        cx, cy = np.mean(self._xy, axis=0)
        if self.heading_source == "track":
            (x0, y0), (x1, y1) = self._xy[0], self._xy[-1]
            yaw = math.atan2(y1 - y0, x1 - x0)
        else:
            yaw = math.atan2(np.mean(np.sin(self._yaw)), np.mean(np.cos(self._yaw)))
        return GuidanceLine(float(cx), float(cy), yaw)


class VariableTargetLine:
    """Variable target heading (SPEC §3.6, Fig. 2.19) for one fused yaw stream: every ΔT the line is turned to
    the mean heading of the last T s about the vehicle (cross-track kept), windowing by agnav_common's VWA."""

    def __init__(self, settings: VwaSettings | None = None):
        self._vwa = VariableTargetVwa(settings)
        self._heading = None  # unwrapped thesis heading (rad, clockwise from north)

    def update(self, line: GuidanceLine, t: float, x: float, y: float, yaw: float) -> GuidanceLine:
        """Feed the pose at t; returns the re-targeted line when an update is due, else `line`."""
        heading = float(heading_from_yaw(yaw))
        if self._heading is not None:
            heading = self._heading + wrap_angle(heading - self._heading)
        self._heading = heading
        before = self._vwa.stats
        self._vwa.update(t, heading, heading)
        if self._vwa.stats is before:
            return line
        target = float(yaw_from_heading(self._vwa.target))
        if abs(wrap_angle(target - line.yaw)) > math.pi / 2:  # keep the line's own direction
            target = wrap_angle(target + math.pi)
        return line.rotated_about(x, y, target)
