"""Gyro drift LSM against the delayed GDS and the delay-compensated GDS–gyro VWA (SPEC §4.5–4.6)."""
import math

import numpy as np
import pytest

from agnav_fusion.gds_drift_lsm import (DelayedVwaSettings, DriftLsmSettings, GdsGyroSystem, GyroDriftLsm)
from synthetic_heading import rms_deg, straight_run

DELAY = 35


def _delayed(x, n):
    return np.concatenate([np.full(n, x[0]), x[:-n]])


def test_drift_lsm_recovers_a_constant_bias_exactly_without_noise():
    dt, bias = 0.02, math.radians(0.3)
    t = np.arange(0, 20, dt)
    true = 0.5 + 0.02 * np.sin(t)
    lsm = GyroDriftLsm(DriftLsmSettings(window=175, delay=DELAY, dt=dt))
    rate = np.diff(true, prepend=true[0]) / dt          # backward difference, as ω_GDS of (3.15)
    for w, g in zip(rate + bias, _delayed(true, DELAY)):
        d = lsm.update(float(w), float(g))
    assert lsm.ready
    assert d == pytest.approx(-bias, abs=1e-9)


def test_drift_lsm_on_noisy_signals_with_wrapping_heading():
    run = straight_run(seed=11, duration=60.0, bias_deg_s=0.14)
    gds = np.angle(np.exp(1j * (run.gds + math.pi - 0.7)))          # crosses ±180°
    lsm = GyroDriftLsm()
    est = [lsm.update(w, g) for w, g in zip(run.gyro_rate, _delayed(gds, DELAY))]
    tail = np.array(est[1000:])
    assert np.mean(tail) == pytest.approx(-run.bias, abs=math.radians(0.03))


def test_delay_compensated_system_beats_gds_and_raw_gyro():
    run = straight_run(seed=12, duration=100.0, bias_deg_s=0.14)
    gds_delayed = _delayed(run.gds, DELAY)
    system = GdsGyroSystem(DriftLsmSettings(), DelayedVwaSettings(window=15.0, interval=5.0))
    out = np.array([system.update(w, g)[:2] for w, g in zip(run.gyro_rate, gds_delayed)])
    skip = int(20.0 / run.dt)
    err = rms_deg(out[skip:, 0] - run.true[skip:])
    assert np.all(np.isfinite(out[skip:, 1])) and np.all(out[skip:, 1] > 0)
    assert err < 0.5 * rms_deg(run.gds[skip:] - run.true[skip:])
    assert err < 0.5 * rms_deg(gds_delayed[skip:] - run.true[skip:])
    gyro = run.gyro - run.gyro[0] + run.gds[0]
    assert err < 0.1 * rms_deg(gyro[skip:] - run.true[skip:])
    # ignoring the 0.7 s GDS latency costs accuracy when the heading moves
    naive = GdsGyroSystem(DriftLsmSettings(delay=0), DelayedVwaSettings(delay=0))
    out0 = np.array([naive.update(w, g)[0] for w, g in zip(run.gyro_rate, gds_delayed)])
    assert err < rms_deg(out0[skip:] - run.true[skip:])
