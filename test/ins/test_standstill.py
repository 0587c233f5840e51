"""Gyro bias learnt standing still before the GNSS/INS alignment (issue 15: heading on straight runs): the mean rate
of the stretch the fixes show standing, less the vertical earth rate; a start's pitching and the samples the fixes
see late are left out; nothing without a standing stretch."""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from agnav_fusion.ins import earth
from agnav_fusion.ins.standstill import StandstillBias, StandstillSettings

LAT = math.radians(36.0)
BIAS = np.radians([0.12, -0.2, 0.25])        # rad/s, FRD
NOISE = math.radians(0.1)                    # rad/s per 100 Hz sample
G = 9.80665


def _drive(still, vel=True, stand=10.0, seed=0):
    """100 Hz IMU standing `stand` s (level, FRD), then a start: 1 s of 2 deg/s pitching and 0.5 m/s^2; 5 Hz fixes
    0.12 s late, with or without a receiver velocity."""
    rng = np.random.default_rng(seed)
    earth_rate = earth.OMEGA * np.array([math.cos(LAT), 0.0, -math.sin(LAT)])   # heading north, level
    fixes, north = [], 0.0
    for k in range(int((stand + 4.0) * 100)):
        t = k * 0.01
        moving = t >= stand
        pitch_rate = math.radians(2.0) if stand <= t < stand + 1.0 else 0.0
        speed = 0.5 * (t - stand) if moving else 0.0
        gyro = BIAS + earth_rate + [0.0, pitch_rate, 0.0] + NOISE * rng.standard_normal(3)
        still.add_imu(t, gyro.tolist(), [0.5 if moving else 0.0, 0.0, -G])
        north += speed * 0.01
        if k % 20 == 0 and t >= 0.12:
            lag = max(t - 0.12 - stand, 0.0)
            fixes.append(SimpleNamespace(t=t - 0.12, lat=LAT + (0.25 * lag ** 2) / earth.radii(LAT)[0], lon=0.1,
                                         alt=100.0, pos_cov_enu=np.diag([1e-4, 1e-4, 4e-4]),
                                         vel_enu=(0.0, 0.5 * lag, 0.0) if vel else None))
            still.add_fix(fixes[-1])
    return fixes


@pytest.mark.parametrize("vel", [True, False])
def test_bias_of_the_standing_stretch_within_its_sigma(vel):
    still = StandstillBias(StandstillSettings(), gyro_arw=NOISE * 0.1)
    _drive(still, vel=vel)
    bias, var = still.estimate(LAT)[:2]
    err = np.array(bias) - BIAS
    assert np.all(np.abs(err) <= 3.0 * np.sqrt(var)), (np.degrees(err) * 3600, np.degrees(np.sqrt(var)) * 3600)
    assert np.all(np.degrees(np.abs(err)) * 3600 < 30.0)    # deg/h: the start's pitching left out


def test_start_pitching_is_dropped_even_when_the_fixes_see_it_late():
    """A radius the start stays inside for a while: the trailing samples that disagree with the median go."""
    still = StandstillBias(StandstillSettings(radius=0.15, guard=0.0), gyro_arw=NOISE * 0.1)
    _drive(still, vel=False)
    bias = still.estimate(LAT).bias
    assert abs(bias[1] - BIAS[1]) < math.radians(30.0 / 3600)


def test_nothing_without_a_standing_stretch():
    still = StandstillBias(StandstillSettings(), gyro_arw=NOISE * 0.1)
    _drive(still, stand=1.0)                 # moves after 1 s: shorter than min_duration
    assert still.estimate(LAT) is None
    off = StandstillBias(StandstillSettings(enabled=False), gyro_arw=NOISE * 0.1)
    _drive(off)
    assert off.estimate(LAT) is None


def test_published_once_the_heading_is_known_and_then_through_an_outage():
    """The shipped `ins` pipeline on a simulated field run (standing start, in-motion alignment from the course, a
    20 s GNSS outage): nothing is publishable before the yaw sigma is below heading_valid_sigma; from then on every
    sample is, the outage included."""
    from agnav_bringup.graph_config import load_config
    from agnav_sim_eval import offline
    from agnav_sim_eval.bench.module_runs import sim_rows
    from agnav_sim_eval.sim import simulate
    config = load_config("ins")
    pipeline = offline.pipeline_for(config)
    states = [s for s in offline.run_rows(pipeline, config, sim_rows(simulate("mems_field", seed=3, messages=True),
                                                                     outage=(60.0, 80.0))) if s is not None]
    valid = [s.heading_valid for s in states]
    first = valid.index(True)
    assert first > 0 and math.sqrt(states[first].pose_cov[5, 5]) <= pipeline.backend.settings.heading_valid_sigma
    assert all(valid[first:]) and any(s.dead_reckoning for s in states[first:])


def test_the_standing_level_is_carried_by_the_gyros_through_the_start():
    """_drive's start pitches the vehicle up 2 deg while accelerating at 0.5 m/s^2: the standing level carried by
    the bias-corrected gyros ends at the true attitude; the accelerometers there read 2.9 deg of acceleration."""
    still = StandstillBias(StandstillSettings(), gyro_arw=NOISE * 0.1)
    _drive(still)
    roll, pitch = still.level(still.estimate(LAT))
    assert abs(math.degrees(roll)) < 0.1 and abs(math.degrees(pitch) - 2.0) < 0.1     # gyro noise over 4 s
    short = StandstillBias(StandstillSettings(carry=1.0), gyro_arw=NOISE * 0.1)
    _drive(short)
    assert short.level(short.estimate(LAT)) is None       # the samples since the stretch are gone
