"""Local ENU tangent plane of the `map` frame at a geodetic datum (WGS-84, pymap3d)."""
from dataclasses import dataclass

import numpy as np
import pymap3d


@dataclass(frozen=True)
class LocalTangentPlane:
    """ENU plane at (lat_deg, lon_deg, alt_m): the REP-105 `map` frame."""

    lat_deg: float
    lon_deg: float
    alt_m: float

    def to_enu(self, lat_deg, lon_deg, alt_m):
        """Geodetic (deg, deg, m ellipsoidal) -> (east, north, up) m; scalars or arrays."""
        e, n, u = pymap3d.geodetic2enu(lat_deg, lon_deg, alt_m, self.lat_deg, self.lon_deg, self.alt_m)
        return np.asarray(e), np.asarray(n), np.asarray(u)

    def to_geodetic(self, east, north, up):
        """(east, north, up) m -> geodetic (deg, deg, m ellipsoidal)."""
        lat, lon, alt = pymap3d.enu2geodetic(east, north, up, self.lat_deg, self.lon_deg, self.alt_m)
        return np.asarray(lat), np.asarray(lon), np.asarray(alt)
