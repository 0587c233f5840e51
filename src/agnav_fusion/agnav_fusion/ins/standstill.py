"""Gyro bias and level learnt standing still before the in-motion alignment ([IMPL]).

The GNSS/INS waits for the vehicle to drive before it aligns; while it stands, the gyros read their biases plus the
earth rate. The mean rate over the latest stretch that the fixes show standing, less the earth rate's component
along the vertical (known from the latitude and the accelerometers), starts the gyro bias state; the horizontal
earth rate (direction unknown until the heading is) counts in its variance. Without it the bias is learnt only
from heading innovations once moving, and on straight runs those go into the crab as much as into the bias.
Motion shows in the fixes late (latency, the radius a fix-only start must leave), so the stretch ends `guard` s before
its last standing fix and trailing samples whose mean rate departs from the stretch's median (a start's pitching)
are dropped (and those whose specific force departs from it: a start's acceleration).
The same stretch's mean specific force gives the roll and pitch standing, which the gyros (less that bias) carry to
the alignment: a level taken while driving off reads the start's acceleration as tilt (0.5 m/s^2 is 2.9 deg).
"""
import math
from collections import deque
from dataclasses import dataclass
from typing import NamedTuple

from . import earth, quaternion
from .mechanization import roll_pitch_from_accel


class Standing(NamedTuple):
    """What a standing stretch measured: gyro bias FRD [rad/s], its variances, mean specific force FRD [m/s^2] and
    the end of the samples averaged [s]."""

    bias: list
    var: list
    accel: list
    t_end: float


@dataclass
class StandstillSettings:
    """When the fixes show standing, and how long a stretch must last to measure the gyro bias."""

    enabled: bool = True         # learn the gyro bias standing still (false: it starts at zero)
    speed: float = 0.05          # m/s, a receiver velocity below this shows standing
    radius: float = 0.1          # m, without a receiver velocity: fixes within this plus 3 sigma of the stretch's first
    min_duration: float = 2.0    # s of standing for a bias measurement
    guard: float = 1.0           # s before the last standing fix left out (motion began before the fixes show it)
    rate_tolerance: float = math.radians(0.1)  # rad/s, a trailing 0.25 s mean rate this far from the median: moving
    accel_tolerance: float = 0.05  # m/s^2, a trailing 0.25 s mean specific force this far from the median: moving
    window: float = 60.0         # s, longest stretch averaged (the bias drifts)
    carry: float = 30.0          # s, longest the gyros carry the standing level to the alignment (else: level
                                 # from the accelerometers at the alignment)


class StandstillBias:
    """Feed IMU samples and fixes before the alignment; `estimate(lat)` -> Standing or None; `level(standing)`."""

    BUCKET = 0.25                # s of IMU samples summed per bucket

    def __init__(self, settings, gyro_arw):
        self.s, self.arw = settings, gyro_arw
        self._buckets = deque()  # [t, gyro sums (3), accel sums (3), count]
        self._candidate = None   # [t first, t last, first fix] of the standing stretch in progress
        self._stretch = None     # (t first, t last) of the latest stretch that lasted min_duration
        self._samples = deque()  # (t, gyro) of the last `carry` s
        self._carried = None     # (Standing, attitude quaternion, its time): the level carried so far

    def add_imu(self, t, gyro, accel):
        self._samples.append((t, gyro))
        while self._samples[0][0] < t - self.s.carry:
            self._samples.popleft()
        b = self._buckets[-1] if self._buckets else None
        if b is None or t - b[0] >= self.BUCKET:
            b = [t, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 0]
            self._buckets.append(b)
        for i in range(3):
            b[1][i] += gyro[i]
            b[2][i] += accel[i]
        b[3] += 1
        while self._buckets[0][0] < t - 2.0 * self.s.window:
            self._buckets.popleft()

    def add_fix(self, g):
        """A fix g (geodetic rad/m, ENU covariances; vel_enu: the receiver's velocity or None)."""
        c = self._candidate
        if not self._standing(g, c[2] if c else g):
            self._candidate = None
            return
        if c is None:
            self._candidate = c = [g.t, g.t, g]
        c[1] = g.t
        if c[1] - c[0] >= self.s.min_duration:
            self._stretch = (max(c[0], c[1] - self.s.window), c[1])

    def estimate(self, lat):
        """Standing from the latest standing stretch, or None."""
        if not self.s.enabled or self._stretch is None:
            return None
        t0, t1 = self._stretch
        inside = [b for b in self._buckets if t0 <= b[0] and b[0] + self.BUCKET <= t1 - self.s.guard]
        if inside:
            rates, forces = ([[v / b[3] for v in b[k]] for b in inside] for k in (1, 2))
            mid_rate, mid_force = ([sorted(m[i] for m in means)[len(means) // 2] for i in range(3)]
                                   for means in (rates, forces))
            while inside and (math.dist(rates[len(inside) - 1], mid_rate) > self.s.rate_tolerance
                              or math.dist(forces[len(inside) - 1], mid_force) > self.s.accel_tolerance):
                inside.pop()
        n, duration = sum(b[3] for b in inside), len(inside) * self.BUCKET
        if duration < self.s.min_duration / 2:
            return None
        gyro = [sum(b[1][i] for b in inside) / n for i in range(3)]
        accel = [sum(b[2][i] for b in inside) / n for i in range(3)]
        norm = math.sqrt(sum(a * a for a in accel)) or 1.0
        down = [-a / norm for a in accel]                  # specific force at rest points up
        vertical, horizontal = earth.OMEGA * math.sin(lat), earth.OMEGA * math.cos(lat)
        bias = [w + vertical * d for w, d in zip(gyro, down)]   # earth rate along down: -Ω sin(lat)
        var = [self.arw ** 2 / duration + horizontal ** 2 * (1.0 - d * d) / 2 for d in down]
        return Standing(bias, var, accel, inside[-1][0] + self.BUCKET)

    def level(self, standing):
        """(roll, pitch) [rad] of the standing stretch carried by the gyros (less its bias) to the latest sample, or
        None when the samples since the stretch are no longer all kept. Carried on from the last call for the same
        stretch: only the new samples are integrated."""
        if self._carried is not None and self._carried[0] == standing:
            q, t0 = self._carried[1:]
        elif self._samples and self._samples[0][0] <= standing.t_end:
            q, t0 = tuple(quaternion.from_roll_pitch_yaw(*roll_pitch_from_accel(standing.accel))), standing.t_end
        else:
            return None
        new = []
        for t, gyro in reversed(self._samples):
            if t <= t0:
                break
            new.append((t, gyro))
        b0, b1, b2 = standing.bias
        for t, (w0, w1, w2) in reversed(new):
            q, t0 = quaternion.increment((w0 - b0) * (t - t0), (w1 - b1) * (t - t0), (w2 - b2) * (t - t0), *q), t
        self._carried = (standing, q, t0)
        (_, _, _), (_, _, _), (c6, c7, c8) = quaternion.dcm_rows(q)
        return math.atan2(c7, c8), -math.asin(max(-1.0, min(1.0, c6)))

    def _standing(self, g, first):
        if g.vel_enu is not None:
            return math.hypot(g.vel_enu[0], g.vel_enu[1]) < self.s.speed
        rm, rn = earth.radii(g.lat)
        d = math.hypot((g.lat - first.lat) * (rm + g.alt), (g.lon - first.lon) * (rn + g.alt) * math.cos(g.lat))
        return d < self.s.radius + 3.0 * math.sqrt((g.pos_cov_enu[0][0] + g.pos_cov_enu[1][1]) / 2)
