"""Ground height fields and the vehicle attitude they impose (SPEC §11.10 terrain models [IMPL])."""
import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TerrainParams:
    """Sum of: random undulations (sum of sines), a cross slope ramping along an axis, and a sleeper bump.

    rough_rms_deg: r.m.s. slope of the random undulations along any direction (≈ r.m.s. roll and pitch they
    cause for wavelengths longer than the wheel base); rough_wavelength_m: (min, max) wavelengths;
    slope_deg reached at slope_ramp_m[1] along slope_axis_yaw, falling to the right of that axis;
    sleeper: raised strip ((x, y) centre, length along its yaw, width, height, yaw, end-ramp length), all m/rad.
    """

    rough_rms_deg: float = 0.0
    rough_wavelength_m: tuple = (2.0, 6.0)
    rough_components: int = 24
    slope_deg: float = 0.0
    slope_axis_yaw: float = 0.0
    slope_ramp_m: tuple = (0.0, 1.0)
    sleeper: tuple | None = None


class Terrain:
    """Height h(x, y) in metres over the map plane; smooth so that attitude rates stay finite."""

    def __init__(self, params: TerrainParams, rng: np.random.Generator):
        self.params = params
        n = params.rough_components
        lam = rng.uniform(*params.rough_wavelength_m, n)
        direction = rng.uniform(0, 2 * math.pi, n)
        k = 2 * math.pi / lam
        self._k = np.stack([k * np.cos(direction), k * np.sin(direction)], axis=1)
        self._phase = rng.uniform(0, 2 * math.pi, n)
        # component slope amplitude k·A; directional slope variance = n (kA)^2 / 4 for random directions
        self._amp = math.tan(math.radians(params.rough_rms_deg)) * math.sqrt(4.0 / n) / k

    def height(self, xy):
        """Heights (m) at points xy (..., 2)."""
        p = self.params
        xy = np.asarray(xy, dtype=float)
        h = np.sin(xy @ self._k.T + self._phase) @ self._amp
        if p.slope_deg:
            ax = np.array([math.cos(p.slope_axis_yaw), math.sin(p.slope_axis_yaw)])
            right = np.array([ax[1], -ax[0]])
            a0, a1 = p.slope_ramp_m
            frac = np.clip((xy @ ax - a0) / (a1 - a0), 0.0, 1.0)
            h = h - math.tan(math.radians(p.slope_deg)) * frac * (xy @ right)
        if p.sleeper is not None:
            (cx, cy), length, width, height, yaw, ramp = p.sleeper
            d = xy - np.array([cx, cy])
            u = d @ np.array([math.cos(yaw), math.sin(yaw)])
            w = d @ np.array([-math.sin(yaw), math.cos(yaw)])
            rise = np.clip((length / 2 - np.abs(u)) / ramp, 0.0, 1.0)
            h = h + height * 0.5 * (1 - np.cos(math.pi * rise)) * (np.abs(w) < width / 2)
        return h


def attitude_on_terrain(terrain, x, y, yaw, wheelbase, track):
    """(z, roll, pitch) of base_link (rear-axle centre) resting on the terrain, REP-103 angles.

    Tractor suspension: the rear axle is rigid (sets roll), the front axle pivots (its centre sets pitch).
    """
    c, s = math.cos(yaw), math.sin(yaw)
    fwd, left = np.array([c, s]), np.array([-s, c])
    base = np.array([x, y])
    pts = np.stack([base + left * track / 2, base - left * track / 2,
                    base + fwd * wheelbase + left * track / 2, base + fwd * wheelbase - left * track / 2])
    h_rl, h_rr, h_fl, h_fr = terrain.height(pts)
    roll = math.atan2(h_rl - h_rr, track)  # left side up = right side down = roll +
    pitch = math.atan2(0.5 * (h_rl + h_rr) - 0.5 * (h_fl + h_fr), wheelbase)  # front low = nose down = +
    return 0.5 * (h_rl + h_rr), roll, pitch
