"""Campaign scenario generator (ranges, determinism) and the simulator features it draws (issue 15)."""
import math
from dataclasses import replace

import numpy as np
import pytest

from agnav_common.frames import rotation_matrix
from agnav_sim_eval.sim import SCENARIOS, TractorSimulator, simulate, stats
from agnav_sim_eval.sim.random_scenarios import RANGES, draw
from agnav_sim_eval.sim.route import DriverParams, straight
from agnav_sim_eval.sim.sensors.accelerometer import AccelParams
from agnav_sim_eval.sim.sensors.fluxgate import Fluxgate, FluxgateParams
from agnav_sim_eval.sim.sensors.gnss import FIX_RTK_FLOAT
from agnav_sim_eval.sim.sensors.magnetic_field import DisturbanceParams, MagneticEnvironment
from agnav_sim_eval.sim.sensors.wheel import WheelParams
from agnav_sim_eval.sim.terrain import TerrainParams

SEEDS = range(40)
SHORT = dict(route=straight(20.0), driver=DriverParams(speed_mps=2.0, start_standstill_s=2.0, end_standstill_s=1.0))


def within(value, key):
    lo, hi = RANGES[key]
    return lo - 1e-9 <= value <= hi + 1e-9


def test_draws_respect_the_ranges_and_cover_every_class():
    seen = {"sensor_set": set(), "receiver": set(), "surface": set(), "gnss_vel": set()}
    for seed in SEEDS:
        sc, p = draw(seed)
        for key in seen:
            seen[key].add(p[key])
        key = "rough_road_speed_mps" if p["surface"] == "rough_road" else "speed_mps"
        assert within(sc.driver.speed_mps, key) and within(sc.driver.start_standstill_s, "start_standstill_s")
        g = sc.gnss
        assert within(g.latency_s, "latency_s") and within(g.latency_jitter_s, "latency_jitter_s")
        assert within(g.bias_sigma_m, "rtk_wander_m" if p["receiver"] == "RTK" else "dgps_wander_m")
        assert all(within(b - a, "outage_s") for a, b in g.outages)
        assert all(within(b - a, "float_s") for a, b in g.float_episodes) and (p["receiver"] == "RTK" or not g.float_episodes)
        assert within(sc.mounts["gnss_link"][0][2], "antenna_height_m") and within(sc.mounts["imu_link"][0][2], "imu_height_m")
        roll_err, pitch_err, yaw_err = np.degrees(sc.mount_errors["imu_link"])
        assert max(abs(roll_err), abs(pitch_err)) <= RANGES["mount_tilt_deg"][1] and abs(yaw_err) <= RANGES["mount_yaw_deg"][1]
        if p["sensor_set"] == "thesis":
            assert sc.accel is None and within(sc.incl.tau_s, "incl_tau_s") and within(sc.incl.offset_deg, "incl_zero_deg")
        else:
            assert sc.accel is not None and sc.incl is None
        if p["surface"] == "slope":
            assert within(p["slope_deg"], "slope_deg") and within(sc.crab_gain, "crab_gain")
        assert sc.gnss_vel == p["gnss_vel"]
    assert seen == {"sensor_set": {"thesis", "mems"}, "receiver": {"RTK", "DGPS"},
                    "surface": {"flat", "slope", "tilled", "rough_road"}, "gnss_vel": {True, False}}


def test_runs_last_about_one_to_two_minutes():
    for seed in range(1000, 1006):
        sim = TractorSimulator(draw(seed)[0], seed)
        while not sim.done:
            sim.step()
        assert 50.0 <= sim.t <= 150.0


def test_deterministic_per_seed():
    (a, pa), (b, pb), (_, pc) = draw(7), draw(7), draw(8)
    assert pa == pb and pa != pc
    sims = [TractorSimulator(sc, 7) for sc in (a, b)]
    out = [[d for _ in range(300) for kind, _, d in s.step() if kind == "imu"] for s in sims]
    assert all(np.array_equal(x["gyro"], y["gyro"]) for x, y in zip(*out))
    gyro = np.array([d["gyro"] for d in out[0]])
    assert np.unique(gyro[:, 0]).size == gyro.shape[0]  # noisy, not a stuck IMU


def test_rough_road_sway_matches_table_5_4_raw_rows():
    rows = []
    for seed in (1, 2, 3):
        run = simulate("rough_road_sway", seed=seed)
        inc, moving = stats.inclinometer_errors(run), run.truth.speed > 0.3
        rows.append([inc["roll_rms_deg"], inc["pitch_rms_deg"], *np.degrees([np.std(run.truth.roll[moving]),
                                                                            np.std(run.truth.pitch[moving])])])
    roll_err, pitch_err, roll, pitch = np.mean(rows, axis=0)
    assert roll_err == pytest.approx(3.28, rel=0.2) and pitch_err == pytest.approx(1.84, rel=0.2)
    assert 1.5 < roll < 2.3 and 1.4 < pitch < 2.2


def test_gnss_outage_float_jitter_and_no_velocity():
    base = SCENARIOS["mems_field"]
    gnss = replace(base.gnss, outages=((5.0, 8.0),), float_episodes=((9.0, 11.0),), latency_jitter_s=0.05,
                   float_sigma_m=0.3)
    run = simulate("mems_field", seed=3, gnss=gnss, gnss_vel=False, messages=True, **SHORT)
    g = run.gnss
    assert not np.any((g.t >= 5.0) & (g.t < 8.0)) and np.any(g.t >= 8.0)
    floating = (g.t >= 9.0) & (g.t < 11.0)
    assert np.all(g.fix_type[floating] == FIX_RTK_FLOAT) and np.all(g.fix_type[~floating] == base.gnss.fix_type)
    assert np.all(g.cov[floating, 0, 0] > 0.3 ** 2) and np.all(g.cov[~floating, 0, 0] < 0.05 ** 2)
    late = g.t_arrival - g.t
    assert np.all(np.diff(g.t_arrival) > 0) and late.min() >= base.gnss.latency_s and np.ptp(late) > 0.01
    assert {topic for _, topic, _ in run.messages} >= {"/gnss/fix", "/gnss/status"}
    assert "/gnss/vel" not in {topic for _, topic, _ in run.messages}


def test_crab_on_a_slope_and_wheel_slip():
    slope = TerrainParams(slope_deg=8.0, slope_axis_yaw=math.pi / 2, slope_ramp_m=(-1e4, -1e4 + 1.0))
    sim = TractorSimulator("asphalt_loop", 2, terrain=slope, crab_gain=0.3, wheel=WheelParams(slip_mean=0.1),
                           **SHORT)
    crab, ratio = [], []
    while not sim.done:
        for kind, _, d in sim.step():
            tr = sim.truth_state()
            if kind == "truth" and tr["speed"] > 1.5:
                crab.append(math.atan2(d["vy"], d["vx"]) - d["yaw"])
            if kind == "wheel" and tr["speed"] > 1.5:
                ratio.append(d["speed"] / tr["speed"])
    # roll ≈ +8° (falls to the right of north): slides right, ≈ -0.3·8° = -2.4°
    assert math.degrees(np.median(crab)) == pytest.approx(-2.4, abs=0.4)
    assert np.mean(ratio) == pytest.approx(1.1, abs=0.04)


def test_mount_misalignment_is_hidden_from_tf_static():
    err = np.radians([0.5, 0.0, 0.0])
    run = simulate("mems_field", seed=1, mount_errors={"imu_link": tuple(err)},
                   accel=AccelParams(bias_mps2=0.0, scale_error=0.0, noise_mps2=0.01), **SHORT)
    still = run.truth.speed == 0.0
    tr = run.truth
    g_body = rotation_matrix(tr.roll[still].mean(), tr.pitch[still].mean(), tr.yaw[still].mean()).T @ [0, 0, 9.80665]
    nominal = run.mounts["imu_link"][1]  # what /tf_static says
    assert nominal == SCENARIOS["mems_field"].mounts["imu_link"][1]
    f = run.imu.accel[still].mean(axis=0)

    def angle_deg(rpy):
        v = rotation_matrix(*rpy).T @ g_body
        return math.degrees(math.acos(np.dot(f, v) / np.linalg.norm(f) / np.linalg.norm(v)))
    assert angle_deg(nominal) == pytest.approx(0.5, abs=0.05) and angle_deg(np.add(nominal, err)) < 0.05


def test_magnetometer_soft_iron_and_passing_disturbance():
    env = MagneticEnvironment(SCENARIOS["mems_field"].datum, DisturbanceParams(passing=((10.0, 4.0, 200.0),)),
                              np.random.default_rng(1))
    quiet, peak = env.field(3.0, 4.0, 7.9), env.field(3.0, 4.0, 10.0)
    assert np.array_equal(quiet, env.field(3.0, 4.0)) and np.array_equal(env.field(3.0, 4.0, 12.1), quiet)
    assert np.linalg.norm(peak - quiet) == pytest.approx(200e-7, rel=1e-9)  # 200 mG at the centre
    bare = Fluxgate(FluxgateParams(), np.random.default_rng(2))
    steel = Fluxgate(FluxgateParams(soft_iron=0.1), np.random.default_rng(2))
    distortion = steel.matrix @ np.linalg.inv(bare.matrix) - np.eye(3)  # same draws, then the soft iron
    assert np.allclose(distortion, distortion.T) and 0.01 < np.abs(distortion).max() <= 0.1
