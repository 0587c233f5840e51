"""Shared synthetic straight run for the heading-fusion tests: true heading, drifting gyro, noisy GDS."""
import math
from dataclasses import dataclass

import numpy as np


@dataclass
class StraightRun:
    t: np.ndarray
    dt: float
    true: np.ndarray        # rad, clockwise from north
    rate: np.ndarray        # true rate rad/s
    gyro_rate: np.ndarray   # measured rate = true + bias + noise
    gyro: np.ndarray        # integrated gyro heading (starts with an offset)
    gds: np.ndarray         # true + white noise (+ optional slow spatial variation)
    bias: float


def straight_run(seed=0, duration=120.0, dt=0.02, bias_deg_s=0.1, gds_sigma_deg=0.42, gyro_sigma_deg_s=0.05,
                 offset_deg=2.0, spatial_deg=0.0):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, dt)
    true = math.radians(40.0) + np.radians(1.5 * np.sin(2 * np.pi * t / 25.0) + 0.5 * np.sin(2 * np.pi * t / 7.0))
    rate = np.gradient(true, dt)
    bias = math.radians(bias_deg_s)
    gyro_rate = rate + bias + rng.normal(0.0, math.radians(gyro_sigma_deg_s), t.size)
    gyro = true[0] + math.radians(offset_deg) + np.concatenate([[0.0], np.cumsum(gyro_rate[:-1] * dt)])
    gds = true + rng.normal(0.0, math.radians(gds_sigma_deg), t.size) + math.radians(spatial_deg) * np.sin(
        2 * np.pi * t / duration)
    return StraightRun(t, dt, true, rate, gyro_rate, gyro, gds, bias)


def rms_deg(err):
    err = np.angle(np.exp(1j * np.asarray(err)))
    return math.degrees(float(np.sqrt(np.mean(err**2))))
