"""World Magnetic Model at the current fix (pygeomag) and magnetic-disturbance check (SPEC §2.3, §3.1–3.2)."""
import datetime as dt
import math
from dataclasses import dataclass

from pygeomag import GeoMag, decimal_year_from_date

NT = 1e-9  # WMM works in nanotesla


@dataclass(frozen=True)
class ExpectedField:
    """WMM field at a place and date: declination D (east +) and inclination I (down +) in rad, intensities in T."""

    declination: float
    inclination: float
    total: float
    horizontal: float
    decimal_year: float
    extrapolated: bool   # the stamp's date was outside every model's span: the fallback date was used


class MagneticModel:
    """Declination/inclination/intensity from WMM (pygeomag); cached per ~1 km cell and day."""

    def __init__(self, coefficients_file: str | None = None, fallback_year: float | None = None,
                 first_year: float = 2010.0, last_year: float = 2029.99):
        """fallback_year replaces dates outside the models' span (e.g. simulation stamps from 0); None = today."""
        self._file = coefficients_file
        self._fallback = fallback_year
        self._span = (first_year, last_year)
        self._models: dict = {}
        self._cache: dict = {}

    def _geomag(self, year: float) -> GeoMag:
        key = self._file or int(year // 5 * 5)
        if key not in self._models:
            self._models[key] = GeoMag(coefficients_file=self._file) if self._file else GeoMag(base_year=year)
        return self._models[key]

    def at(self, lat_deg: float, lon_deg: float, alt_m: float, unix_time: float) -> ExpectedField:
        """WMM field at (lat, lon, ellipsoidal alt) and a UNIX time (s)."""
        date = dt.datetime.fromtimestamp(unix_time, dt.timezone.utc)
        return self.at_year(lat_deg, lon_deg, alt_m, decimal_year_from_date(date))

    def at_year(self, lat_deg: float, lon_deg: float, alt_m: float, year: float) -> ExpectedField:
        """WMM field at a decimal year; dates outside the models' span use the fallback date and are flagged."""
        clamped = year
        if not self._span[0] <= year <= self._span[1]:
            fallback = self._fallback or decimal_year_from_date(dt.datetime.now(dt.timezone.utc))
            clamped = min(max(fallback, self._span[0]), self._span[1])
        key = (round(lat_deg, 2), round(lon_deg, 2), round(alt_m, -3), round(clamped, 2))
        if key not in self._cache:
            r = self._geomag(clamped).calculate(glat=lat_deg, glon=lon_deg, alt=alt_m / 1000.0, time=clamped,
                                                allow_date_outside_lifespan=True)
            self._cache[key] = ExpectedField(math.radians(r.d), math.radians(r.i), r.f * NT, r.h * NT,
                                             clamped, clamped != year)
        return self._cache[key]


@dataclass
class DisturbanceSettings:
    """Tolerances of the measured field against the WMM value (SPEC §3.2 error class 3)."""

    intensity_tolerance: float = 0.10            # relative |F| error
    inclination_tolerance: float = math.radians(5.0)


def disturbance(total_t: float, incl_rad: float | None, expected: ExpectedField, s: DisturbanceSettings):
    """(disturbed, relative intensity error, inclination error rad) of a levelled field sample; incl_rad None
    (attitude unknown: |F| alone, rotation invariant) gives a NaN inclination error that flags nothing."""
    d_f = total_t / expected.total - 1.0
    d_i = math.nan if incl_rad is None else incl_rad - expected.inclination
    bad = not math.isfinite(d_f) or abs(d_f) > s.intensity_tolerance or abs(d_i) > s.inclination_tolerance
    return bad, d_f, d_i
