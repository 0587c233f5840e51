"""Sensor models reproduce their data-sheet statistics (SPEC §11) within stated tolerances."""
import math

import numpy as np
import pytest

from agnav_sim_eval.sim.scenarios import D5R, MS7400, STARFIRE, env05f, fog
from agnav_sim_eval.sim.sensors.fluxgate import Fluxgate, FluxgateParams
from agnav_sim_eval.sim.sensors.gnss import GnssReceiver
from agnav_sim_eval.sim.sensors.gyro import Gyro
from agnav_sim_eval.sim.sensors.inclinometer import G, Inclinometer
from agnav_sim_eval.sim.sensors.magnetic_field import earth_field_enu

RNG = np.random.default_rng


def test_vibratory_gyro_noise_within_datasheet():
    params = env05f((0.0, 0.0, 0.0))
    gyro = Gyro(params, RNG(1))
    out = np.array([gyro.sample(k * 0.01, 0.01, np.zeros(3), False) for k in range(5000)])
    noise = np.degrees(out.std(axis=0))
    assert np.all(noise < 0.4)  # data sheet: ≤ 10 mV ≈ 0.4 °/s
    assert noise == pytest.approx(np.full(3, params.noise_dps), rel=0.1)


def test_vibratory_gyro_bandwidth_is_10_hz():
    gyro = Gyro(env05f((0.0, 0.0, 0.0)).__class__(noise_dps=0.0, scale_error=0.0, random_walk_dps_rt_s=0.0,
                                                   offset_dps=0.0, bandwidth_hz=10.0), RNG(2))
    dt = 1e-4
    step = np.array([0.0, 0.0, 1.0])
    gyro.sample(0.0, dt, np.zeros(3), False)
    resp = np.array([gyro.sample(k * dt, dt, step, False)[2] for k in range(1, 200)])
    t63 = (np.argmax(resp >= 1 - math.exp(-1)) + 1) * dt
    assert 1 / (2 * math.pi * t63) == pytest.approx(10.0, rel=0.05)


def test_motion_bias_appears_when_moving_and_scale_error_bounded():
    params = env05f((-0.095, 0.084, -0.036))
    gyro = Gyro(params, RNG(3))
    still = np.array([gyro.sample(k * 0.01, 0.01, np.zeros(3), False) for k in range(1000)]).mean(axis=0)
    moving = np.array([gyro.sample(10 + k * 0.01, 0.01, np.zeros(3), True) for k in range(6000)])[3000:].mean(axis=0)
    assert np.degrees(moving - still) == pytest.approx(params.motion_bias_dps, abs=0.03)
    assert np.all(np.abs(gyro.scale) <= params.scale_error)


def test_fog_angle_noise_and_drift():
    params = fog(0.005)
    gyro = Gyro(params, RNG(4))
    dt = 0.01
    rates = np.array([gyro.sample(k * dt, dt, np.zeros(3), True) for k in range(20000)])
    angle = np.degrees(np.cumsum(rates, axis=0) * dt)
    drift = np.polyfit(np.arange(20000) * dt, angle, 1)[0]
    assert np.all(np.abs(drift) < 0.01)  # ≤ 0.005 °/s turn-on drift + random walk, far inside 2°/min
    resid = angle - np.outer(np.arange(20000) * dt, drift)
    assert np.std(np.diff(resid, axis=0), axis=0) / math.sqrt(2) == pytest.approx(np.full(3, 0.06), rel=0.15)


def test_inclinometer_first_order_lag():
    incl = Inclinometer(D5R.__class__(tau_s=D5R.tau_s, offset_deg=0, scale_error=0, cross_axis=0, noise_deg=0),
                        RNG(5))
    dt = 0.01
    f_level = np.array([0.0, 0.0, G])
    incl.sample(dt, 0.0, 0.0, f_level)
    roll = math.radians(10)
    f_tilt = np.array([0.0, G * math.sin(roll), G * math.cos(roll)])
    resp = np.array([incl.sample(dt, roll, 0.0, f_tilt)[0] for _ in range(500)]) / roll
    t90 = (np.argmax(resp >= 0.9) + 1) * dt
    assert t90 <= 2.5  # D5R data sheet: 90 % step response ≤ 2.5 s
    assert (np.argmax(resp >= 1 - math.exp(-1)) + 1) * dt == pytest.approx(D5R.tau_s, abs=0.02)


@pytest.mark.parametrize("accel", [0.5, -1.0])
def test_inclinometer_feels_longitudinal_and_lateral_acceleration(accel):
    incl = Inclinometer(D5R.__class__(tau_s=0.5, offset_deg=0, scale_error=0, cross_axis=0, noise_deg=0), RNG(6))
    f = np.array([accel, accel, G])  # forward and leftward acceleration, level vehicle
    for _ in range(1000):
        roll, pitch = incl.sample(0.01, 0.0, 0.0, f)
    assert pitch == pytest.approx(-math.asin(accel / G), rel=1e-6)  # accelerating: reads nose up (pitch < 0)
    assert roll == pytest.approx(math.asin(accel / G), rel=1e-6)  # left (centripetal) push reads right side down


def test_fluxgate_noise_and_field_angles():
    b_enu, decl, incl_deg = earth_field_enu(43.073, 141.338, 45.0)
    assert -11 < decl < -8 and 55 < incl_deg < 60  # Sapporo, WMM
    assert math.degrees(math.atan2(b_enu[0], b_enu[1])) == pytest.approx(decl, abs=1e-9)
    assert math.degrees(math.atan2(-b_enu[2], math.hypot(b_enu[0], b_enu[1]))) == pytest.approx(incl_deg, abs=1e-9)
    params = FluxgateParams()
    mag = Fluxgate(params, RNG(7))
    assert np.all(np.abs(mag.hard_iron) <= (params.hard_iron_mg + params.zero_bias_mg) * 1e-7)
    out = np.array([mag.sample(1 / 15, np.eye(3), b_enu) for _ in range(3000)])
    assert out.std(axis=0) / 1e-7 == pytest.approx(np.full(3, params.noise_mg), rel=0.1)
    calibrated = np.linalg.solve(mag.matrix, out.mean(axis=0) - mag.hard_iron)
    assert calibrated == pytest.approx(b_enu, abs=8e-9)  # 0.08 mG of ≈ 460 mG


@pytest.mark.parametrize("params", [STARFIRE, MS7400])
def test_gnss_error_matches_honest_covariance(params):
    rx = GnssReceiver(params, RNG(8))
    dt = 1 / params.rate_hz
    err = np.array([rx.sample(dt, np.zeros(3), np.zeros(3))[0] for _ in range(40000)])
    sigma = np.sqrt(np.diag(rx.position_cov))
    assert err.std(axis=0) == pytest.approx(sigma, rel=0.25)
    # coloured: epoch-to-epoch differences carry only the white part
    white = params.white_sigma_m * np.array([1.0, 1.0, params.vertical_ratio])
    assert np.diff(err, axis=0).std(axis=0) == pytest.approx(math.sqrt(2) * white, rel=0.1)
