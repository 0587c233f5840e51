"""Tilt correction (SPEC §5.3, eq 4.18-4.24) against hand-computed poses."""
import math

import numpy as np
import pytest

from agnav_common.frames import rotation_matrix
from agnav_fusion import tilt_correction as tc

DEG = math.pi / 180.0


def expanded_E(phi, tp, tr):
    """The SPEC's element-by-element corrected (4.22)."""
    c, s = math.cos, math.sin
    return np.array([
        [c(phi) * c(tr) + s(phi) * s(tp) * s(tr), s(phi) * c(tp), c(phi) * s(tr) - s(phi) * s(tp) * c(tr)],
        [-s(phi) * c(tr) + c(phi) * s(tp) * s(tr), c(phi) * c(tp), -s(phi) * s(tr) - c(phi) * s(tp) * c(tr)],
        [-c(tp) * s(tr), s(tp), c(tp) * c(tr)],
    ])


def test_level_vehicle_only_rotates_lever_by_heading():
    off = tc.antenna_offset((0.0, -1.67, 3.23), heading=90 * DEG, pitch=0.0, roll=0.0)
    # facing east, 1.67 m behind -> 1.67 m west, 3.23 m up
    np.testing.assert_allclose(off, [-1.67, 0.0, 3.23], atol=1e-12)


def test_sleeper_case_1751mm_six_degree_roll():
    # heading north, left wheels on a sleeper -> right side down 6 deg; hand values h*sin6, h*cos6
    antenna = np.array([10.0, 20.0, 1.751])
    corrected = tc.correct(antenna + [0.0, 0.0, 0.0], (0.0, 0.0, 1.751), heading=0.0, pitch=0.0, roll=6 * DEG)
    off = antenna - corrected
    np.testing.assert_allclose(off, [0.183029, 0.0, 1.741408], atol=1e-6)


def test_mx240_lever_matches_hand_value_and_rep103_rotation():
    lever = (0.0, -1.67, 3.23)
    phi, tp, tr = 30 * DEG, 2 * DEG, -3 * DEG
    off = tc.antenna_offset(lever, phi, tp, tr)
    # REP-103 check (SPEC §2.3): ENU offset = R(roll=tr, pitch=-tp, yaw=pi/2-phi) @ FLU lever (b, -a, h)
    flu = np.array([lever[1], -lever[0], lever[2]])
    np.testing.assert_allclose(off, rotation_matrix(tr, -tp, math.pi / 2 - phi) @ flu, atol=1e-12)
    # hand value: forward axis (sin phi cos tp, cos phi cos tp, sin tp), up axis = third column of (4.22)
    fwd = np.array([math.sin(phi) * math.cos(tp), math.cos(phi) * math.cos(tp), math.sin(tp)])
    up = expanded_E(phi, tp, tr)[:, 2]
    np.testing.assert_allclose(off, -1.67 * fwd + 3.23 * up, atol=1e-12)
    # by hand: -1.67*(sin30, cos30) = (-0.835, -1.446); roll 3 deg left-down tilts the 3.23 m mast left,
    # (-cos30, sin30)*3.23*sin3 = (-0.146, 0.085); pitch 2 deg nose-up tilts it back, -(sin30, cos30)*3.23*sin2
    # = (-0.056, -0.098); up = 1.67*sin2 + 3.23*cos2*cos3
    np.testing.assert_allclose(off, [-1.03717, -1.45835, 3.16533], atol=2e-5)


@pytest.mark.parametrize("phi,tp,tr", [(0.3, 0.1, -0.2), (-2.0, -0.05, 0.15), (3.0, 0.2, 0.2)])
def test_elementary_product_equals_corrected_expansion(phi, tp, tr):
    np.testing.assert_allclose(tc.vehicle_to_ground(phi, tp, tr), expanded_E(phi, tp, tr), atol=1e-12)


def test_lever_from_flu():
    np.testing.assert_allclose(tc.lever_from_flu((-1.67, 0.0, 3.23)), [0.0, -1.67, 3.23])
