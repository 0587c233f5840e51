"""Settings and solution of the GNSS/INS EKF (`ekf.InsEkf`, SPEC §7)."""
import math
from dataclasses import dataclass, field

import numpy as np

from . import error_model as em
from .constraints import NhcSettings, SpeedHoldSettings, WheelSettings
from .gnss_bias import GnssBiasSettings
from .standstill import StandstillSettings


@dataclass
class InsEkfSettings:
    """Filter parameters ([IMPL] values for a consumer MEMS IMU; SPEC gives none for §7)."""

    error: em.ErrorModelSettings = field(default_factory=em.ErrorModelSettings)
    lever_gnss_frd: tuple = (0.0, 0.0, 0.0)    # IMU -> antenna in body FRD [m]
    lever_base_frd: tuple = (0.0, 0.0, 0.0)    # IMU -> base_link (non-holonomic point) in body FRD [m]
    mount_yaw_sigma: float = math.radians(0.5)  # rad, IMU yaw mount error beyond TF (bracket squared to the vehicle
                                               # axis by eye, +-1 deg): estimated (the lever arms and the NHC head
                                               # the vehicle, the accelerometers the IMU); this is its initial sigma
    nhc: NhcSettings = field(default_factory=NhcSettings)
    wheel: WheelSettings = field(default_factory=WheelSettings)   # wheel or radar speed, when present
    speed_hold: SpeedHoldSettings = field(default_factory=SpeedHoldSettings)  # in outages: the speed is kept
    standstill: StandstillSettings = field(default_factory=StandstillSettings)  # gyro bias before the alignment
    gnss_bias: GnssBiasSettings = field(default_factory=GnssBiasSettings)  # the receiver's slow error as states
    initial_heading: float = 0.0               # best guess, clockwise from north [rad]
    initial_heading_sigma: float = math.inf    # inf: unknown heading (γ/β span the full circle)
    tilt_sigma: float = math.radians(2.0)      # rad, initial roll/pitch (the standing level, else accelerometers
                                               # while driving)
    velocity_sigma: float = 0.1                # m/s, initial velocity (side-slip, speed noise)
    accel_bias_sigma0: float = 0.1             # m/s^2, initial accelerometer bias
    gyro_bias_sigma0: float = math.radians(0.2)  # rad/s, initial gyro bias
    level_window: float = 1.0                  # s of accelerometer averaging for the initial roll/pitch
    align_speed: float = 0.5                   # m/s, moving: initial velocity along the body x axis
    align_from_course: bool = True             # unknown heading: start from the GNSS course (else the guess)
    align_course_sigma: float = math.radians(5.0)    # rad, course of a Doppler velocity vs heading (crab, noise)
    align_fix_course_sigma: float = math.radians(30.0)  # rad, course of a fix-difference velocity (lags in turns)
    aligned_heading_sigma: float = math.radians(1.0)  # rad, heading sigma below which the filter is aligned
    gate_probability: float = 0.9999           # chi-square innovation gate
    reinit_after: float = 30.0                 # s of rejected GNSS, then the filter reinitialises (nsm: gnss_reset_time)
    history: float = 2.0                       # s, latency compensation window
    gap_accel_sigma: float = 1.0               # m/s^2, unknown acceleration while IMU samples are missing
    gap_rate_sigma: float = 0.1                # rad/s, unknown rate (e.g. a turn begun) over an IMU gap
    max_gnss_lead: float = 5.0                 # s, GNSS epochs further ahead of the IMU time are rejected
    covariance_interval: float = 0.05          # s, P propagated at this period (Φ from the latest F);
                                               # 0 = every IMU sample; always brought current before updates


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
    crab: float = 0.0            # rad, base_link side slip (+ moving to the right of the body x axis)
    crab_var: float = math.inf   # rad^2 (inf: not estimated)
