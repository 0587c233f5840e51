"""GNSS measurement models of the INS EKF (issue 15): the lever arm's attitude and gyro-bias dependence is in H,
exactly (γ/β for the azimuth), not white noise: H x = z(computed) - z(computed corrected by x)."""
import copy
import math

import numpy as np
import pytest

from agnav_fusion.ins import error_model as em, feedback
from agnav_fusion.ins.lever_arm import imu_to_point_position
from agnav_fusion.ins.measurements import GnssPosition, GnssSample, GnssVelocity, Snapshot
from agnav_fusion.ins.mechanization import T, InsState, Mechanization, c_cbar_ned

LEVER = np.array([-1.67, 0.3, -3.23])     # IMU -> antenna, FRD [m]: tall antenna behind the IMU
OMEGA = np.array([0.2, -0.15, 0.1])       # body rates (rough track, turning)


def _snap(mech, omega=OMEGA):
    s = mech.state
    cn = c_cbar_ned(s.alpha)
    return Snapshot(0.0, s.lat, s.lon, s.h, cn @ (T @ s.v), cn @ s.c_b_cbar(), np.asarray(omega, dtype=float))


def _setup():
    mech = Mechanization(InsState.from_geodetic(0.75, 2.4, 30.0, 0.05, -0.08, 2.2, (1.5, -3.0, 0.2)))
    s = _snap(mech)
    lat, lon, h = imu_to_point_position(s.lat, s.lon, s.h, LEVER, s.c_b_ned)
    g = GnssSample(0.0, lat + 1e-7, lon - 2e-7, h + 0.05, np.eye(3) * 1e-4, np.array([-2.0, 1.2, 0.1]),
                   np.eye(3) * 1e-4)
    return mech, g


def _x(i, step):
    x = np.zeros(em.N_STATES)
    x[i] = step
    if i == em.GAMMA:                       # a finite azimuth error: γ = sin δα, β = 1 - cos δα
        x[em.BETA] = 1.0 - math.sqrt(1.0 - step * step)
    return x


@pytest.mark.parametrize("model", [GnssPosition, GnssVelocity])
@pytest.mark.parametrize("i, step", [(em.TX, 1e-4), (em.TY, 1e-4), (em.GAMMA, 1e-4), (em.GAMMA, 0.3)])
def test_attitude_columns_match_the_feedback_correction(model, i, step):
    """Before: no attitude column for the lever term (heading: white noise γ² |l|², velocity: γ rotated the lever
    velocity too); a 0.3 rad azimuth error is exact in γ/β."""
    mech, g = _setup()
    m = model(LEVER)
    lin = m.linearize(_snap(mech), mech.state.alpha, g, em.N_STATES)
    x = _x(i, step)
    corrected = copy.deepcopy(mech)
    feedback.apply(corrected, x)
    true = m.linearize(_snap(corrected), corrected.state.alpha, g, em.N_STATES)
    scale = np.array([6.4e6, 6.4e6, 1.0]) if model is GnssPosition else np.ones(3)   # rad -> m
    np.testing.assert_allclose((lin.z - true.z) * scale, (lin.h @ x) * scale, atol=2e-3 * step + 1e-9)


def test_velocity_gyro_bias_columns():
    """ω = gyro - bias in the ω x l lever velocity: a bias correction changes it (before: no column)."""
    mech, g = _setup()
    m = GnssVelocity(LEVER)
    lin = m.linearize(_snap(mech), mech.state.alpha, g, em.N_STATES)
    for i in range(3):
        x = np.zeros(em.N_STATES)
        x[em.BG.start + i] = 1e-4
        true = m.linearize(_snap(mech, OMEGA - x[em.BG]), mech.state.alpha, g, em.N_STATES)
        np.testing.assert_allclose(lin.z - true.z, lin.h @ x, atol=1e-10)


def test_position_mount_yaw_column():
    """Body axes turned by δm off base_link's (yaw mount state): the lever, measured on base_link, is R_z(δm) l on
    the body axes; the column is z(lever l) - z(lever R_z(δm) l) per δm."""
    mech, g = _setup()
    n, dm = em.N_INS, 1e-4
    lin = GnssPosition(LEVER).linearize(_snap(mech), mech.state.alpha, g, n)
    turned = np.array([LEVER[0] - dm * LEVER[1], LEVER[1] + dm * LEVER[0], LEVER[2]])
    true = GnssPosition(turned).linearize(_snap(mech), mech.state.alpha, g, n)
    scale = np.array([6.4e6, 6.4e6, 1.0])
    np.testing.assert_allclose((lin.z - true.z) * scale, lin.h[:, em.MOUNT_YAW] * dm * scale, atol=1e-7)
    assert np.abs(lin.h[:, em.MOUNT_YAW] * scale).max() > 1.0
