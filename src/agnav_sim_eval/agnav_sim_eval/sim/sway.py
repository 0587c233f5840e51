"""Tyre/suspension sway: band-limited random roll and pitch on top of the terrain attitude [IMPL].

Each axis is a sum of sines with random frequencies in band_hz (a near-Gaussian process of the given r.m.s.),
soft-limited to ±peak_deg by tanh and faded in with the speed (no sway at standstill). The vehicle body rotates
about base_link (on the ground), so a sensor mounted h above it also feels the lateral/longitudinal acceleration
h·θ̈ of the sway: what makes a pendulous inclinometer read several degrees wrong on a rough road (Table 5.4).
"""
import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SwayParams:
    """r.m.s. roll and pitch (deg) in band_hz (pitch in pitch_band_hz when given), soft peak limit (deg), speed (m/s)
    from which the sway is full."""

    roll_rms_deg: float = 0.0
    pitch_rms_deg: float = 0.0
    band_hz: tuple = (0.3, 2.0)
    pitch_band_hz: tuple | None = None
    peak_deg: float = 6.0
    full_speed_mps: float = 0.5
    components: int = 24


class Sway:
    """(roll, pitch) sway in rad at time t for the current speed."""

    def __init__(self, params: SwayParams, rng: np.random.Generator):
        self.params = params
        n = params.components
        lo, hi = zip(params.band_hz, params.pitch_band_hz or params.band_hz)
        self._w = 2 * math.pi * rng.uniform(np.array(lo)[:, None], np.array(hi)[:, None], (2, n))
        self._phase = rng.uniform(0, 2 * math.pi, (2, n))
        rms = np.radians([params.roll_rms_deg, params.pitch_rms_deg])
        self._amp = rms[:, None] * math.sqrt(2.0 / n) * np.ones((2, n))

    def angles(self, t, speed):
        """Sway (roll, pitch) rad at time t (s) and ground speed (m/s)."""
        p = self.params
        raw = np.sum(self._amp * np.sin(self._w * t + self._phase), axis=1)
        peak = math.radians(p.peak_deg)
        gain = min(1.0, speed / p.full_speed_mps) if p.full_speed_mps > 0 else 1.0
        return gain * peak * np.tanh(raw / peak)
