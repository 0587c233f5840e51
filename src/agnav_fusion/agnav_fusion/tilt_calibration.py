"""Two-way zero calibration of the tilt sensors (the autosteer set-up step "park, turn round, park again").

Parked facing one way a tilt sensor reads ground + zero, parked on the same spot facing the other way it reads
-ground + zero (roll and pitch both change sign when the vehicle turns 180° on a plane), so
zero = (A + B) / 2 and the ground slope (A - B) / 2 cancels. The zero covers the sensor's zero offset and its
mounting misalignment; the scale error is not observable this way.
"""
import math
from dataclasses import dataclass

import numpy as np


@dataclass
class TiltCalibrationSettings:
    still_speed: float = 0.15              # m/s: slower GNSS speeds mean parked (DGPS velocity noise ≈ 0.05)
    settle: float = 5.0                    # s of readings dropped after stopping (inclinometer lag: D5R τ 1.05 s)
    min_parked: float = 10.0               # s of settled readings needed per parking
    reversal_tolerance_deg: float = 20.0   # two parkings are reversed when 180° ± this apart


@dataclass
class Parking:
    start: float          # s, first settled reading
    end: float            # s
    heading: float        # rad, gyro-integrated, relative to the first parking
    roll: float           # rad, mean reading
    pitch: float          # rad, mean reading
    roll_std: float       # rad, standard deviation of the readings
    pitch_std: float      # rad


@dataclass
class TiltCalibrationResult:
    roll_zero: float      # rad, subtract from the roll readings
    pitch_zero: float     # rad, subtract from the pitch readings
    ground_roll: float    # rad, ground slope under the first parking
    ground_pitch: float   # rad
    turn: float           # rad, heading change between the two parkings used
    first: Parking
    second: Parking


def _runs(mask):
    """(start, stop) index pairs of the True runs of a boolean array."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return list(zip(edges[::2], edges[1::2]))


class TiltCalibration:
    """Collect speed, yaw rate and tilt readings of a calibration drive, then solve()."""

    def __init__(self, settings=None):
        self.settings = settings or TiltCalibrationSettings()
        self._speed, self._yaw_rate, self._tilt = [], [], []

    def speed(self, t, speed):
        """Ground speed (m/s), e.g. the GNSS velocity's horizontal norm."""
        self._speed.append((t, speed))

    def yaw_rate(self, t, rate):
        """Body yaw rate (rad/s, REP-103) at the IMU rate."""
        self._yaw_rate.append((t, rate))

    def tilt(self, t, roll, pitch):
        """Raw tilt reading (rad, REP-103): inclinometer, or accelerometer-derived."""
        self._tilt.append((t, roll, pitch))

    def parkings(self):
        """Settled standstills long enough to average, with their gyro-integrated relative headings."""
        s = self.settings
        if not self._speed or not self._yaw_rate or not self._tilt:
            raise ValueError("calibration needs GNSS speed, IMU yaw rate and tilt readings; one is missing")
        v = np.array(sorted(self._speed))
        spans = [(v[i, 0] + s.settle, v[j - 1, 0]) for i, j in _runs(v[:, 1] < s.still_speed)]
        spans = [(a, b) for a, b in spans if b - a >= s.min_parked]
        if not spans:
            raise ValueError(f"no standstill of {s.settle + s.min_parked:g} s or more (GNSS speed < "
                             f"{s.still_speed} m/s): park for longer")
        w = np.array(sorted(self._yaw_rate))
        first = (w[:, 0] >= spans[0][0]) & (w[:, 0] <= spans[0][1])
        bias = w[first, 1].mean() if first.any() else 0.0   # the gyro offset, measured while parked
        heading = np.concatenate([[0.0], np.cumsum((w[1:, 1] - bias) * np.diff(w[:, 0]))])
        tilt = np.array(sorted(self._tilt))
        out = []
        for a, b in spans:
            inside = (tilt[:, 0] >= a) & (tilt[:, 0] <= b)
            here = (w[:, 0] >= a) & (w[:, 0] <= b)
            if inside.sum() < 2 or not here.any():
                continue
            r, p = tilt[inside, 1], tilt[inside, 2]
            out.append(Parking(a, b, float(heading[here].mean()), float(r.mean()), float(p.mean()),
                               float(r.std()), float(p.std())))
        if not out:
            raise ValueError("no tilt readings or IMU samples while parked")
        h0 = out[0].heading
        for park in out:
            park.heading -= h0
        return out

    def solve(self):
        """Zeros from the first parking and the last one turned 180° from it; ValueError says what is missing."""
        parks = self.parkings()
        tol = math.radians(self.settings.reversal_tolerance_deg)
        first = parks[0]
        turned = [p for p in parks[1:] if abs(abs(math.remainder(p.heading - first.heading, 2 * math.pi)) - math.pi)
                  <= tol]
        if not turned:
            found = ", ".join(f"{math.degrees(p.heading):.0f}°" for p in parks)
            raise ValueError(f"no parking turned 180° ± {self.settings.reversal_tolerance_deg:g}° from the first "
                             f"(relative headings of the parkings: {found}): turn round and park on the same spot")
        second = turned[-1]
        return TiltCalibrationResult(
            roll_zero=(first.roll + second.roll) / 2, pitch_zero=(first.pitch + second.pitch) / 2,
            ground_roll=(first.roll - second.roll) / 2, ground_pitch=(first.pitch - second.pitch) / 2,
            turn=second.heading - first.heading, first=first, second=second)
