"""Settings and solution of the GNSS/INS EKF (`ekf.InsEkf`, SPEC §7)."""
import math
from dataclasses import dataclass, field

import numpy as np

from . import error_model as em


@dataclass
class InsEkfSettings:
    """Filter parameters ([IMPL] values for a consumer MEMS IMU; SPEC gives none for §7)."""

    error: em.ErrorModelSettings = field(default_factory=em.ErrorModelSettings)
    lever_gnss_frd: tuple = (0.0, 0.0, 0.0)    # IMU -> antenna in body FRD [m]
    initial_heading: float = 0.0               # best guess, clockwise from north [rad]
    initial_heading_sigma: float = math.inf    # inf: unknown heading (γ/β span the full circle)
    tilt_sigma: float = math.radians(2.0)      # roll/pitch from accelerometers while driving
    velocity_sigma: float = 0.1                # initial velocity (side-slip, speed noise) [m/s]
    accel_bias_sigma0: float = 0.1             # [m/s^2]
    gyro_bias_sigma0: float = math.radians(0.2)  # [rad/s]
    level_window: float = 1.0                  # accelerometer averaging for roll/pitch [s]
    align_speed: float = 0.5                   # moving: initial velocity along the body x axis [m/s]
    aligned_heading_sigma: float = math.radians(1.0)
    gate_probability: float = 0.9999           # chi-square innovation gate
    reinit_after: float = 10.0                 # reinitialise after this long of rejected GNSS [s]
    history: float = 2.0                       # latency compensation window [s]
    gap_accel_sigma: float = 1.0               # unknown acceleration while IMU samples are missing [m/s^2]
    gap_rate_sigma: float = 0.1                # unknown rate (e.g. a turn begun) over an IMU gap [rad/s]
    max_gnss_lead: float = 5.0                 # GNSS epochs further ahead of the IMU time are rejected [s]
    covariance_interval: float = 0.05          # P propagated at this period (Φ from the latest F) [s];
                                               # 0 = every IMU sample; always brought current before updates
    gnss_correlated_fraction: float = 0.5      # part of a fix's variance that drifts slowly (corrections, multipath):
                                               # fused as white, it is not averaged down, so the latest fix's share
                                               # is added to the published position covariance


@dataclass
class NavSolution:
    """IMU-point solution: NED velocity, heading clockwise from north, FRD rates, ENU covariances."""

    t: float
    lat: float
    lon: float
    h: float
    v_ned: np.ndarray
    roll: float
    pitch: float
    heading: float
    omega_b: np.ndarray
    c_b_ned: np.ndarray
    pos_cov_enu: np.ndarray
    vel_cov_enu: np.ndarray
    att_var: np.ndarray          # roll, pitch, heading [rad^2]
    gyro_bias_var: np.ndarray    # FRD gyro bias estimate variances [(rad/s)^2]
