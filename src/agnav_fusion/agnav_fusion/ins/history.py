"""INS solution history for GNSS latency compensation (SPEC §7.6): fixes are applied against the INS at their epoch."""
from collections import deque

import numpy as np

from .measurements import Snapshot


class SolutionHistory:
    """Snapshots of the last `window` s, each with the corrections accumulated when it was taken."""

    def __init__(self, window):
        self.window = window
        self._items = deque()

    def clear(self):
        self._items.clear()

    @property
    def oldest(self):
        return self._items[0][0].t

    def append(self, snap, corr):
        self._items.append((snap, corr.copy()))
        while self._items and self._items[0][0].t < snap.t - self.window:
            self._items.popleft()

    def at(self, t, corr):
        """INS solution interpolated at epoch t, shifted by the corrections applied since (corr: the current total)."""
        hist = self._items
        i = len(hist) - 1
        while i > 0 and hist[i - 1][0].t >= t:
            i -= 1
        (b, cb) = hist[i]
        (a, ca) = hist[i - 1] if i > 0 else hist[i]
        w = 0.0 if b.t == a.t else min(max((t - a.t) / (b.t - a.t), 0.0), 1.0)
        d = corr - (ca + w * (cb - ca))
        pos = (1 - w) * np.array([a.lat, a.lon, a.h]) + w * np.array([b.lat, b.lon, b.h]) + d[:3]
        v = (1 - w) * a.v_ned + w * b.v_ned + d[3:]
        near = b if w >= 0.5 else a
        return Snapshot(t, pos[0], pos[1], pos[2], v, near.c_b_ned, near.omega_b)
