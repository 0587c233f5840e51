"""The gyro's first-order response undone (agnav_fusion.gyro_lag) and applied by the pipeline's front end."""
import math
from types import SimpleNamespace

import numpy as np
import pytest
from agnav_fusion.backends import pipeline_from_parameters
from agnav_fusion.gyro_lag import GyroLag
from agnav_fusion.pipeline import FrontEndSettings, NavigationPipeline

BANDWIDTH = 10.0
TAU = 1.0 / (2.0 * math.pi * BANDWIDTH)


def lagged(times, rates, tau=TAU):
    """A first-order lag of a rate held over each sample (how a data sheet's bandwidth reads the rate)."""
    y, out = rates[0].copy(), [rates[0].copy()]
    for k in range(1, len(times)):
        y = y + (1.0 - math.exp(-(times[k] - times[k - 1]) / tau)) * (rates[k] - y)
        out.append(y.copy())
    return out


def turn(n=600, seed=3):
    """A 100 Hz turn with jittered stamps: yaw rate ramping to 0.5 rad/s and back, a swaying roll rate."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(0.01 + rng.uniform(-0.002, 0.002, n))
    yaw = 0.5 * np.clip(np.minimum(t - 1.0, 5.0 - t), 0.0, 1.0)
    roll = 0.1 * np.sin(2 * math.pi * 1.5 * t)
    return t, [np.array([r, 0.0, w]) for r, w in zip(roll, yaw)]


def test_the_lag_is_undone_sample_for_sample():
    t, rates = turn()
    lag = GyroLag(BANDWIDTH)
    read = lagged(t, rates)
    out = [lag.undo(tk, yk) for tk, yk in zip(t, read)]
    assert np.max(np.abs(np.array(out) - np.array(rates))) < 1e-12
    # mid-turn the heading integrated from the reading trails by (tau - dt/2) x rate (0.31 deg at 0.5 rad/s)
    mid = np.searchsorted(t, 3.0)
    trail = np.sum([(r[2] - y[2]) * dt for r, y, dt in zip(rates[1:mid], read[1:mid], np.diff(t[:mid]))])
    assert math.degrees(trail) == pytest.approx(math.degrees((TAU - 0.005) * 0.5), rel=0.1)


def test_bias_passes_and_the_integrated_noise_does_not_grow():
    rng = np.random.default_rng(5)
    n, dt, bias = 20000, 0.01, 0.003
    noise = rng.normal(0.0, math.radians(0.25), n)
    lag = GyroLag(BANDWIDTH)
    out = np.array([lag.undo(k * dt, np.array([0.0, 0.0, bias + e]))[2] for k, e in enumerate(noise)])
    assert np.mean(out) == pytest.approx(bias, abs=2e-4)
    angle_in, angle_out = np.cumsum(bias + noise) * dt, np.cumsum(out) * dt
    assert np.max(np.abs(angle_out - angle_in)) < 3 * TAU * math.radians(0.25) * 3   # telescoped: tau x a reading
    assert np.std(out - bias) == pytest.approx(2.4 * math.radians(0.25), rel=0.1)     # the rate itself is noisier


def test_bad_samples_pass_unchanged_and_cost_at_most_the_next_samples_correction():
    lag, z = GyroLag(BANDWIDTH), np.array([0.0, 0.0, 0.1])
    assert lag.undo(0.0, z) is z
    bad = np.array([0.0, math.nan, 0.1])
    assert lag.undo(0.01, bad) is bad                             # the input guard's to reject
    assert np.allclose(lag.undo(0.02, z), z)                      # steady against t = 0: NaN was no reference
    assert np.allclose(lag.undo(5.0, np.array([0.0, 0.0, 0.2])), [0.0, 0.0, 0.2])    # a gap: as read
    # a lone far-future stamp (the guard refuses it) restarts the reference; the next sample passes as read, and
    # the one after is de-lagged again (a reference kept in the future would pass every sample as read)
    future = np.array([0.0, 0.0, 0.9])
    assert lag.undo(1e9, future) is future
    read = lagged(np.array([5.01, 5.02, 5.03]), [np.array([0.0, 0.0, 0.2]), np.array([0.0, 0.0, 0.3]),
                                                 np.array([0.0, 0.0, 0.3])])
    assert lag.undo(5.01, read[0]) is read[0]
    assert np.allclose(lag.undo(5.02, read[1]), [0.0, 0.0, 0.3]) and np.allclose(lag.undo(5.03, read[2]),
                                                                                  [0.0, 0.0, 0.3])


def test_no_bandwidth_is_the_reading_itself():
    reading = np.array([0.1, 0.2, 0.3])
    lag = GyroLag(0.0)
    assert lag.undo(0.0, reading) is reading and lag.undo(0.01, reading) is reading


def test_bunched_stamps_keep_the_gain_bounded():
    lag = GyroLag(BANDWIDTH)
    for k in range(50):
        lag.undo(0.01 * k, np.zeros(3))
    step = np.array([0.0, 0.0, 0.01])
    out = lag.undo(0.491, step)             # 1 ms after the last sample of a 100 Hz stream (taken on arrival)
    assert out[2] == pytest.approx(0.01 / -math.expm1(-0.005 / TAU))   # as half a period: gain 3.7, not 16


class Recorder:
    """A backend that keeps the rates the front end hands it."""
    guard = None

    def __init__(self):
        self.rates = []

    def set_mounts(self, *levers):
        pass

    def imu(self, t, gyro, accel):
        self.rates.append(gyro)


def test_the_pipeline_hands_the_backend_the_de_lagged_rate_turned_into_base_link():
    t, rates = turn(200)
    backend = Recorder()
    pipe = NavigationPipeline(backend, FrontEndSettings(gyro_bandwidth_hz=BANDWIDTH))
    pipe.set_mounts(np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]), (0.0, 0.0, 2.0), (0.0, 0.0, 1.0))
    for tk, (x, y, z) in zip(t, lagged(t, rates)):      # the IMU turned 90 deg left: its x is base_link's y
        stamp = SimpleNamespace(sec=int(tk), nanosec=int(round((tk - int(tk)) * 1e9)))
        pipe.on_imu(SimpleNamespace(header=SimpleNamespace(stamp=stamp), angular_velocity=SimpleNamespace(
            x=y, y=-x, z=z), linear_acceleration_covariance=[-1.0] + [0.0] * 8))
    assert np.max(np.abs(np.array(backend.rates) - np.array(rates))) < 1e-6      # (stamps rounded to ns)


def test_the_pipeline_takes_the_bandwidth_from_its_parameters():
    assert pipeline_from_parameters({"gyro_bandwidth_hz": BANDWIDTH}).gyro_lag.tau == pytest.approx(TAU)
    assert pipeline_from_parameters({}).gyro_lag.tau == 0.0
