"""Site geomagnetic field (WMM via pygeomag) plus a spatially correlated disturbance (SPEC §11.1 environment)."""
import math
from dataclasses import dataclass

import numpy as np
from pygeomag import GeoMag

NT = 1e-9


def earth_field_enu(lat_deg, lon_deg, alt_m, year=2025.0):
    """Earth field (east, north, up) in tesla and (declination, inclination) in degrees from the WMM."""
    r = GeoMag().calculate(glat=lat_deg, glon=lon_deg, alt=alt_m / 1000.0, time=year,
                           allow_date_outside_lifespan=True)
    return np.array([r.y, r.x, -r.z]) * NT, r.d, r.i


@dataclass(frozen=True)
class DisturbanceParams:
    """Random-Fourier 2-D field: horizontal rms ≈ H·tan(base_deg), growing to peak_deg between ramp distances
    along ramp_yaw (e.g. concrete at the end of a field), correlation length ≈ wavelength_m/2π.
    passing: ((t_centre s, duration s, magnitude mG), ...) transient disturbances of a random fixed direction
    (another vehicle or a steel structure passing by), raised-cosine in time."""

    base_deg: float = 0.3
    peak_deg: float = 0.3
    ramp_yaw: float = math.pi / 2
    ramp_m: tuple = (0.0, 1.0)
    wavelength_m: tuple = (20.0, 80.0)
    components: int = 16
    passing: tuple = ()


class MagneticEnvironment:
    """B(x, y) = B_earth + B_dist(x, y) in map ENU (tesla)."""

    def __init__(self, datum, params: DisturbanceParams, rng: np.random.Generator, year=2025.0):
        self.b_earth, self.declination_deg, self.inclination_deg = earth_field_enu(*datum, year=year)
        self.params = params
        n = params.components
        lam = rng.uniform(*params.wavelength_m, n)
        ang = rng.uniform(0, 2 * math.pi, n)
        self._k = np.stack([np.cos(ang), np.sin(ang)], axis=1) * (2 * math.pi / lam)[:, None]
        self._phase = rng.uniform(0, 2 * math.pi, n)
        direction = rng.standard_normal((n, 3))
        # unit per-axis rms: a horizontal component of rms H·tan(g) turns the field by ≈ g rms
        self._vec = direction * math.hypot(self.b_earth[0], self.b_earth[1]) * math.sqrt(2.0 / n)
        self._axis = np.array([math.cos(params.ramp_yaw), math.sin(params.ramp_yaw)])
        if params.passing:
            d = rng.standard_normal((len(params.passing), 3))
            self._passing_dir = d / np.linalg.norm(d, axis=1, keepdims=True)

    def gain_deg(self, x, y):
        """Disturbance size (deg of horizontal field direction) at (x, y)."""
        p = self.params
        frac = np.clip((np.dot(self._axis, (x, y)) - p.ramp_m[0]) / (p.ramp_m[1] - p.ramp_m[0]), 0.0, 1.0)
        return p.base_deg + (p.peak_deg - p.base_deg) * frac

    def passing_field(self, t):
        """Sum of the passing disturbances (tesla, ENU) at time t (s)."""
        b = np.zeros(3)
        for (tc, dur, mg), u in zip(self.params.passing, getattr(self, "_passing_dir", ())):
            if abs(t - tc) < dur / 2:
                b += mg * 1e-7 * 0.5 * (1 + math.cos(2 * math.pi * (t - tc) / dur)) * u
        return b

    def field(self, x, y, t=None):
        """Field (tesla, ENU) at map position (x, y) and time t (s; None: without the passing disturbances)."""
        s = np.sin(self._k @ (x, y) + self._phase)
        b = self.b_earth + math.tan(math.radians(self.gain_deg(x, y))) * (s @ self._vec)
        return b if t is None or not self.params.passing else b + self.passing_field(t)
