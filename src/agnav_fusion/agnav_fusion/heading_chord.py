"""Absolute heading from the chord of the fixes before the heading is known (agnav; thesis conventions: heading
clockwise from north, pitch nose up, roll right side down).

The chord runs from the oldest fix of a window to the newest; the window drops its oldest fixes while the gyro's
relative heading over it spans more than max_turn. Each fix is kept at the antenna, so the lever arm is placed
with the chord's own heading (iterated): a lever placed with a wrong heading would bend the chord by metres. The
chord's direction is the mean course, the course at the newest fix is it plus half the gyro turn. The vehicle is
taken to drive forward (a reversing start gives a reversed heading; the estimator catches it by a negative speed).
"""
import math
from collections import deque

import numpy as np

from agnav_fusion.tilt_correction import antenna_offset


class HeadingChord:
    def __init__(self, max_turn, min_length, max_sigma, size=1200):
        self.max_turn, self.min_length, self.max_sigma = max_turn, min_length, max_sigma
        self.lever = np.zeros(3)  # (right, forward, up) m, antenna lever arm (set by add)
        self.fixes = deque(maxlen=size)  # (t, antenna xy, raw heading, pitch, roll, white variance per axis)

    def clear(self):
        self.fixes.clear()

    def _base(self, fix, raw_to_true):
        t, ant, raw, pitch, roll, _ = fix
        return ant - antenna_offset(self.lever, raw + raw_to_true, pitch, roll)[:2]

    def add(self, lever, t, antenna_xy, raw_heading, pitch, roll, white_var):
        """Add a fix (lever: the antenna's lever arm); -> (course at this fix rad, its variance, base_link xy, mean speed m/s) once the chord is at
        least min_length long and its course known within max_sigma, else None."""
        fixes, self.lever = self.fixes, lever
        fixes.append((t, np.asarray(antenna_xy, float), raw_heading, pitch, roll, white_var))
        raws = [f[2] for f in fixes]
        while max(raws) - min(raws) > self.max_turn:
            fixes.popleft()
            raws.pop(0)
        first, last = fixes[0], fixes[-1]
        turn = last[2] - first[2]
        d = last[1] - first[1]
        course = math.atan2(d[0], d[1]) + 0.5 * turn
        for _ in range(3):  # lever placed with the chord's heading at each end
            d = self._base(last, course - last[2]) - self._base(first, course - last[2])
            course = math.atan2(d[0], d[1]) + 0.5 * turn
        length = float(np.hypot(*d))
        if length < self.min_length:
            return None
        var = (first[5] + last[5]) / length ** 2 + (turn / 4) ** 2
        if var > self.max_sigma ** 2:
            return None
        return (math.remainder(course, 2 * math.pi), var, self._base(last, course - last[2]),
                length / max(last[0] - first[0], 1e-3))
