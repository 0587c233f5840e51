"""The receiver's slow error as three augmented states (em.GNSS_BIAS: east, north, up [m], Gauss-Markov).

A fix's error is mostly slow (DGPS wander, RTK float, multipath: tens of seconds) with a small fix-to-fix part. Fused
as white noise at 5-10 Hz the slow part is averaged down as if it were independent, so the filter grows sure of a
position, a heading and a speed that the receiver's drift is still carrying (an alignment during RTK float was 4 deg
off at a 1.2 deg sigma). Here a fix's covariance splits into the bias variances (`fraction` of the horizontal one per
horizontal axis, of the vertical one upward) and a white part (the rest); the fix is corrected by the bias estimate and the position rows read the bias error as well.
A change of receiver class (the bias variance outside a quarter .. 4x the previous one) restarts the bias at zero.
"""
import math
from dataclasses import dataclass, replace

import numpy as np

from . import earth, error_model as em

B = em.GNSS_BIAS.start


@dataclass
class GnssBiasSettings:
    tau: float = 40.0           # s, correlation time of the receiver's slow error; 0: fixes are white (no bias)
    fraction: float = 0.5       # part of a fix's variance that is slow (corrections, multipath)


class GnssBias:
    """Bias estimate (ENU [m]) of the states em.GNSS_BIAS and the fix-class bookkeeping."""

    def __init__(self, settings):
        self.s = settings
        self.b = np.zeros(3)
        self.var = np.zeros(3)  # m^2 per axis: the stationary variances of the current receiver class
        self._t = None
        self.fix_var_h = 0.0    # horizontal variance per axis of the previous fix [m^2]

    @property
    def enabled(self):
        return self.s.tau > 0.0

    def initial_var(self, g):
        return self._split(g.pos_cov_enu)[1] if self.enabled else np.zeros(3)

    def _split(self, cov):
        cov = np.asarray(cov, dtype=float)
        h = float(np.trace(cov[:2, :2])) / 2
        var = self.s.fraction * np.array((h, h, cov[2, 2]))
        return cov - np.diag(var), var

    def reset(self, var):
        self.b, self.var, self._t = np.zeros(3), np.asarray(var, dtype=float), None

    def fix(self, g, p, snap):
        """The fix corrected by the bias (white covariance) and P (in place where it grows) with a restarted bias on
        a class change; snap: the INS solution at the fix epoch."""
        var_h = float(np.trace(g.pos_cov_enu[:2, :2])) / 2
        if var_h < self.fix_var_h / 4:      # better receiver class (float -> fixed): the position still carries the
            r2 = (earth.mean_radius(snap.lat) + snap.h) ** 2        # old fixes' slowly drifting error
            p[[em.RX, em.RY], [em.RX, em.RY]] += self.fix_var_h / r2
            p[em.H, em.H] += self.fix_var_h
        self.fix_var_h = var_h
        if not self.enabled:
            return g, p
        white, var = self._split(g.pos_cov_enu)
        if self._t is not None:
            self.b = self.b * math.exp(-max(g.t - self._t, 0.0) / self.s.tau)
        self._t = g.t
        if not 0.25 * self.var[0] <= var[0] <= 4.0 * self.var[0]:
            self.b = np.zeros(3)
            p = p.copy()
            p[em.GNSS_BIAS, :] = p[:, em.GNSS_BIAS] = 0.0
            p[em.GNSS_BIAS, em.GNSS_BIAS] = np.diag(var)
        self.var = var
        rm, rn = earth.radii(g.lat)
        lat = g.lat - self.b[1] / (rm + g.alt)
        lon = g.lon - self.b[0] / ((rn + g.alt) * math.cos(g.lat))
        return replace(g, lat=lat, lon=lon, alt=g.alt - self.b[2], pos_cov_enu=white), p

    def add_columns(self, lin, snap, alpha):
        """The position rows' columns of the bias error (true - estimate): it moves the corrected fix."""
        if not self.enabled:
            return
        rm, rn = earth.radii(snap.lat)
        ca, sa = math.cos(alpha), math.sin(alpha)
        e, n = 1.0 / (rn + snap.h), 1.0 / (rm + snap.h)
        lin.h[0, B], lin.h[0, B + 1] = -ca * e, -sa * n
        lin.h[1, B], lin.h[1, B + 1] = sa * e, -ca * n
        lin.h[2, B + 2] = -1.0

    def propagate(self, phi, q, dt):
        """Gauss-Markov rows of Φ and Q (stationary at the class variance)."""
        f = math.exp(-dt / self.s.tau) if self.enabled else 1.0
        for i in range(3):
            phi[B + i, B + i] = f
        q[em.GNSS_BIAS] = self.var * (1.0 - f * f)

    def feedback(self, x):
        self.b = self.b + x[em.GNSS_BIAS]
