"""GDS heading (SPEC §3.1–3.2): calibration, tilt compensation, WMM declination, disturbance."""
import math

import numpy as np
import pytest

from agnav_common.frames import rotation_matrix
from agnav_fusion.gds_heading import (CircleCalibration, fit_circle, fit_ellipse, inclination, magnetic_heading,
                                      tilt_compensate)
from agnav_fusion.geomagnetic_model import DisturbanceSettings, MagneticModel, disturbance

H, DIP = 30e-6, math.radians(55.0)


def _thesis_field(heading, roll, pitch):
    """Field seen by a thesis-frame (right, forward, up) sensor at a pose, built with the REP-103 matrices."""
    b_enu = np.array([0.0, H, -H * math.tan(DIP)])            # magnetic north, field pointing down
    flu = rotation_matrix(roll, -pitch, math.pi / 2 - heading).T @ b_enu
    return np.array([-flu[1], flu[0], flu[2]])


@pytest.mark.parametrize("heading,roll,pitch", [(0.3, 0.1, -0.05), (-2.5, -0.2, 0.15), (1.7, 0.0, 0.25)])
def test_tilt_compensation_of_a_known_pose(heading, roll, pitch):
    b = _thesis_field(heading, roll, pitch)
    level = tilt_compensate(b, roll, pitch)
    assert magnetic_heading(level) == pytest.approx(heading, abs=1e-9)
    assert inclination(level) == pytest.approx(DIP, abs=1e-9)
    # without compensation the tilt leaks the vertical field into the heading
    assert abs(magnetic_heading(b) - heading) > 0.02


def test_heading_is_clockwise_from_north():
    assert magnetic_heading(_thesis_field(math.pi / 2, 0, 0)) == pytest.approx(math.pi / 2)  # facing east


def _turn(center, soft, n=400, seed=1, noise=0.05e-6):
    rng = np.random.default_rng(seed)
    phi = np.linspace(-math.pi, math.pi, n, endpoint=False)
    true = np.column_stack([-H * np.sin(phi), H * np.cos(phi)])
    raw = true @ np.linalg.inv(soft).T + center + rng.normal(0, noise, true.shape)
    return phi, true, raw


def test_hard_iron_circle_fit_recovers_offset():
    center = np.array([4e-6, -2.5e-6])
    _, _, raw = _turn(center, np.eye(2))
    cal = fit_circle(raw[:, 0], raw[:, 1])
    np.testing.assert_allclose(cal.center, center, atol=0.02e-6)
    assert cal.radius == pytest.approx(H, rel=1e-3)


def test_soft_iron_ellipse_fit_recovers_parameters_and_heading():
    center = np.array([-3e-6, 5e-6])
    soft = np.array([[1.15, 0.08], [0.08, 0.9]])                  # symmetric distortion to undo
    soft /= math.sqrt(np.linalg.det(soft))                        # area preserving: radius stays H
    phi, _, raw = _turn(center, soft)
    cal = fit_ellipse(raw[:, 0], raw[:, 1])
    np.testing.assert_allclose(cal.center, center, atol=0.03e-6)
    np.testing.assert_allclose(cal.soft_iron, soft, atol=5e-3)
    raw3 = np.column_stack([raw, np.zeros(len(raw))])
    err = _rms_heading_error(cal.apply(raw3), phi)
    assert math.degrees(err) < 0.3
    hard_only = CircleCalibration(center=fit_circle(raw[:, 0], raw[:, 1]).center)
    assert _rms_heading_error(hard_only.apply(raw3), phi) > 3 * err


def _rms_heading_error(b, phi):
    e = np.angle(np.exp(1j * (magnetic_heading(b) - phi)))
    return float(np.sqrt(np.mean(e**2)))


def test_wmm_declination_matches_noaa_reference_values():
    # NOAA WMM2020 test values (WMM2020testvalues.pdf): (year, lat, lon) -> D [deg] at 0 km
    model = MagneticModel("wmm/WMM_2020.COF")
    for year, lat, lon, d_ref in [(2020.0, 80, 0, -1.28), (2022.5, -80, 240, 69.13), (2022.5, 0, 120, -0.06)]:
        assert math.degrees(model.at_year(lat, lon, 0.0, year).declination) == pytest.approx(d_ref, abs=0.1)


def test_default_model_follows_the_date():
    model = MagneticModel()
    field = model.at(43.07, 141.34, 0.0, 1.75e9)                    # Sapporo, 2025
    assert not field.extrapolated
    assert -12 < math.degrees(field.declination) < -8               # west declination in Hokkaido
    assert model.at(43.07, 141.34, 0.0, 0.0).extrapolated           # 1970: outside every WMM


def test_magnetic_disturbance_flagged():
    expected = MagneticModel().at_year(43.07, 141.34, 0.0, 2026.0)
    s = DisturbanceSettings()
    ok, *_ = disturbance(expected.total * 1.02, expected.inclination + 0.01, expected, s)
    assert not ok
    bad_f, d_f, _ = disturbance(expected.total * 1.3, expected.inclination, expected, s)
    bad_i, _, d_i = disturbance(expected.total, expected.inclination + math.radians(9), expected, s)
    assert bad_f and d_f == pytest.approx(0.3)
    assert bad_i and d_i == pytest.approx(math.radians(9))
    # attitude unknown: the rotation-invariant strength alone
    ok_f, _, nan_i = disturbance(expected.total * 1.02, None, expected, s)
    assert not ok_f and math.isnan(nan_i)
    assert disturbance(expected.total * 0.7, None, expected, s)[0]
    assert disturbance(0.0, None, expected, s)[0]                    # a dead sensor
