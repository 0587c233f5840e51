"""Strapdown mechanization against closed-form cases (SPEC §7.2)."""
import math

import numpy as np

from agnav_fusion.ins import earth
from agnav_sim_eval.sim import ins_synthetic as sy
from agnav_fusion.ins.mechanization import InsState, Mechanization, c_e_c, roll_pitch_from_accel


def _run(traj):
    gyro, accel = sy.ideal_imu(traj)
    roll, pitch, heading = traj.euler()
    m = Mechanization(InsState.from_geodetic(traj.lat[0], traj.lon[0], traj.h[0], roll[0], pitch[0], heading[0],
                                             traj.v_ned[0]))
    for k in range(len(gyro)):
        m.step(gyro[k], accel[k], traj.t[k + 1] - traj.t[k])
    s = m.state
    rm, rn = earth.radii(s.lat)
    pos = np.array([(s.lat - traj.lat[-1]) * rm, (s.lon - traj.lon[-1]) * rn * math.cos(s.lat), s.h - traj.h[-1]])
    att = np.array(s.euler()) - np.array([roll[-1], pitch[-1], heading[-1]])
    return pos, s.v_ned() - traj.v_ned[-1], att


def test_frame_matrix_recovers_lat_lon_wander():
    s = InsState(c_e_c(0.7, -2.1, 0.4), 0.0, np.zeros(3), np.array([1.0, 0, 0, 0]))
    assert math.isclose(s.lat, 0.7) and math.isclose(s.lon, -2.1) and math.isclose(s.alpha, 0.4)
    np.testing.assert_allclose(s.c_ec @ s.c_ec.T, np.eye(3), atol=1e-12)


def test_earth_model_values():
    rm, rn = earth.radii(0.0)
    assert math.isclose(rn, earth.A) and rm < rn
    assert abs(earth.gravity(0.0, 0.0) - 9.7803253359) < 1e-9
    assert abs(earth.gravity(math.pi / 2, 0.0) - 9.8321849378) < 1e-6
    # α = 0: ρ_x = v_E/(R_N+h) (north), ρ_y = v_N/(R_M+h) (west) (§7.2 step 8 check)
    lat, v_n, v_e = 0.8, 3.0, -2.0
    rho = earth.transport_rate(np.array([v_n, -v_e, 0.0]), lat, 0.0, 0.0)
    rm, rn = earth.radii(lat)
    np.testing.assert_allclose(rho, [v_e / rn, v_n / rm, 0.0])


def test_roll_pitch_from_accelerometers():
    roll, pitch = 0.1, -0.2
    g = 9.8
    f = np.array([g * math.sin(pitch), -g * math.cos(pitch) * math.sin(roll), -g * math.cos(pitch) * math.cos(roll)])
    np.testing.assert_allclose(roll_pitch_from_accel(f), (roll, pitch))


def test_stationary_on_rotating_earth_stays_put():
    pos, vel, att = _run(sy.drive([(200.0, 0.0, 0.0)], dt=0.05, heading0=0.7, tilt=lambda t: (0.05, -0.03)))
    assert np.all(np.abs(pos) < 0.05)           # Schuler-stable; only the g_N term remains
    assert np.all(np.abs(vel) < 1e-3)
    assert np.all(np.abs(att) < 1e-6)


def test_constant_velocity_straight_run_and_turns():
    traj = sy.drive([(4.0, 0.5, 0.0), (30.0, 0.0, 0.0), (10.0, 0.0, math.radians(15)), (16.0, 0.0, 0.0)],
                    dt=0.02, heading0=-2.0, tilt=lambda t: (0.04 * math.sin(0.3 * t), 0.02 * math.cos(0.2 * t)))
    pos, vel, att = _run(traj)
    assert np.all(np.abs(pos) < 0.05)
    assert np.all(np.abs(vel) < 5e-3)
    assert np.all(np.abs(att) < 1e-5)
