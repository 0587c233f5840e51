"""WGS-84 helpers for raw GNSS: geodetic <-> ECEF (cssrlib), local east/north/up axes, elevation and azimuth."""
import numpy as np
from cssrlib.gnss import ecef2pos, pos2ecef


def llh_to_ecef(lat_deg, lon_deg, h):
    return np.asarray(pos2ecef(np.array([lat_deg, lon_deg, h], float), isdeg=True), float)


def ecef_to_llh(xyz):
    """(lat rad, lon rad, h m)."""
    return np.asarray(ecef2pos(np.asarray(xyz, float)), float)


def enu_basis(xyz):
    """Unit vectors (east, north, up) in ECEF at `xyz` (geodetic up)."""
    lat, lon, _ = ecef_to_llh(xyz)
    sl, cl, sp, cp = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    return np.array([-sp, cp, 0.0]), np.array([-sl * cp, -sl * sp, cl]), np.array([cl * cp, cl * sp, sl])


def to_enu(vec, xyz):
    """ECEF vector(s) `vec` in east/north/up at `xyz`."""
    return np.asarray(vec, float) @ np.array(enu_basis(xyz)).T


def elevation_azimuth(rx_pos, sat_pos):
    """(elevation, azimuth) [rad] of the rows of `sat_pos` seen from `rx_pos` (ECEF m)."""
    east, north, up = enu_basis(rx_pos)
    los = np.atleast_2d(sat_pos) - rx_pos
    los = los / np.linalg.norm(los, axis=1, keepdims=True)
    return np.arcsin(np.clip(los @ up, -1, 1)), np.arctan2(los @ east, los @ north)
