"""INS solution history for GNSS latency compensation (SPEC §7.6): fixes are applied against the INS at their epoch."""
from collections import deque

import numpy as np

from .measurements import Snapshot
from .mechanization import T, c_cbar_ned


def snapshot(raw):
    """Snapshot of a stored (t, lat, lon, h, alpha, v^C, C_B^Cbar, omega_b) entry: the NED velocity and attitude
    are formed only for the entries a fix is interpolated between (the history takes one per IMU sample)."""
    t, lat, lon, h, alpha, v_c, c_bc, omega_b = raw
    cn = c_cbar_ned(alpha)
    return Snapshot(t, lat, lon, h, cn @ (T @ v_c), cn @ np.asarray(c_bc), omega_b)


class SolutionHistory:
    """Entries of the last `window` s, each with the corrections accumulated when it was taken."""

    def __init__(self, window):
        self.window = window
        self._items = deque()

    def clear(self):
        self._items.clear()

    @property
    def oldest(self):
        return self._items[0][0][0]

    def append(self, raw, corr):
        """raw: (t, lat, lon, h, alpha, v^C, C_B^Cbar, omega_b), none of them changed afterwards; corr: the
        accumulated corrections, an array the caller replaces rather than modifies."""
        items, t_min = self._items, raw[0] - self.window
        items.append((raw, corr))
        while items and items[0][0][0] < t_min:
            items.popleft()

    def at(self, t, corr):
        """INS solution interpolated at epoch t, shifted by the corrections applied since (corr: the current total)."""
        hist = self._items
        i = len(hist) - 1
        while i > 0 and hist[i - 1][0][0] >= t:
            i -= 1
        (b, cb) = hist[i]
        (a, ca) = hist[i - 1] if i > 0 else hist[i]
        a, b = snapshot(a), snapshot(b)
        w = 0.0 if b.t == a.t else min(max((t - a.t) / (b.t - a.t), 0.0), 1.0)
        d = corr - (ca + w * (cb - ca))
        pos = (1 - w) * np.array([a.lat, a.lon, a.h]) + w * np.array([b.lat, b.lon, b.h]) + d[:3]
        v = (1 - w) * a.v_ned + w * b.v_ned + d[3:]
        near = b if w >= 0.5 else a
        return Snapshot(t, pos[0], pos[1], pos[2], v, near.c_b_ned, near.omega_b)


class ImuPeriod:
    """Nominal IMU period: running mean of the regular intervals (gaps excluded); dt None before one interval."""

    def __init__(self):
        self.dt = None

    def update(self, dt):
        """Take an interval (None: no previous sample); returns the nominal period."""
        if dt is not None:
            if self.dt is None:
                self.dt = dt
            elif dt <= 1.5 * self.dt:
                self.dt += 0.05 * (dt - self.dt)
        return self.dt
