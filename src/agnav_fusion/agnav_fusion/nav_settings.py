"""Navigation sensor module types (SPEC §6.3): settings, the REP-103 output NavState, the IMU history sample, and
small per-sample helpers shared by the module and its estimators."""
import bisect
import math
from dataclasses import dataclass, field

import numpy as np
from agnav_common.frames import cross  # noqa: F401 (the estimators' per-sample cross product)

from agnav_fusion.attitude_kf import AttitudeKFSettings
from agnav_fusion.attitude_lsm import AttitudeLSMSettings
from agnav_fusion.dead_reckoning import DeadReckoningSettings
from agnav_fusion.front_end import InputGuardSettings
from agnav_fusion.gnss_heading_lsm import GnssGyroHeadingSettings
from agnav_fusion.nav_ekf import NavEKFSettings

GRAVITY = 9.80665
MOUNTS = ("lever_flu", "incl_lever_flu")  # settings that come from TF, not from parameters


@dataclass
class NavSensorModuleSettings:
    estimator: str = "agnav"                  # "agnav" or "thesis"
    lever_flu: tuple = (0.0, 0.0, 0.0)        # m, base_link -> gnss_link translation (from TF)
    roll_lsm: AttitudeLSMSettings = field(default_factory=lambda: AttitudeLSMSettings(window=270))
    pitch_lsm: AttitudeLSMSettings = field(default_factory=lambda: AttitudeLSMSettings(window=200))
    roll_kf: AttitudeKFSettings = field(default_factory=AttitudeKFSettings)
    # pitch: the start/stop acceleration left after compensation (from 1 Hz GNSS speed) is a coloured error of
    # seconds, so the pitch inclinometer is trusted less and averaged longer (tuned on seeds 4-5; bench: 1-3); the
    # same error makes its identified time constant less sure (campaign tuning seeds < 40)
    pitch_kf: AttitudeKFSettings = field(default_factory=lambda: AttitudeKFSettings(bias_walk=2.0e-4, incl_noise=0.03,
                                                                                    tau_rel_identified=0.3))
    heading: GnssGyroHeadingSettings = field(default_factory=GnssGyroHeadingSettings)
    dead_reckoning: DeadReckoningSettings = field(default_factory=DeadReckoningSettings)
    ekf: NavEKFSettings = field(default_factory=NavEKFSettings)
    incl_lever_flu: tuple = (0.0, 0.0, 0.0)   # m, base_link -> inclinometer_link translation (from TF)
    incl_zero_deg: tuple = (0.0, 0.0)         # deg, tilt (roll, pitch) read at true level (agnav calibrate tilt)
    accel_compensation: bool = True           # agnav: remove the modelled kinematic acceleration from the inclinometer
    use_gnss_velocity: bool = True            # agnav: also fuse /gnss/vel (course and speed)
    velocity_sigma: float = 0.05              # m/s, 1-sigma per axis of GNSS velocity
    gate_chi2: float = 13.8                   # squared Mahalanobis gate, 2 dof 99.9 %
    gnss_reset_time: float = 30.0             # s of fixes refused by the gate, then the position restarts from them
    diverged_time: float = 2.0                # s of refused fixes that all continue the last accepted one's track
    #                                           smoothly: the estimate diverged, not the receiver (both restart)
    track_max_accel: float = 1.0              # m/s^2, velocity change between fixes of a smooth receiver track
    heading_init_speed: float = 0.3           # m/s: slower receiver courses are no provisional heading; driving
    #                                           backwards this fast (beyond 3 sigma) restarts the heading (agnav)
    heading_init_distance: float = 3.0        # m, shortest chord of fixes that initialises the heading
    chord_max_turn: float = 0.35              # rad of gyro turn a chord may span (agnav)
    heading_valid_sigma: float = 0.05         # rad: the heading is published once known this well (agnav)
    heading_lost_sigma: float = 0.3           # rad: ... and until known worse than this (gaps, outages widen it)
    chord_max_sigma: float = 0.15             # rad: a chord this good starts the heading, the fixes refine it (agnav)
    stationary_speed: float = 0.05            # m/s: slower fixes mark the vehicle still (yaw rate zero: gyro bias)
    still_baseline: float = 1.0               # s, fixes this far apart give that speed without a receiver velocity
    standstill_sigma: float = 0.005           # m/s (and m/s^2): speed and acceleration of a vehicle at rest
    wheel_speed_sigma: float = 0.05           # m/s, floor of a wheel/radar speed's noise (agnav; /wheel/odometry)
    wheel_slip_sigma: float = 0.03            # of the speed: slip changes about the EKF's learnt wheel scale
    wheel_timeout: float = 0.5                # s, an older wheel speed is not fused
    lever_rate_window: float = 0.1            # s of body rates averaged (centred) for the antenna lever velocity
    lever_rate_sigma: float = 0.02            # rad/s, error of that rate at the receiver's velocity epoch (sway)
    lever_accel_tau: float = 0.05             # s, low-pass of the angular acceleration (gyro differences) in the
    #                                           tilt sensor's lever-arm acceleration: sway passes, differentiated noise not
    path_pitch_speed: float = 1.0             # m/s: faster, the GNSS climb over the ground speed is the pitch (agnav)
    path_pitch_sigma: float = 0.015           # rad, body pitch off the path's over 1 s of fixes (sway, terrain waves)
    path_pitch_max_slow: float = 0.05         # m, fix differences give the climb only while the fixes' slow error
    #                                           sigma is below this (RTK fixed): a float or DGPS wander moves many
    #                                           successive differences alike
    fix_accel_gain: float = 0.3               # smoothing of the fixes' speed change (inclinometer compensation)
    max_accel: float = 3.0                    # m/s^2, along-track accelerometer reading clipped (bumps) (agnav)
    still_rate_sigma: float = 0.01            # rad/s per IMU sample of a still gyro (ENV-05F 0.25 deg/s; 2.4x de-lagged)
    motion_bias_sigma: float = 0.003          # rad/s, gyro bias change once moving (SPEC §11.4 motion biases)
    motion_bias_spread: float = 10.0          # s, the tilt gyros' motion biases build up over the first seconds of a
    #                                           drive (vibration): that much variance per s, not all at the start fix
    start_accel_sigma: float = 0.5            # m/s^2, acceleration of a start, unknown to the A state (agnav)
    tilt_revert_sigma: float = 3.0            # GNSS speed off the speed model by more (sigmas): the acceleration removed
    #                                           from the inclinometers since the last epoch was wrong; gyro-only since
    tilt_keep_sigma: float = 1.5              # within (sigmas): it was right, the gyro-only copies restart (agnav)
    history: float = 2.0                      # s of IMU history kept for GNSS latency
    incl_timeout: float = 0.5                 # s, older inclinometer data is stale (gyro-only attitude)
    untracked_tilt_sigma: float = 0.035       # rad, roll/pitch uncertainty while no tilt sensor reports (2°: field)
    gnss_timeout: float = 2.5                 # s without an accepted fix -> dead reckoning
    coast_margin: float = 0.5                 # s a fix may be late (latency, jitter): then the speed model
    #                                           coasts and forgets the acceleration the fixes confirmed
    max_dt: float = 0.5                       # s, a longer IMU gap is counted and bridged in steps of this length
    gap_periods: float = 3.0                  # IMU sample periods: a longer spacing is counted as a gap
    gap_rate_sigma: float = 0.1               # rad/s, unknown yaw-rate change across an IMU gap
    gap_accel_sigma: float = 0.5              # m/s^2, unknown acceleration across an IMU gap
    gnss_overdue_periods: float = 1.5         # fix periods without a fix: gnss_overdue (diagnostics)
    max_gap: float = 10.0                     # s, after a longer IMU gap the navigation solution restarts
    guard: InputGuardSettings = field(default_factory=InputGuardSettings)


@dataclass
class NavState:
    """Module output at one IMU epoch (REP-103)."""
    t: float
    position: np.ndarray      # map ENU of base_link
    rpy: np.ndarray           # roll, pitch, yaw
    pose_cov: np.ndarray      # 6x6 (x, y, z, roll, pitch, yaw)
    speed: float              # forward speed
    rates: np.ndarray         # bias-corrected body rates (FLU)
    twist_cov: np.ndarray     # 6x6 (vx, vy, vz, wx, wy, wz)
    heading_valid: bool
    position_valid: bool
    dead_reckoning: bool
    crab: float = 0.0         # rad, side-slip: course over ground = yaw - crab (REP-103, + sliding right)
    crab_var: float = math.inf  # rad^2 (inf: not estimated)


@dataclass
class Sample:
    t: float
    dt: float
    rate_cw: float            # yaw Euler rate, clockwise (thesis), rad/s
    body_rates: np.ndarray
    roll: float               # thesis roll / pitch (nose up) at this epoch
    pitch: float
    heading: float            # thesis heading estimate at this epoch
    raw_heading: float        # thesis: integrated raw yaw gyro
    nav: tuple                # agnav: (x, P) of the EKF; thesis: (xy, cov) of dead reckoning
    still: bool = False       # agnav: vehicle stationary (zero-yaw-rate update of the gyro bias)
    wheel: tuple = None       # agnav: (speed m/s, variance) of a wheel speed fused at this epoch
    accel: float = None       # agnav: along-track acceleration of base_link from the accelerometer (m/s^2)


def last_at(history, t):
    """Index of the last Sample of `history` (in time order) at or before t; -1 if none."""
    return bisect.bisect_right(history, t, key=lambda sample: sample.t) - 1


def euler_rates(body_rates, roll, pitch, yaw_q_offset=0.0):
    """REP-103 Euler-angle rates (roll, pitch, yaw)' from FLU body rates (p, q, r); the yaw rate's q plus
    yaw_q_offset (a y gyro bias correction that the tilt rates leave to their own filters)."""
    p, q, r = body_rates
    sr, cr = math.sin(roll), math.cos(roll)
    cp = max(math.cos(pitch), 1e-3)
    return (p + (q * sr + r * cr) * math.tan(pitch), q * cr - r * sr, ((q + yaw_q_offset) * sr + r * cr) / cp)
