"""Navigation sensor module data flow (SPEC §6.3, Fig. 5.5): attitude -> GNSS tilt correction -> heading ->
position at the IMU rate, with GNSS latency compensation, input guarding and covariances.

The module's boundary is REP-103 (ENU map, FLU base_link, yaw CCW from east, pitch nose down); the cores
inside run in the thesis' conventions (heading clockwise from north, pitch nose up; SPEC §2.3).
Estimators: "thesis" = attitude LSM (5.1-5.11) + Kise/drift LSM (4.1-4.17) + dead reckoning (5.12-5.13);
"agnav" = attitude KF (lag + acceleration model) + navigation EKF (nav_ekf.py). Both tilt-correct (4.18-4.24).
"""
import math
from collections import Counter, deque
from dataclasses import dataclass, field

import numpy as np

from agnav_fusion import tilt_correction
from agnav_fusion.attitude_kf import AttitudeKF, AttitudeKFSettings
from agnav_fusion.attitude_lsm import AttitudeLSM, AttitudeLSMSettings
from agnav_fusion.dead_reckoning import DeadReckoning, DeadReckoningSettings
from agnav_fusion.front_end import InputGuard, InputGuardSettings
from agnav_fusion.gnss_heading_lsm import GnssGyroHeading, GnssGyroHeadingSettings
from agnav_fusion.nav_ekf import IB, IPHI, IV, IA, NavEKF, NavEKFSettings

GRAVITY = 9.80665
MOUNTS = ("lever_flu", "incl_lever_flu")  # settings that come from TF, not from parameters
DIAG6 = np.diag_indices(6)
POSE_XY_YAW, EKF_XY_PHI = np.ix_([0, 1, 5], [0, 1, 5]), np.ix_([0, 1, IPHI], [0, 1, IPHI])
YAW_SIGN = np.array([[1, 1, -1], [1, 1, -1], [-1, -1, 1]])


@dataclass
class NavSensorModuleSettings:
    estimator: str = "agnav"                  # "agnav" or "thesis"
    lever_flu: tuple = (0.0, 0.0, 0.0)        # m, base_link -> gnss_link translation (from TF)
    roll_lsm: AttitudeLSMSettings = field(default_factory=lambda: AttitudeLSMSettings(window=270))
    pitch_lsm: AttitudeLSMSettings = field(default_factory=lambda: AttitudeLSMSettings(window=200))
    roll_kf: AttitudeKFSettings = field(default_factory=AttitudeKFSettings)
    # pitch: the start/stop acceleration left after compensation (from 1 Hz GNSS speed) is a coloured error of
    # seconds, so the pitch inclinometer is trusted less and averaged longer (tuned on seeds 4-5; bench: 1-3)
    pitch_kf: AttitudeKFSettings = field(default_factory=lambda: AttitudeKFSettings(bias_walk=2.0e-4,
                                                                                    incl_noise=0.03))
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
    heading_init_speed: float = 0.3           # m/s of GNSS speed before the absolute heading is initialised
    heading_init_distance: float = 3.0        # m of chord between moving fixes that initialises the heading
    stationary_speed: float = 0.05            # m/s: slower fixes mark the vehicle still (yaw rate zero: gyro bias)
    standstill_sigma: float = 0.005           # m/s (and m/s^2): speed and acceleration of a vehicle at rest
    wheel_speed_sigma: float = 0.05           # m/s, floor of a wheel/radar speed's noise (agnav; /wheel/odometry)
    wheel_slip_sigma: float = 0.03            # of the speed: slip and rolling-radius error of a wheel speed
    wheel_timeout: float = 0.5                # s, an older wheel speed is not fused
    lever_rate_window: float = 0.2            # s of body rates averaged for the antenna lever-arm velocity
    still_rate_sigma: float = 0.01            # rad/s per IMU sample of a still gyro (ENV-05F 0.25 deg/s, 10 Hz band)
    motion_bias_sigma: float = 0.003          # rad/s, yaw-gyro bias change once moving (SPEC §11.4 motion biases)
    history: float = 2.0                      # s of IMU history kept for GNSS latency
    incl_timeout: float = 0.5                 # s, older inclinometer data is stale (gyro-only attitude)
    untracked_tilt_sigma: float = 0.035       # rad, roll/pitch uncertainty while no tilt sensor reports (2°: field)
    gnss_timeout: float = 2.5                 # s without an accepted fix -> dead reckoning
    max_dt: float = 0.5                       # s, a longer IMU gap is counted and bridged in steps of this length
    gap_periods: float = 3.0                  # IMU sample periods: a longer spacing is counted as a gap
    gap_rate_sigma: float = 0.05              # rad/s, unknown yaw-rate change across an IMU gap
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


@dataclass
class _Sample:
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


def cross(a, b):
    """a x b of 3-vectors (np.cross costs ~20x more on this per-sample path)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def euler_rates(body_rates, roll, pitch):
    """REP-103 Euler-angle rates (roll, pitch, yaw)' from FLU body rates (p, q, r)."""
    p, q, r = body_rates
    sr, cr = math.sin(roll), math.cos(roll)
    cp = max(math.cos(pitch), 1e-3)
    return (p + (q * sr + r * cr) * math.tan(pitch), q * cr - r * sr, (q * sr + r * cr) / cp)


class NavSensorModule:
    """Feed imu() at the IMU rate, inclinometer() and gnss() whenever they arrive; read state()."""

    def __init__(self, settings=None):
        self.settings = s = settings or NavSensorModuleSettings()
        if s.estimator not in ("agnav", "thesis"):
            raise ValueError(f"unknown estimator {s.estimator!r}")
        self.lever = tilt_correction.lever_from_flu(s.lever_flu)
        self.guard = InputGuard(s.guard)
        self._history = deque()
        self._start()

    @property
    def counters(self):
        """Totals of every input and rejection event since the start (guard.recent(): the last seconds only)."""
        return Counter(self.guard.totals)

    def _start(self):
        """(Re)start the estimators: at construction and after an IMU gap longer than max_gap."""
        s = self.settings
        if s.estimator == "agnav":
            self.roll_filter, self.pitch_filter = AttitudeKF(s.roll_kf), AttitudeKF(s.pitch_kf)
            self.ekf = NavEKF(s.ekf)
        else:
            self.roll_filter, self.pitch_filter = AttitudeLSM(s.roll_lsm), AttitudeLSM(s.pitch_lsm)
            self.heading_lsm = GnssGyroHeading(s.heading)
            self.dr = DeadReckoning(s.dead_reckoning)
        self._history.clear()
        self._imu_period = None                    # s, running mean IMU sample spacing
        self._gnss_epoch = (None, None)            # (latest fix epoch, running mean fix period)
        self._gnss_arrival, self._gnss_overdue = (0.0, None), False
        self._pending_gnss = []
        self._incl = None            # (t, roll, pitch) REP-103
        self._wheel = None           # agnav: latest wheel speed (t, speed, variance) not yet fused
        self._last_accepted_t = -math.inf
        self._rejected_since = None  # epoch of the first of the fixes the gate refuses in a row
        self._raw_heading = 0.0      # relative yaw before the absolute heading exists (agnav)
        self._fix = None             # latest accepted corrected fix (t, xyz, cov)
        self._heading_known = False  # agnav: absolute heading initialised from the GNSS course
        self._chord_start = None     # agnav: (xy, relative heading) of the first moving fix before initialisation
        self._still = False          # agnav: the latest fix says the vehicle stands still
        self._speed = 0.0            # thesis: travel speed V for dead reckoning
        self._state = None

    def set_mounts(self, lever_flu, incl_lever_flu=None):
        """Update the base_link -> gnss_link (and inclinometer_link) translations, e.g. when TF arrives."""
        self.settings.lever_flu = tuple(float(v) for v in lever_flu)
        self.lever = tilt_correction.lever_from_flu(lever_flu)
        if incl_lever_flu is not None:
            self.settings.incl_lever_flu = tuple(float(v) for v in incl_lever_flu)

    # ---- inputs -------------------------------------------------------------------------------------
    def inclinometer(self, t, roll, pitch):
        """Raw inclinometer reading (REP-103 rad) stamped at its epoch."""
        if not self.guard.accept("incl", t, roll, pitch):
            return False
        zero_roll, zero_pitch = (math.radians(v) for v in self.settings.incl_zero_deg)
        self._incl = (t, roll - zero_roll, pitch - zero_pitch)
        return True

    def gnss(self, t, antenna_enu, cov, vel_enu=None, vel_var=None):
        """Antenna fix (map ENU m, 3x3 covariance m^2, optional ENU velocity m/s with its per-axis horizontal
        variance m^2/s^2, at least velocity_sigma^2; default velocity_sigma^2) stamped at its epoch. A bad velocity
        is dropped (counted) and the fix used without it."""
        ref = self._history[-1].t if self._history else None
        if not self.guard.accept("gnss", t, antenna_enu, ref=ref):
            return False
        if self._history and t < self._history[0].t:
            self.guard.count("gnss_too_old")
            return False
        cov = self.guard.fix_covariance(cov)
        if cov is None:
            return False
        self.guard.count("gnss")
        self._fix_arrived(t)
        if vel_enu is not None:
            vel_var = self.guard.velocity_variance(vel_var, self.settings.velocity_sigma ** 2)
            if vel_var is None or not self.guard.accept("vel", t, vel_enu):
                vel_enu = None
        self._pending_gnss.append((t, np.asarray(antenna_enu, float), cov,
                                   None if vel_enu is None else np.asarray(vel_enu, float), vel_var))
        self._drain_gnss()
        return True

    def wheel_speed(self, t, speed, var=None):
        """Forward ground speed (m/s, negative reversing) of base_link from wheel odometry or a radar, with its
        variance (None: wheel_speed_sigma), stamped at its epoch; fused by the agnav EKF at the next IMU sample."""
        if not self.guard.accept("wheel", t, speed, 0.0 if var is None else var):
            return False
        self.guard.count("wheel")
        s = self.settings
        var = max(var or 0.0, s.wheel_speed_sigma ** 2) + (s.wheel_slip_sigma * speed) ** 2
        self._wheel = (t, float(speed), var)
        return True

    def imu(self, t, gyro_flu):
        """Body (base_link FLU) gyro rates (rad/s) at epoch t; advances the module. Returns the new NavState."""
        if not self.guard.accept("imu", t, gyro_flu):
            return None
        self.guard.count("imu")
        s = self.settings
        dt = t - self._history[-1].t if self._history else 0.0
        if dt > s.max_gap:
            self.guard.count("imu_gap_restart")
            self._start()
            dt = 0.0
        elif dt > s.max_dt or (self._imu_period and dt > s.gap_periods * self._imu_period):
            self.guard.count("imu_gap")
        elif dt > 0:
            self._imu_period = dt if self._imu_period is None else self._imu_period + 0.01 * (dt - self._imu_period)
        self._check_gnss_overdue(t)
        self._step(t, dt, np.asarray(gyro_flu, dtype=float))
        self._drain_gnss()
        self._state = self._output()
        return self._state

    def state(self):
        return self._state

    def _check_gnss_overdue(self, t):
        """Count one gnss_overdue event when no fix has arrived for gnss_overdue_periods fix periods."""
        last, period = self._gnss_arrival
        if period and not self._gnss_overdue and t - last > self.settings.gnss_overdue_periods * period:
            self._gnss_overdue = True
            self.guard.count("gnss_overdue")

    def _fix_arrived(self, t_fix):
        """A fix arrived at IMU time now: its epoch spacing sets the fix period the overdue check expects."""
        now = max(self._history[-1].t, t_fix) if self._history else t_fix
        last_epoch, period = self._gnss_epoch
        if last_epoch is not None and t_fix > last_epoch:
            step = t_fix - last_epoch
            period = step if period is None else period + 0.1 * (min(step, 2 * period) - period)
        self._gnss_epoch = (t_fix, period)
        self._gnss_arrival = (now, period)
        self._gnss_overdue = False

    # ---- per-sample processing -----------------------------------------------------------------------
    def _step(self, t, dt, gyro):
        s = self.settings
        prev = self._history[-1] if self._history else None
        roll0, pitch0 = (prev.roll, prev.pitch) if prev else (0.0, 0.0)
        if s.estimator == "agnav":
            droll, dpitch, dyaw = euler_rates(gyro, roll0, -pitch0)
        else:  # the thesis treats each axis independently (SPEC §6.2 pitfall)
            droll, dpitch, dyaw = gyro
        incl = self._incl if self._incl and t - self._incl[0] <= s.incl_timeout else None
        self._incl = None if incl else self._incl
        roll_incl = None if incl is None else incl[1]
        pitch_incl = None if incl is None else -incl[2]
        rate_cw = -dyaw
        wheel = None
        if s.estimator == "agnav":
            acc = self._kinematic_acceleration(gyro, prev, dt) if s.accel_compensation else np.zeros(3)
            # a pendulum reads roll + a_y/g and (REP-103) pitch - a_x/g, i.e. thesis nose-up pitch + a_x/g
            roll = self.roll_filter.update(droll, roll_incl, dt, acc[1] / GRAVITY)
            pitch = self.pitch_filter.update(-dpitch, pitch_incl, dt, acc[0] / GRAVITY)
            self._raw_heading += rate_cw * dt
            wheel = self._wheel[1:] if self._wheel and 0 <= t - self._wheel[0] <= s.wheel_timeout else None
            self._wheel = None if wheel else self._wheel
            if self.ekf.x is not None:
                self._propagate(rate_cw, dt, self._still, wheel)
                heading, nav = self.ekf.x[IPHI], (self.ekf.x.copy(), self.ekf.P.copy())
            else:
                heading, nav = self._raw_heading, None
        else:
            roll = self.roll_filter.update(droll, roll_incl, dt)
            pitch = self.pitch_filter.update(-dpitch, pitch_incl, dt)
            heading = self.heading_lsm.on_gyro(rate_cw, dt)
            heading = self.heading_lsm.raw_heading if heading is None else heading
            nav = None
            if self.dr.xy is not None:
                xy, cov = self.dr.step(heading, self._speed, dt)
                nav = (xy.copy(), cov.copy())
        roll = 0.0 if roll is None else roll
        pitch = 0.0 if pitch is None else pitch
        raw = self._raw_heading if s.estimator == "agnav" else self.heading_lsm.raw_heading
        self._history.append(_Sample(t, dt, rate_cw, gyro, roll, pitch, heading, raw, nav, self._still, wheel))
        while self._history[0].t < t - s.history:
            self._history.popleft()

    def _propagate(self, rate_cw, dt, still, wheel=None):
        """EKF prediction with the yaw rate; standing still, the gyro reading is its bias (zero-rate update);
        a wheel speed (speed, variance) measures V. An IMU gap is bridged in steps of max_dt with the yaw rate and
        acceleration it may have hidden added as noise."""
        s = self.settings
        if dt > s.max_dt:
            n = math.ceil(dt / s.max_dt)
            for _ in range(n):
                self.ekf.P[IPHI, IPHI] += (s.gap_rate_sigma * dt) ** 2 / n
                self.ekf.P[IV, IV] += (s.gap_accel_sigma * dt) ** 2 / n
                self.ekf.predict(rate_cw, dt / n)
        else:
            self.ekf.predict(rate_cw, dt)
        if still:
            y, S, H, R = self.ekf.zero_rate_innovation(rate_cw, self.settings.still_rate_sigma ** 2)
            self.ekf.update(y, S, H, R)
        if wheel is not None:
            self._fuse(self.ekf.speed_innovation(*wheel), counter="wheel_gated")

    def _kinematic_acceleration(self, gyro, prev, dt):
        """Body (FLU) acceleration of the inclinometer: forward A, centripetal V*wz, and the lever-arm terms
        alpha x r + w x (w x r) (alpha from gyro differences; the inclinometer lag filters its noise)."""
        speed, accel = (self.ekf.x[IV], self.ekf.x[IA]) if self.ekf.x is not None else (0.0, 0.0)
        r = self.settings.incl_lever_flu
        alpha = (gyro - prev.body_rates) / dt if prev is not None and dt > 0 else np.zeros(3)
        return np.array([accel, speed * gyro[2], 0.0]) + cross(alpha, r) + cross(gyro, cross(gyro, r))

    def _drain_gnss(self):
        if not self._history:
            return
        now = self._history[-1].t
        ready = [g for g in self._pending_gnss if g[0] <= now]
        self._pending_gnss = [g for g in self._pending_gnss if g[0] > now]
        for fix in ready:
            self._process_fix(*fix)

    # ---- GNSS fix at its epoch ----------------------------------------------------------------------------
    def _process_fix(self, t, antenna, cov, vel, vel_var):
        hist = self._history
        k = max(i for i in range(len(hist)) if hist[i].t <= t) if hist[0].t <= t else 0
        snap = hist[k]
        corrected = tilt_correction.correct(antenna, self.lever, snap.heading, snap.pitch, snap.roll)
        v_ref = None if vel is None else vel[:2] - self._lever_velocity(k)
        fix_cov = cov[:2, :2]
        if self.settings.estimator == "agnav":  # the receiver's slow error becomes the EKF's bias states
            fix_cov, _ = self.ekf.split_fix_covariance(fix_cov)
        R = fix_cov + self._tilt_variance() * np.eye(2)
        speed = float(np.hypot(*v_ref)) if v_ref is not None else None
        fwd = np.array([math.sin(snap.heading), math.cos(snap.heading)])
        xy = corrected[:2] - (t - snap.t) * (speed or 0.0) * fwd   # align to the snapshot epoch
        if self.settings.estimator == "agnav":
            if speed is None and self._fix is not None:  # V from successive tilt-corrected fixes
                speed = float(np.hypot(*(xy - self._fix[1][:2]))) / max(t - self._fix[0], 1e-3)
            # still: slower than stationary_speed, or for a receiver velocity than twice its noise (its norm's bias)
            s = self.settings
            still_below = max(s.stationary_speed, 2.0 * s.velocity_sigma) if self._doppler(vel, vel_var) \
                else s.stationary_speed
            was_still, self._still = self._still, speed is not None and speed < still_below
            accepted = self._fix_agnav(k, t, xy, R, v_ref, vel_var, speed, was_still and not self._still)
        else:
            accepted = self._fix_thesis(k, t, xy, R, speed)
        if accepted:
            self._last_accepted_t = t
            self._fix = (t, corrected, cov)

    def _gate(self, t, d2):
        """True to accept; False (counted) to refuse; None once fixes have been refused for gnss_reset_time: then
        the position restarts from the fix (a receiver jump that persists, or a dead reckoning gone wrong)."""
        if d2 <= self.settings.gate_chi2:
            self._rejected_since = None
            return True
        if self._rejected_since is None:
            self._rejected_since = t
        if t - self._rejected_since >= self.settings.gnss_reset_time:
            self.guard.count("gnss_forced")
            self._rejected_since = None
            return None
        self.guard.count("gnss_gated")
        return False

    def _fix_agnav(self, k, t, xy, R, v_ref, vel_var, speed, started=False):
        s, hist, ekf = self.settings, self._history, self.ekf
        snap = hist[k]
        first, verdict = ekf.x is None, True
        if first:  # position and speed from the first fix; heading unknown until moving
            ekf.initialise(xy, R, snap.heading, speed or 0.0)
            ekf.P[IPHI, IPHI] = math.pi ** 2
        else:
            ekf.x, ekf.P = snap.nav[0].copy(), snap.nav[1].copy()
            if started:  # the gyro bias learnt standing still shifts once the vehicle moves
                ekf.P[IB, IB] += s.motion_bias_sigma ** 2
        if first:
            pass
        elif not self._heading_known:
            for i, var in ((IPHI, math.pi ** 2), (IB, ekf.P[IB, IB])):  # no heading yet: decouple
                ekf.P[i, :] = ekf.P[:, i] = 0.0
                ekf.P[i, i] = var
            if self._still and self._doppler(v_ref, vel_var):
                self._fuse(ekf.standstill_innovation(s.standstill_sigma ** 2), gated=False)
            elif v_ref is not None and speed > 3.0 * math.sqrt(vel_var):  # (a slower norm is biased by the noise)
                self._fuse(ekf.speed_innovation(speed, vel_var))  # needs no heading: carries the start of motion
            chord = self._chord_course(xy, snap.raw_heading, speed or 0.0)
            if chord is not None:  # absolute heading from the chord between moving fixes
                ekf.x[IPHI] = chord
                ekf.P[IPHI, IPHI] = np.trace(R) / s.heading_init_distance ** 2
                self._heading_known = True
            elif v_ref is not None and speed >= s.heading_init_speed:  # provisional: the course over ground
                ekf.x[IPHI] = math.atan2(*v_ref)
                ekf.P[IPHI, IPHI] = s.ekf.init_heading_sigma ** 2
            y, S, d2, H = ekf.position_innovation(xy, R)
            ekf.update(y, S, H, R)
        else:
            y, S, d2, H = ekf.position_innovation(xy, R)
            verdict = self._gate(t, d2)
            doppler = self._doppler(v_ref, vel_var)
            if verdict is False and not doppler:  # a refused fix's own difference velocity is no better
                ekf.x, ekf.P = hist[-1].nav[0].copy(), hist[-1].nav[1].copy()
                return False
            if verdict is None:
                ekf.reset_position(xy, R)
            elif verdict:
                ekf.update(y, S, H, R)
            if self._still and doppler:  # standing: zero speed (noise has no direction)
                self._fuse(ekf.standstill_innovation(s.standstill_sigma ** 2), gated=False)
            elif s.use_gnss_velocity and v_ref is not None:  # a receiver velocity even when its fix is refused
                Rv = vel_var * np.eye(2)
                y, S, d2, H = ekf.velocity_innovation(v_ref, Rv)
                if d2 <= s.gate_chi2:
                    ekf.update(y, S, H, Rv)
                else:
                    self.guard.count("velocity_gated")
        snap.nav, snap.heading = (ekf.x.copy(), ekf.P.copy()), ekf.x[IPHI]
        for j in range(k + 1, len(hist)):  # replay the IMU samples received since the epoch
            self._propagate(hist[j].rate_cw, hist[j].dt, hist[j].still, hist[j].wheel)
            hist[j].nav, hist[j].heading = (ekf.x.copy(), ekf.P.copy()), ekf.x[IPHI]
        return verdict is not False

    def _doppler(self, vel, vel_var):
        """True for a receiver velocity (variance at the velocity_sigma floor), not one from fix differences:
        only that one tells standing still from creeping."""
        return vel is not None and vel_var <= self.settings.velocity_sigma ** 2

    def _fuse(self, innovation, gated=True, counter="velocity_gated"):
        """EKF update from a (y, S, d2, H, R) speed or standstill innovation, gated unless a constraint."""
        y, S, d2, H, R = innovation
        if not gated or d2 <= self.settings.gate_chi2:
            self.ekf.update(y, S, H, R)
        else:
            self.guard.count(counter)

    def _chord_course(self, xy, rel_heading, speed):
        """Heading (rad, cw from north) at this fix from the chord to the first moving fix once it is
        heading_init_distance long (the chord's direction is the mean heading: half the gyro turn is added), or None.
        speed: from /gnss/vel when present, else from successive fixes."""
        s = self.settings
        if speed < s.heading_init_speed:
            self._chord_start = None
            return None
        if self._chord_start is None:
            self._chord_start = (xy, rel_heading)
            return None
        d = xy - self._chord_start[0]
        if np.hypot(*d) < s.heading_init_distance:
            return None
        return math.atan2(d[0], d[1]) + 0.5 * math.remainder(rel_heading - self._chord_start[1], 2 * math.pi)

    def _fix_thesis(self, k, t, xy, R, speed):
        hist = self._history
        snap = hist[k]
        if snap.nav is not None and self.heading_lsm.heading is not None:  # no gate on a heading not yet known
            y = xy - snap.nav[0]
            S = snap.nav[1] + R
            verdict = self._gate(t, float(y @ np.linalg.solve(S, y)))
            if verdict is False:
                return False
        dt_fix = t - self._fix[0] if self._fix else 1.0
        if speed is None:  # V from successive tilt-corrected fixes (SPEC §6.3 [IMPL])
            speed = float(np.hypot(*(xy - self._fix[1][:2]))) / dt_fix if self._fix else 0.0
        self._speed = speed
        self.heading_lsm.on_fix(xy[0], xy[1], speed, snap.raw_heading, snap.heading, dt_fix)
        self.dr.reset(xy, R)
        snap.nav = (xy.copy(), R.copy())
        for j in range(k + 1, len(hist)):  # (5.12)-(5.13) from the fix epoch to now
            out = self.dr.step(hist[j].heading, speed, hist[j].dt)
            hist[j].nav = (out[0].copy(), out[1].copy())
        return True

    # ---- helpers -----------------------------------------------------------------------------------------
    def _attitude_variances(self):
        return self.roll_filter.variance, self.pitch_filter.variance

    def _heading_variance(self):
        if self.settings.estimator == "agnav":
            return float(self.ekf.P[IPHI, IPHI]) if self.ekf.x is not None else math.inf
        pos_var = float(np.trace(self._fix[2][:2, :2])) / 2 if self._fix else 1.0
        return self.heading_lsm.kise.variance(pos_var) + 1e-6

    def _tilt_variance(self):
        """Horizontal variance that attitude errors add to the corrected position (per axis)."""
        untracked = self.settings.untracked_tilt_sigma ** 2
        vr, vp = (v if np.isfinite(v) else untracked for v in self._attitude_variances())
        return tilt_correction.tilt_variance(self.lever, vr, vp, self._heading_variance())

    def _rate_corrections(self):
        """Estimated gyro errors removed from the body rates (FLU); a tilt axis without attitude filter output
        (no inclinometer yet) is zeroed, since its raw gyro offset would pass into the lever-arm velocity."""
        if self.settings.estimator == "agnav":
            yaw_corr = -float(self.ekf.x[IB]) if self.ekf.x is not None else 0.0
            roll_corr, pitch_corr = -self.roll_filter.bias, -self.pitch_filter.bias
        else:
            roll_corr, pitch_corr, yaw_corr = self.roll_filter.drift, self.pitch_filter.drift, self.heading_lsm.drift
        return np.array([roll_corr, -pitch_corr, -yaw_corr])

    def _corrected_rates(self, body_rates):
        rates = body_rates + self._rate_corrections()
        rates[0] *= self.roll_filter.angle is not None
        rates[1] *= self.pitch_filter.angle is not None
        return rates

    def _lever_velocity(self, k):
        """ENU velocity of the antenna relative to base_link at history sample k: omega x lever, omega the corrected
        body rate averaged over lever_rate_window (a FOG's angle noise differentiated per sample would be m/s)."""
        hist, snap = self._history, self._history[k]
        window = [h.body_rates for h in hist if snap.t - self.settings.lever_rate_window <= h.t <= snap.t]
        omega = self._corrected_rates(np.mean(window, axis=0))
        v_body = cross(omega, self.settings.lever_flu)
        e = tilt_correction.vehicle_to_ground(snap.heading, snap.pitch, snap.roll)
        right_fwd_up = np.array([-v_body[1], v_body[0], v_body[2]])
        return (e @ right_fwd_up)[:2]

    def _output(self):
        s, snap = self.settings, self._history[-1]
        vr, vp = self._attitude_variances()
        big = 1e6
        pose_cov = np.zeros((6, 6))
        pose_cov[DIAG6] = (big, big, big, min(vr, big), min(vp, big), big)
        twist_cov = np.zeros((6, 6))
        twist_cov[DIAG6] = (1.0, 0.01, 0.01, 1e-4, 1e-4, 1e-4)
        position, speed = np.zeros(3), 0.0
        heading_valid = position_valid = False
        if self._fix is not None:
            position[2] = self._fix[1][2]
            pose_cov[2, 2] = self._fix[2][2, 2]
        if s.estimator == "agnav":
            if snap.nav is not None:
                x, P = snap.nav
                position[:2], speed = x[:2], float(x[IV])
                heading_valid = self._heading_known
                pose_cov[POSE_XY_YAW] = P[EKF_XY_PHI] * YAW_SIGN  # heading cw -> yaw ccw
                twist_cov[0, 0] = P[IV, IV]
                twist_cov[5, 5] = P[IB, IB] + s.ekf.rate_noise ** 2
                position_valid = True
            elif self._fix is not None:
                position[:2] = self._fix[1][:2]
                pose_cov[:2, :2] = self._fix[2][:2, :2]
                position_valid = True
        else:
            speed = self._speed
            if snap.nav is not None:
                position[:2] = snap.nav[0]
                pose_cov[:2, :2] = snap.nav[1]
                position_valid = True
            if self.heading_lsm.heading is not None:
                heading_valid = True
                pose_cov[5, 5] = self._heading_variance()
        rates = snap.body_rates + self._rate_corrections()
        rpy = np.array([snap.roll, -snap.pitch, math.remainder(math.pi / 2 - snap.heading, 2 * math.pi)])
        dead_reckoning = snap.t - self._last_accepted_t > s.gnss_timeout
        return NavState(snap.t, position, rpy, pose_cov, speed, rates, twist_cov,
                        heading_valid, position_valid, dead_reckoning)
