"""Kise LSM (SPEC eq 4.1-4.11) and the drift LSM driven by it (eq 4.12-4.17) on synthetic tracks."""
import math

import numpy as np

from agnav_fusion.drift_lsm import wrap
from agnav_fusion.gnss_heading_lsm import GnssGyroHeading, KiseLSM

DEG = math.pi / 180.0


def test_kise_recovers_heading_offset_on_a_noiseless_straight_track():
    kise = KiseLSM()
    true_heading, offset, speed = 0.7, 0.25, 0.5  # gyro heading = true - offset  => b = +offset
    for k in range(12):
        x, y = k * speed * math.sin(true_heading), k * speed * math.cos(true_heading)
        b = kise.update(x, y, speed, true_heading - offset, 1.0)
    assert abs(b - offset) < 1e-12


def test_kise_on_an_arc_matches_trapezoidal_model():
    kise = KiseLSM()
    speed, rate, offset = 1.0, 0.05, -0.4
    heading, x, y = 1.0, 0.0, 0.0
    kise.update(x, y, speed, heading - offset, 1.0)
    for _ in range(15):
        h0, heading = heading, heading + rate
        x += 0.5 * speed * (math.sin(h0) + math.sin(heading))  # exactly (4.1)-(4.2)
        y += 0.5 * speed * (math.cos(h0) + math.cos(heading))
        b = kise.update(x, y, speed, heading - offset, 1.0)
    assert abs(b - offset) < 1e-9


def run_drifting_gyro(seed=5, seconds=300.0, drift=0.02 * DEG, sigma=0.015):
    """Gentle S-curve at 0.5 m/s; yaw gyro with constant drift; GNSS 1 Hz with white noise sigma (m)."""
    rng = np.random.default_rng(seed)
    dt, n_per = 0.01, 100
    est = GnssGyroHeading()
    heading, x, y = 0.3, 0.0, 0.0
    errs, raw = [], []
    for k in range(int(seconds / dt)):
        rate = 0.02 * math.sin(2 * math.pi * k * dt / 60.0)
        heading += rate * dt
        x += 0.5 * math.sin(heading) * dt
        y += 0.5 * math.cos(heading) * dt
        est.on_gyro(rate + drift + rng.normal(0, 0.002), dt)
        if k % n_per == n_per - 1:
            est.on_fix(x + rng.normal(0, sigma), y + rng.normal(0, sigma), 0.5, est.raw_heading, est.heading, 1.0)
        if est.heading is not None and k * dt > 60:
            errs.append(wrap(est.heading - heading))
            raw.append(wrap(0.3 + est.raw_heading - heading))
    return np.array(errs), np.array(raw), est


def test_kise_plus_drift_lsm_beats_raw_gyro_and_estimates_drift():
    errs, raw, est = run_drifting_gyro()
    rms = float(np.sqrt(np.mean(errs ** 2)))
    assert rms < 1.0 * DEG
    assert rms < 0.3 * float(np.sqrt(np.mean(raw ** 2)))
    assert abs(est.drift + 0.02 * DEG) < 0.01 * DEG
