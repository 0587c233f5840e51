"""Dead reckoning between GNSS fixes (SPEC §6.3, eq 5.12-5.13), thesis conventions (X east, Y north,
heading clockwise from north, radians), with a first-order covariance for the horizontal position."""
import math
from dataclasses import dataclass

import numpy as np


@dataclass
class DeadReckoningSettings:
    speed_sigma: float = 0.05     # m/s, 1-sigma error of the travel speed V [IMPL]
    heading_sigma: float = 0.011  # rad, 1-sigma heading error (~0.63 deg, Table 5.4 module) [IMPL]


class DeadReckoning:
    """X(k) = X_latest + sum sin(phi) V dt (5.12), Y(k) = Y_latest + sum cos(phi) V dt (5.13)."""

    def __init__(self, settings=None):
        self.settings = settings or DeadReckoningSettings()
        self.xy = None     # [X, Y] floats, None before the first fix
        self._cov0 = None  # the fix's 2x2 covariance as floats (row by row)
        self._time = 0.0
        self._distance = 0.0

    def reset(self, xy, cov):
        """Restart from the latest tilt-corrected fix (X_latest, Y_latest) with its 2x2 covariance."""
        self.xy = [float(xy[0]), float(xy[1])]
        self._cov0 = np.asarray(cov, dtype=float).ravel().tolist()
        self._time = self._distance = 0.0

    def step(self, heading, speed, dt):
        """Advance one attitude-package sample (5.12)-(5.13); returns new arrays (xy, 2x2 cov)."""
        s, c = math.sin(heading), math.cos(heading)
        xy = self.xy
        xy[0] += s * speed * dt
        xy[1] += c * speed * dt
        self._time += dt
        self._distance += abs(speed) * dt
        # speed and heading errors are slow (bias-like): error grows with time / distance since the fix; the
        # along-track (s, c) and cross-track (c, -s) variances rotated into (X, Y)
        va = (self.settings.speed_sigma * self._time) ** 2
        vc = (self.settings.heading_sigma * self._distance) ** 2
        sc = (va - vc) * s * c
        c00, c01, c10, c11 = self._cov0
        return np.array(xy), np.array([[c00 + (va * s * s + vc * c * c), c01 + sc],
                                       [c10 + sc, c11 + (va * c * c + vc * s * s)]])
