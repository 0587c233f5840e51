"""Variance-weighted average of GDS and gyro headings with variable target heading (SPEC §3.6, eq 2.32–2.52).

Headings in rad, clockwise from north; callers pass continuous (unwrapped) headings.
"""
from collections import deque
from dataclasses import dataclass

import numpy as np


def vwa(x1: float, var1: float, x2: float, var2: float) -> tuple[float, float]:
    """Optimal combination of two unbiased uncorrelated estimates (2.32)–(2.36): (x_est, σ²_est)."""
    total = var1 + var2
    if total <= 0.0:
        return 0.5 * (x1 + x2), 0.0
    return (var2 * x1 + var1 * x2) / total, var1 * var2 / total


@dataclass(frozen=True)
class WindowStats:
    """Means and 1/T variances (2.45)–(2.46) of the two headings over one window."""

    mean_gds: float
    mean_gyro: float
    var_gds: float
    var_gyro: float

    @property
    def gyro_weight(self) -> float:
        """Weight of the gyro in (2.37)/(2.52): σ²_GDS / (σ²_GDS + σ²_gyro)."""
        return self.var_gds / (self.var_gds + self.var_gyro) if self.var_gds + self.var_gyro > 0 else 0.5

    @staticmethod
    def of(gds: np.ndarray, gyro: np.ndarray) -> "WindowStats":
        """Statistics of paired samples (population variance, 1/T as in (2.45))."""
        gds, gyro = np.asarray(gds, float), np.asarray(gyro, float)
        return WindowStats(float(gds.mean()), float(gyro.mean()), float(gds.var()), float(gyro.var()))

    def heading(self, gds: float, gyro: float) -> tuple[float, float]:
        """Absolute VWA (2.37) with η = φ̄_gyro − φ̄_GDS (3.22): (φ_est, σ²_est)."""
        return vwa(gds, self.var_gds, gyro - (self.mean_gyro - self.mean_gds), self.var_gyro)

    def deviation(self, gds: float, gyro: float) -> float:
        """Implementable heading deviation from the window target (2.52)."""
        return vwa(gds - self.mean_gds, self.var_gds, gyro - self.mean_gyro, self.var_gyro)[0]


@dataclass
class VwaSettings:
    """Table 2.5: window T and target update interval ΔT (s)."""

    window: float = 10.0     # T
    interval: float = 2.0    # ΔT


class VariableTargetVwa:
    """Every ΔT the target and weights are recomputed on (kΔT − T, kΔT] (Fig. 2.19); between updates (2.52)."""

    def __init__(self, settings: VwaSettings | None = None):
        self.s = settings or VwaSettings()
        self._buf: deque = deque()       # (t, gds, gyro)
        self._next_update: float | None = None
        self.stats: WindowStats | None = None
        self.last_update: float | None = None   # kΔT of the current statistics

    def update(self, t: float, heading_gds: float, heading_gyro: float, gds_variance_scale: float = 1.0):
        """Add a sample; returns (Δφ_est (2.52), φ_est (2.37), σ²_est) or None before the first window.

        gds_variance_scale inflates σ²_GDS (magnetic disturbance de-weighting).
        """
        self._buf.append((t, heading_gds, heading_gyro))
        while self._buf[0][0] <= t - self.s.window:
            self._buf.popleft()
        if self._next_update is None:
            self._next_update = t + self.s.window
        if t >= self._next_update:
            _, g, y = zip(*self._buf)
            w = WindowStats.of(g, y)
            self.stats = WindowStats(w.mean_gds, w.mean_gyro, w.var_gds * gds_variance_scale, w.var_gyro)
            self.last_update = t
            while self._next_update <= t:
                self._next_update += self.s.interval
        if self.stats is None:
            return None
        est, var = self.stats.heading(heading_gds, heading_gyro)
        return self.stats.deviation(heading_gds, heading_gyro), est, var

    @property
    def target(self) -> float | None:
        """Current target heading: the VWA of the window means (2.44) with the unknown η, δ̄_GDS dropped."""
        return None if self.stats is None else self.stats.mean_gds
