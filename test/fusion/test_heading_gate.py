"""Magnetic-disturbance gate and the gyro-only heading of the estimators while it is closed (issue 16 item 10)."""
import math

import numpy as np
import pytest

from agnav_fusion.heading_estimators import EstimatorSettings, HeadingEstimator
from agnav_fusion.heading_gate import GyroErrorSettings, MagneticGate, propagation_variance
from synthetic_heading import straight_run

ONSET, END = 40.0, 50.0


def _rotated(run, deg=10.0):
    """GDS headings with the field turned by `deg` during [ONSET, END)."""
    return run.gds + np.where((run.t >= ONSET) & (run.t < END), math.radians(deg), 0.0)


def test_propagation_variance_grows_with_every_gyro_error():
    g = GyroErrorSettings(bias=1e-3, arw=1e-3, bias_walk=1e-4)
    taus = np.linspace(0.0, 60.0, 50)
    v = np.array([propagation_variance(g, tau) for tau in taus])
    assert v[0] == 0.0 and np.all(np.diff(v) > 0)
    assert propagation_variance(g, 10.0) == pytest.approx(1e-6 * 10 + 1e-4 + 1e-8 * 1000 / 3)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_gate_flags_a_rotation_of_the_field_at_once_and_reopens(seed):
    run = straight_run(seed=seed, duration=90.0, dt=1 / 15, bias_deg_s=0.03)
    gate = MagneticGate()
    gds = _rotated(run)
    flags = np.array([gate.update(t, gds[k], run.gyro[k], False) for k, t in enumerate(run.t)])
    inside = (run.t >= ONSET) & (run.t < END)
    assert np.all(flags[inside])                               # from the first rotated sample to the last
    assert not flags[run.t < ONSET].any()                      # no false alarm on the clean run
    assert not flags[run.t > END + 2.0].any()                  # reopened after the recovery time
    assert gate.reason is None and abs(gate.innovation) < 4 * gate.sigma


def test_gate_field_flag_and_the_reference_frozen_while_disturbed():
    run = straight_run(seed=4, duration=60.0, dt=1 / 15, bias_deg_s=0.0)
    gate = MagneticGate()
    field_bad = (run.t >= ONSET) & (run.t < END)
    gds = _rotated(run, 30.0)                                  # a flagged field may say anything
    flags = [gate.update(t, gds[k], run.gyro[k], bool(field_bad[k])) for k, t in enumerate(run.t)]
    assert all(f for f, bad in zip(flags, field_bad) if bad) and not flags[-1]
    assert abs(gate.innovation) < math.radians(2.0)           # the 30° samples never entered the reference


@pytest.mark.parametrize("name,bias", [("vwa", 0.03), ("gds_kf", 0.03), ("gds_gyro_lsm", 0.1)])
def test_estimators_propagate_the_gyro_alone_with_growing_variance(name, bias):
    run = straight_run(seed=21, duration=90.0, dt=1 / 15, bias_deg_s=bias)
    est = HeadingEstimator(EstimatorSettings(estimator=name, imu_rate_hz=15.0))
    gate = MagneticGate()
    gds = _rotated(run)
    out = []
    for k, t in enumerate(run.t):
        o = est.on_gyro(t, run.gyro_rate[k], run.dt)
        disturbed = gate.update(t, gds[k], run.gyro[k], False)
        o2 = est.on_gds(t, float(gds[k]), disturbed)
        out += [x for x in (o, o2) if x is not None]
    t, h, var = (np.array(c) for c in zip(*out))
    err = np.abs(np.angle(np.exp(1j * (h - np.interp(t, run.t, run.true)))))
    sigma = np.sqrt(var)
    late = t > 20.0
    assert np.all(err[late] <= 3.0 * sigma[late])
    during = (t > ONSET + 0.5) & (t < END)
    assert np.all(np.diff(sigma[during]) > 0)
    td = t[during]
    assert var[during][-1] - var[during][0] >= propagation_variance(est.s.gyro, td[-1] - td[0])
    assert math.degrees(err[during].max()) < 1.5               # the 10° never reaches the heading
    assert not est.disturbed and math.degrees(np.sqrt(np.mean(err[t > END + 20.0] ** 2))) < 0.6
