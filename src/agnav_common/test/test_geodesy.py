"""offset_geodetic (the per-fix lever move) against the tangent plane's exact to_geodetic."""
import numpy as np

from agnav_common.geodesy import LocalTangentPlane, offset_geodetic


def test_offset_geodetic_matches_the_tangent_plane():
    rng = np.random.default_rng(4)
    for _ in range(300):
        lat, lon, alt = rng.uniform(-85.0, 85.0), rng.uniform(-180.0, 180.0), rng.uniform(-100.0, 3000.0)
        offset = rng.uniform(-3.5, 3.5, 3)
        plane = LocalTangentPlane(lat, lon, alt)
        moved = offset_geodetic(lat, lon, alt, *offset)
        assert np.allclose(np.array(plane.to_enu(*moved), dtype=float), offset, rtol=0.0, atol=2e-5)


def test_a_zero_offset_is_the_point_itself():
    assert offset_geodetic(35.996, 139.6, 50.0, 0.0, 0.0, 0.0) == (35.996, 139.6, 50.0)
