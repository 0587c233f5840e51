"""Variance-weighted average with variable target heading (SPEC §3.6)."""
import math

import numpy as np
import pytest

from agnav_common.variance_weighted_average import VariableTargetVwa, VwaSettings, WindowStats, vwa
from synthetic_heading import rms_deg, straight_run


def test_vwa_of_two_estimates_is_the_inverse_variance_mean():
    x, var = vwa(1.0, 4.0, 2.0, 1.0)
    assert x == pytest.approx((1.0 * 1.0 + 4.0 * 2.0) / 5.0)
    assert var == pytest.approx(0.8)


def test_deviation_cancels_the_unknown_gyro_bias_and_gds_offset():
    stats = WindowStats.of([0.10, 0.12, 0.08], [5.10, 5.12, 5.08])
    # gyro offset 5 rad and an equal GDS/gyro change: the deviation is the common change
    assert stats.deviation(0.15, 5.15) == pytest.approx(0.05)
    assert stats.heading(0.15, 5.15)[0] == pytest.approx(0.15)


def test_variable_target_vwa_beats_gds_and_drifting_gyro():
    run = straight_run(seed=7, duration=400.0, dt=1 / 15, bias_deg_s=0.004, gds_sigma_deg=0.26 * 1.4,
                       gyro_sigma_deg_s=0.02, spatial_deg=0.8)
    f = VariableTargetVwa(VwaSettings(window=10.0, interval=2.0))
    dev, dev_true, gyro_weights = [], [], []
    history = []
    for k, t in enumerate(run.t):
        history.append((t, run.true[k]))
        out = f.update(t, run.gds[k], run.gyro[k])
        if out is None:
            continue
        dev.append(out[0])
        window = [h for (s, h) in history if f.last_update - f.s.window < s <= f.last_update]
        dev_true.append(run.true[k] - np.mean(window))
        gyro_weights.append(f.stats.gyro_weight)
    dev, dev_true = np.array(dev), np.array(dev_true)
    n0 = int(10.0 / run.dt)
    gds_dev = run.gds - run.gds[:n0].mean() - (run.true - run.true[:n0].mean())
    gyro_dev = run.gyro - run.gyro[:n0].mean() - (run.true - run.true[:n0].mean())
    err_vwa = rms_deg(dev - dev_true)
    assert err_vwa < 0.5 * rms_deg(gds_dev)
    assert err_vwa < 0.5 * rms_deg(gyro_dev)
    assert 0.5 < np.mean(gyro_weights) < 1.0


def test_target_updates_every_interval():
    f = VariableTargetVwa(VwaSettings(window=1.0, interval=0.5))
    updates = []
    for k in range(60):
        t = k * 0.1
        f.update(t, 0.01 * k, 0.01 * k + 1.0)
        updates.append(f.last_update)
    assert sorted(set(u for u in updates if u is not None)) == pytest.approx([1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0,
                                                                              4.5, 5.0, 5.5])
    assert f.target == pytest.approx(np.mean([0.01 * k for k in range(46, 56)]))
    assert math.isfinite(f.stats.gyro_weight)
