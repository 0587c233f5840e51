"""Attitude KF: online identification of the inclinometer's time constant (inclinometer_lag.LagIdentifier) and the
gyro-only hold over a start that the GNSS reports late, and the re-filter with the acceleration it corrects."""
import math

import numpy as np
import pytest

from agnav_fusion.attitude_kf import AttitudeKF, AttitudeKFSettings
from agnav_fusion.inclinometer_lag import LagIdentifier

DT = 0.01


def sway(seed, seconds=60.0, amplitude=math.radians(1.0)):
    """(true angle, gyro reading with bias and noise) of a coloured sway (0.2-2 Hz)."""
    rng = np.random.default_rng(seed)
    n = int(seconds / DT)
    freqs = rng.uniform(0.2, 2.0, 6)
    phases = rng.uniform(0, 2 * math.pi, 6)
    t = np.arange(n) * DT
    angle = amplitude / math.sqrt(3) * np.sin(2 * math.pi * freqs[:, None] * t + phases[:, None]).sum(axis=0)
    rate = np.gradient(angle, DT) + math.radians(0.4) + math.radians(0.05) * rng.standard_normal(n)
    return angle, rate, rng


def inclinometer(angle, tau, rng, offset=math.radians(0.3), noise=math.radians(0.1)):
    out, y = np.empty_like(angle), angle[0]
    a = 1.0 - math.exp(-DT / tau)
    for i, u in enumerate(angle):
        y += a * (u - y)
        out[i] = y
    return out + offset + noise * rng.standard_normal(angle.size)


@pytest.mark.parametrize("true_tau", [0.4, 0.7, 1.4])
def test_the_time_constant_is_found_from_the_gyro(true_tau):
    angle, rate, rng = sway(3)
    reading = inclinometer(angle, true_tau, rng)
    lag = LagIdentifier(1.1)
    for w, y in zip(rate, reading):
        tau = lag.update(w - math.radians(0.4), y, 0.0, DT)
    assert tau == pytest.approx(true_tau, rel=0.1)


def test_no_motion_tells_no_time_constant():
    rng = np.random.default_rng(4)
    lag = LagIdentifier(1.1)
    for _ in range(6000):
        tau = lag.update(math.radians(0.05) * rng.standard_normal(), math.radians(0.1) * rng.standard_normal(), 0.0,
                         DT)
    assert tau is None


def test_an_identified_lag_makes_the_attitude_filter_follow_the_sway():
    """Configured 1.1 s, sensor 0.4 s: with identification the angle error under sway is smaller."""
    angle, rate, rng = sway(5)
    reading = inclinometer(angle, 0.4, rng, offset=0.0)
    rms = {}
    for identify in (False, True):
        kf = AttitudeKF(AttitudeKFSettings(identify_tau=identify))
        est = np.array([kf.update(w, y, DT) for w, y in zip(rate, reading)])
        rms[identify] = math.degrees(np.sqrt(np.mean((est - angle)[3000:] ** 2)))
    assert kf.lag.tau == pytest.approx(0.4, rel=0.1)
    assert rms[True] < 0.7 * rms[False]


def test_a_start_seen_late_does_not_bend_the_gyro_bias():
    """Standing still 20 s (bias learnt), then 1 s of 0.5 m/s^2 that the inclinometer reads as 2.9 deg of pitch
    before a GNSS epoch shows the start: the gyro-only copy keeps the bias and the angle."""
    rng = np.random.default_rng(6)
    bias, accel = math.radians(0.3), 0.5 / 9.81
    errors = {}
    for hold in (False, True):
        kf = AttitudeKF(AttitudeKFSettings(identify_tau=False, tau=0.5))
        for i in range(2100):
            if i == 2000 and hold:
                kf.checkpoint()
            reading = math.radians(0.1) * rng.standard_normal() + (accel if i >= 2000 else 0.0)
            kf.update(bias + math.radians(0.05) * rng.standard_normal(), reading, DT)
        kf.revert()
        errors[hold] = (math.degrees(abs(kf.bias - bias)), math.degrees(abs(kf.angle)))
    assert errors[True][0] < 0.02 and errors[True][1] < 0.1
    assert errors[False][0] > 3 * errors[True][0] and errors[False][1] > 3 * errors[True][1]


def test_a_start_seen_late_is_re_filtered_with_its_acceleration():
    """Standing 20 s, then 1 s of 0.5 m/s^2 the speed model missed (compensation 0), and a direct angle reading in it:
    refilter() with the missed a/g gives what the filter would have given with it from mark() on, bit for bit (the
    identified time constant of each sample kept), and keeps the bias and angle where a refilter(0) does not."""
    rng = np.random.default_rng(7)
    bias, accel = math.radians(0.3), 0.5 / 9.81
    inputs = [(bias + math.radians(0.05) * rng.standard_normal(),
               math.radians(0.1) * rng.standard_normal() + (accel if i >= 2000 else 0.0)) for i in range(2100)]
    filters = {name: AttitudeKF(AttitudeKFSettings(tau=0.5)) for name in ("late", "refiltered", "informed")}
    for i, (rate, reading) in enumerate(inputs):
        if i == 2000:
            filters["late"].mark()
            filters["refiltered"].mark()
        if i == 2050:
            for kf in filters.values():
                kf.observe(0.0, math.radians(0.5) ** 2)
        for name, kf in filters.items():
            kf.update(rate, reading, DT, accel if name == "informed" and i >= 2000 else 0.0)
    filters["late"].refilter(0.0)
    filters["refiltered"].refilter(accel)
    assert filters["refiltered"].x.tolist() == filters["informed"].x.tolist()
    assert filters["refiltered"].P.tolist() == filters["informed"].P.tolist()
    bias_error = {name: math.degrees(abs(kf.bias - bias)) for name, kf in filters.items()}
    angle_error = {name: math.degrees(abs(kf.angle)) for name, kf in filters.items()}
    assert bias_error["refiltered"] < 0.02 and angle_error["refiltered"] < 0.1
    assert bias_error["late"] > 3 * bias_error["refiltered"] and angle_error["late"] > 3 * angle_error["refiltered"]


def test_a_mark_at_an_epoch_samples_ago_re_filters_from_that_epoch():
    """A fix processed 20 samples after its epoch marks there (mark(after=20)); the next, 100 samples later and
    processed 20 after its own epoch, corrects the 80 samples between the epochs by one acceleration and the 20 after
    by another: the same as a filter given both from the start."""
    rng = np.random.default_rng(9)
    inputs = [(math.radians(0.05) * rng.standard_normal(), math.radians(0.1) * rng.standard_normal())
              for _ in range(1000)]
    late, informed = AttitudeKF(AttitudeKFSettings(tau=0.5)), AttitudeKF(AttitudeKFSettings(tau=0.5))
    before, after = 0.3 / 9.81, -0.1 / 9.81
    for i, (rate, reading) in enumerate(inputs):
        if i == 900:
            late.mark()
        if i == 920:
            late.mark(after=20)
        late.update(rate, reading, DT)
        informed.update(rate, reading, DT, before if 900 <= i < 980 else after if i >= 980 else 0.0)
    late.refilter(before, 20, after)
    assert late.x.tolist() == informed.x.tolist() and late.P.tolist() == informed.P.tolist()


def test_the_float_filter_equals_its_matrix_form():
    """AttitudeKF's float steps against kalman.predict / kalman.update_state on the same inputs."""
    from agnav_fusion import kalman
    rng = np.random.default_rng(8)
    s = AttitudeKFSettings(identify_tau=False, tau=0.7)
    kf = AttitudeKF(s)
    kf.update(0.0, 0.01, DT)
    for i in range(500):
        rate, incl = rng.normal(0.0, 0.05), (rng.normal(0.0, 0.02) if i % 3 else None)
        x, P = kf.x, kf.P
        a = 1.0 - math.exp(-DT / s.tau)
        F = np.array([[1.0, -DT, 0.0], [0.0, 1.0, 0.0], [a, 0.0, 1.0 - a]])
        x, P = kalman.predict(x, P, F, np.diag([s.gyro_noise ** 2 * DT, s.bias_walk ** 2 * DT, 0.0]))
        x[0] += rate * DT
        if incl is not None:
            r = s.incl_noise ** 2 + (s.scale_sigma * incl) ** 2 * 2.0 * s.tau / DT
            x, P, _ = kalman.update_state(x, P, 2, incl, r, s.gate)
        kf.update(rate, incl, DT)
        np.testing.assert_allclose(kf.x, x, rtol=0, atol=1e-12)
        np.testing.assert_allclose(kf.P, P, rtol=0, atol=1e-15)


def test_a_spread_bias_change_adds_its_variance_evenly_and_survives_a_refilter():
    """add_bias_variance(var, spread): the bias variance grows by var / spread per s for spread s, not at once, until
    end_bias_change(); a refilter from a mark before it replays that growth (bit for bit with a filter told at the
    mark)."""
    s = AttitudeKFSettings(identify_tau=False, tau=0.5, bias_walk=0.0)
    at_once, spread = AttitudeKF(s), AttitudeKF(s)
    for kf in (at_once, spread):
        kf.update(0.0, 0.0, DT)
        kf.checkpoint()
    p11 = spread.P[1, 1]
    at_once.add_bias_variance(1e-4)
    spread.add_bias_variance(1e-4, spread=2.0)
    assert at_once.P[1, 1] == pytest.approx(p11 + 1e-4) and spread.P[1, 1] == p11
    for kf in (at_once, spread):
        for _ in range(100):  # 1 s without readings: nothing observes the bias
            kf.update(0.0, None, DT)
    assert spread.P[1, 1] == pytest.approx(p11 + 0.5e-4, rel=1e-9)
    for _ in range(150):
        spread.update(0.0, None, DT)
    assert spread.P[1, 1] == pytest.approx(at_once.P[1, 1], rel=1e-9)  # all of it after 2 s, no more
    spread.add_bias_variance(1e-4, spread=2.0)
    for _ in range(50):
        spread.update(0.0, None, DT)
    spread.end_bias_change()  # standing again: the change stops
    for _ in range(100):
        spread.update(0.0, None, DT)
    assert spread.P[1, 1] == pytest.approx(at_once.P[1, 1] + 0.25e-4, rel=1e-9)
    rng = np.random.default_rng(3)
    inputs = [(rng.normal(0.0, 1e-3), rng.normal(0.0, 1e-3)) for _ in range(300)]
    late, told = AttitudeKF(s), AttitudeKF(s)
    for i, (rate, reading) in enumerate(inputs):
        if i == 100:
            late.mark()
            told.add_bias_variance(1e-4, spread=1.0)
        if i == 150:
            late.add_bias_variance(1e-4, spread=1.0)  # a start seen at a later fix: from the mark
        late.update(rate, reading, DT)
        told.update(rate, reading, DT)
    late.refilter(0.0)
    assert late.x.tolist() == told.x.tolist() and late.P.tolist() == told.P.tolist()
