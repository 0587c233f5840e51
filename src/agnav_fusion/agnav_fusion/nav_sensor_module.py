"""Navigation sensor module data flow (SPEC §6.3, Fig. 5.5): attitude -> GNSS tilt correction -> heading ->
position at the IMU rate, with GNSS latency compensation, input guarding and covariances.

The module's boundary is REP-103 (ENU map, FLU base_link, yaw CCW from east, pitch nose down); its estimators run
in the thesis' conventions (heading clockwise from north, pitch nose up; SPEC §2.3). The module owns what every
estimator needs: input guards, the IMU history that late fixes are replayed against, tilt correction and the
antenna lever-arm velocity (4.18-4.24), the fix gate and the output. Estimators (ESTIMATORS, chosen by the
`estimator` setting): "agnav" = attitude KF + navigation EKF (nav_agnav.py); "thesis" = attitude LSM + Kise/drift
LSM + dead reckoning (nav_thesis.py).
"""
import math
from collections import Counter, deque

import numpy as np

from agnav_fusion import tilt_correction
from agnav_fusion.front_end import InputGuard, Overdue
from agnav_fusion.nav_agnav import AgnavEstimator
from agnav_fusion.nav_ekf import same_error_class
from agnav_fusion.nav_settings import MOUNTS, NavSensorModuleSettings, NavState, Sample, cross, last_at  # noqa: F401 (re-exported)
from agnav_fusion.nav_thesis import ThesisEstimator

ESTIMATORS = {"agnav": AgnavEstimator, "thesis": ThesisEstimator}
TWIST_COV = np.diag((1.0, 0.01, 0.01, 1e-4, 1e-4, 1e-4))  # of the output (the estimators fill what they know)
BIG_VAR = 1e6  # of the output's unknown axes
POSE_COV = np.diag((BIG_VAR, BIG_VAR, BIG_VAR, 0.0, 0.0, BIG_VAR))  # of the output, before the attitude variances
DIFFERENCE_S = 12.0  # s of fixes a front end's fix-difference velocity may span (pipeline: 10 s)


class NavSensorModule:
    """Feed imu() at the IMU rate, inclinometer() and gnss() whenever they arrive; read state()."""

    def __init__(self, settings=None):
        self.settings = s = settings or NavSensorModuleSettings()
        if s.estimator not in ESTIMATORS:
            raise ValueError(f"unknown estimator {s.estimator!r} (one of {', '.join(ESTIMATORS)})")
        self.lever = tilt_correction.lever_from_flu(s.lever_flu)
        self.guard = InputGuard(s.guard)
        self.history = deque()
        self._start()

    @property
    def counters(self):
        """Totals of every input and rejection event since the start (guard.recent(): the last seconds only)."""
        return Counter(self.guard.totals)

    def _start(self):
        """(Re)start the estimator: at construction and after an IMU gap longer than max_gap."""
        self.estimator = ESTIMATORS[self.settings.estimator](self)
        self.history.clear()
        self._imu_period = None                    # s, running mean IMU sample spacing
        self._fixes_due = Overdue(self.settings.gnss_overdue_periods)
        self._pending_gnss = []
        self._incl = None            # (t, roll, pitch) REP-103
        self._last_accepted_t = -math.inf
        self._rejected_since = None  # epoch of the first of the fixes the gate refuses in a row
        self._smooth_refusals = 0    # refused fixes since the last accepted one, all on its smooth track (-1: broken)
        self._track = None           # (t, xy, velocity) of the latest fix, accepted or not
        self._smooth = False         # the latest fix continues that track without a step
        self.last_fix = None         # latest accepted corrected fix (t, xyz, cov)
        self._climb_fixes = deque()  # (t, corrected ENU, white, slow variance) of the last still_baseline s: path pitch
        self._climb_skip = False     # the fix being fused was corrected on a heading since replaced
        self._antenna_fixes = deque()  # (t, antenna ENU) of the last DIFFERENCE_S: tells fix-differenced velocities
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
        zero = self.settings.incl_zero_deg
        self._incl = (t, roll - math.radians(zero[0]), pitch - math.radians(zero[1]))
        return True

    def gnss(self, t, antenna_enu, cov, vel_enu=None, vel_var=None):
        """Antenna fix (map ENU m, 3x3 covariance m^2, optional ENU velocity m/s with its per-axis horizontal
        variance m^2/s^2, at least velocity_sigma^2; default velocity_sigma^2) stamped at its epoch. A bad velocity
        is dropped (counted) and the fix used without it."""
        ref = self.history[-1].t if self.history else None
        if not self.guard.accept("gnss", t, antenna_enu, ref=ref):
            return False
        if self.history and t < self.history[0].t:
            self.guard.count("gnss_too_old")
            return False
        cov = self.guard.fix_covariance(cov)
        if cov is None:
            return False
        self.guard.count("gnss")
        self._fixes_due.arrived(t, self.history[-1].t if self.history else None)
        antenna_enu = np.asarray(antenna_enu, float)
        differenced = 0.0 if vel_enu is None else self._differenced(t, antenna_enu, np.asarray(vel_enu, float))
        self._antenna_fixes.append((t, antenna_enu))
        while self._antenna_fixes[0][0] < t - DIFFERENCE_S:
            self._antenna_fixes.popleft()
        if vel_enu is not None:
            vel_var = self.guard.velocity_variance(vel_var, self.settings.velocity_sigma ** 2)
            if vel_var is None or not self.guard.accept("vel", t, vel_enu, ref=ref):
                vel_enu = None
        self._pending_gnss.append((t, antenna_enu, cov, None if vel_enu is None else np.asarray(vel_enu, float),
                                   vel_var, differenced))
        self._drain_gnss()
        return True

    def _differenced(self, t, antenna, vel):
        """The baseline (s) when vel is the difference of this fix and an earlier one over their time (no /gnss/vel:
        the front end's fix-difference velocity), 0.0 for a receiver (Doppler) velocity."""
        if not self._antenna_fixes:
            return 0.0
        t0, p0 = (np.array(v) for v in zip(*self._antenna_fixes))
        dt = (t - t0)[:, None]
        diff = np.divide(antenna - p0, dt, out=np.full(p0.shape, np.inf), where=dt > 0)
        match = np.all(np.abs(diff - vel) <= 1e-9 + 1e-9 * np.abs(vel), axis=1)
        return float(dt[match][-1, 0]) if match.any() else 0.0

    def wheel_speed(self, t, speed, var=None):
        """Forward ground speed (m/s, negative reversing) of base_link from wheel odometry or a radar, with its
        variance (None: wheel_speed_sigma), stamped at its epoch; fused by the agnav EKF at the next IMU sample."""
        if not self.guard.accept("wheel", t, speed, 0.0 if var is None else var):
            return False
        self.guard.count("wheel")
        s = self.settings
        var = max(var or 0.0, s.wheel_speed_sigma ** 2) + (s.wheel_slip_sigma * speed) ** 2
        self.estimator.wheel = (t, float(speed), var)
        return True

    def imu(self, t, gyro_flu, specific_force=None):
        """Body (base_link FLU) gyro rates (rad/s) at epoch t, and optionally the accelerometer's specific force
        (base_link FLU m/s^2; zero or not finite: no accelerometer); advances the module. Returns the new NavState."""
        if not self.guard.accept("imu", t, gyro_flu):
            return None
        if specific_force is not None:
            specific_force = np.asarray(specific_force, dtype=float)
            if not (np.all(np.isfinite(specific_force)) and specific_force.any()):
                specific_force = None
        self.guard.count("imu")
        s = self.settings
        dt = t - self.history[-1].t if self.history else 0.0
        if dt > s.max_gap:
            self.guard.count("imu_gap_restart")
            self._start()
            dt = 0.0
        elif dt > s.max_dt or (self._imu_period and dt > s.gap_periods * self._imu_period):
            self.guard.count("imu_gap")
        elif dt > 0:
            self._imu_period = dt if self._imu_period is None else self._imu_period + 0.01 * (dt - self._imu_period)
        if self._fixes_due.check(t):
            self.guard.count("gnss_overdue")
        self._step(t, dt, np.asarray(gyro_flu, dtype=float), specific_force)
        self._drain_gnss()
        self._state = self._output()
        return self._state

    def state(self):
        return self._state


    # ---- per-sample processing -----------------------------------------------------------------------
    def _step(self, t, dt, gyro, force=None):
        s = self.settings
        prev = self.history[-1] if self.history else None
        incl = self._incl if self._incl and t - self._incl[0] <= s.incl_timeout else None
        self._incl = None if incl else self._incl
        roll_incl = None if incl is None else incl[1]
        pitch_incl = None if incl is None else -incl[2]
        force = (force,) if force is not None and getattr(self.estimator, "uses_specific_force", False) else ()
        rate_cw, roll, pitch, heading, raw, nav, still, wheel, *along = self.estimator.step(
            t, dt, gyro, prev, roll_incl, pitch_incl, *force)
        roll = 0.0 if roll is None else roll
        pitch = 0.0 if pitch is None else pitch
        self.history.append(Sample(t, dt, rate_cw, gyro, roll, pitch, heading, raw, nav, still, wheel, *along))
        while self.history[0].t < t - s.history:
            self.history.popleft()

    def _drain_gnss(self):
        if not (self.history and self._pending_gnss):
            return
        now = self.history[-1].t - self.settings.lever_rate_window / 2  # the lever rates centred on the epoch
        ready = [g for g in self._pending_gnss if g[0] <= now]
        self._pending_gnss = [g for g in self._pending_gnss if g[0] > now]
        for fix in ready:
            self._process_fix(*fix)

    # ---- GNSS fix at its epoch ----------------------------------------------------------------------------
    def _process_fix(self, t, antenna, cov, vel, vel_var, differenced=0.0):
        hist = self.history
        if hist[0].t > t:  # the history moved past the epoch while the fix waited (an IMU gap)
            self.guard.count("gnss_too_old")
            return
        k = last_at(hist, t)
        snap = hist[k]
        if t - snap.t > self.settings.max_dt:  # inside an IMU gap: no attitude or track to place the fix on
            self.guard.count("gnss_in_imu_gap")
            return
        corrected = tilt_correction.correct(antenna, self.lever, snap.heading, snap.pitch, snap.roll)
        # a differenced velocity is a mean over seconds: the antenna's sway velocity averages out of it
        lever_vel = np.zeros(3) if vel is None or differenced else self._lever_velocity(k)
        v_ref = None if vel is None else vel[:2] - lever_vel[:2]
        R = self.estimator.white_fix_covariance(cov[:2, :2]) + self._tilt_variance() * np.eye(2)
        speed = float(np.hypot(*v_ref)) if v_ref is not None else None
        fwd = np.array([math.sin(snap.heading), math.cos(snap.heading)])
        xy = corrected[:2] - (t - snap.t) * (speed or 0.0) * fwd   # align to the snapshot epoch
        self._smooth = self._continues_track(t, antenna[:2], cov)
        if self.estimator.fix(k, t, xy, R, v_ref, vel, vel_var, speed, differenced):
            self._last_accepted_t = t
            self.last_fix = (t, corrected, cov)
        if hasattr(self.estimator, "path_pitch"):
            self._path_pitch(k, t, corrected, cov, v_ref, vel, vel_var, lever_vel, differenced)

    def forget_fix_differences(self):
        """The heading was set anew: the fixes kept, and the one being fused, were tilt-corrected on the old one."""
        self._climb_fixes.clear()
        self._climb_skip = True

    def _path_pitch(self, k, t, corrected, cov, v_ref, vel, vel_var, lever_vel, differenced):
        """Climb and ground speed at the epoch (a receiver's velocity) or over the still_baseline s since an earlier
        fix (their difference, for the sample in the middle; the next difference starts at this fix); the vertical
        noise is the horizontal one scaled as in the fix's covariance: the pitch of the path, for the estimator."""
        s, hist = self.settings, self.history
        vertical = max(float(cov[2, 2]) / max(float(cov[0, 0] + cov[1, 1]) / 2, 1e-12), 1.0)  # VDOP/HDOP squared
        skip, self._climb_skip = self._climb_skip, False
        if v_ref is not None and not differenced:  # (no heading in it)
            self.estimator.path_pitch(k, t, float(vel[2] - lever_vel[2]), float(np.hypot(*v_ref)), vel_var * vertical)
            return
        if skip:
            return
        white = float(np.trace(self.estimator.white_fix_covariance(cov[:2, :2]))) / 2
        slow, fixes = self.estimator.ekf.gnss_bias_var, self._climb_fixes
        if slow > s.path_pitch_max_slow ** 2:  # a float or DGPS error's wander runs through many differences alike
            fixes.clear()
            return
        if fixes and not same_error_class(fixes[-1][3], slow):  # the slow error jumped: no difference across
            fixes.clear()
        fixes.append((t, corrected, white, slow))
        while len(fixes) > 2 and fixes[1][0] <= t - s.still_baseline:
            fixes.popleft()
        t0, p0, w0, _ = fixes[0]
        mid = t - (t - t0) / 2
        if t - t0 < s.still_baseline or hist[0].t > mid:
            return
        d = corrected - p0
        fixes.clear()  # the next difference starts here: no fix's noise counted twice
        fixes.append((t, corrected, white, slow))
        self.estimator.path_pitch(last_at(hist, mid), t, d[2] / (t - t0),
                                  float(np.hypot(d[0], d[1])) / (t - t0),
                                  (w0 + white + self.estimator.ekf.bias_change_variance(t - t0)) * vertical
                                  / (t - t0) ** 2)

    def gate(self, t, d2):
        """True to accept; False (counted) to refuse; None once fixes have been refused for gnss_reset_time (a
        receiver jump that persists) or the fixes refused for diverged_time continue the accepted track without a step
        (the estimate diverged, the receiver did not): then the position restarts from the fix."""
        if d2 <= self.settings.gate_chi2:
            self._rejected_since, self._smooth_refusals = None, 0
            return True
        if self._rejected_since is None:
            self._rejected_since = t
        self._smooth_refusals = self._smooth_refusals + 1 if self._smooth and self._smooth_refusals >= 0 else -1
        if self._smooth_refusals > 1 and t - self._rejected_since >= self.settings.diverged_time:
            self.guard.count("estimate_diverged")
        elif t - self._rejected_since >= self.settings.gnss_reset_time:
            self.guard.count("gnss_forced")
        else:
            self.guard.count("gnss_gated")
            return False
        self._rejected_since, self._smooth_refusals = None, 0
        return None

    def _continues_track(self, t, xy, cov):
        """True when the fix's velocity from the previous fix matches the previous one's (within track_max_accel and
        3 sigma of the fixes' noise): no step in the receiver's track."""
        prev = self._track
        v = (xy - prev[1]) / (t - prev[0]) if prev is not None and t > prev[0] else None
        self._track = (t, xy, v)
        if v is None or prev[2] is None:
            return False
        dt = t - prev[0]
        noise = 3.0 * math.sqrt(6.0 * float(np.trace(cov[:2, :2]))) / dt  # norm of a second difference of fixes
        return float(np.hypot(*(v - prev[2]))) <= self.settings.track_max_accel * dt + noise

    # ---- helpers -----------------------------------------------------------------------------------------
    def _attitude_variances(self):
        return self.estimator.roll_filter.variance, self.estimator.pitch_filter.variance

    def _tilt_variance(self):
        """Horizontal variance that attitude errors add to the corrected position (per axis)."""
        untracked = self.settings.untracked_tilt_sigma ** 2
        vr, vp = (v if np.isfinite(v) else untracked for v in self._attitude_variances())
        return tilt_correction.tilt_variance(self.lever, vr, vp, self.estimator.heading_variance())

    def _unbiased_rates(self, body_rates):
        """Body rates less the estimated gyro errors (FLU)."""
        roll, pitch, yaw_cw = self.estimator.rate_corrections()
        p, q, r = body_rates.tolist()
        return np.array([p + roll, q - pitch, r - yaw_cw])

    def _corrected_rates(self, body_rates):
        """Body rates less the estimated gyro errors; a tilt axis without attitude filter output (no inclinometer
        yet) is zeroed, since its raw gyro offset would pass into the lever-arm velocity."""
        rates = self._unbiased_rates(body_rates)
        rates[0] *= self.estimator.roll_filter.angle is not None
        rates[1] *= self.estimator.pitch_filter.angle is not None
        return rates

    def lever_velocity_variance(self):
        """Per-axis variance (m/s)^2 of the antenna lever-arm velocity at a receiver's velocity epoch."""
        return (self.settings.lever_rate_sigma * float(np.linalg.norm(self.lever))) ** 2

    def _lever_velocity(self, k):
        """ENU velocity of the antenna relative to base_link at history sample k: omega x lever, omega the corrected
        body rate averaged over lever_rate_window centred on the epoch (a FOG's angle noise differentiated per sample
        would be m/s; a window ending at the epoch would lag the sway by half its length)."""
        hist, snap = self.history, self.history[k]
        half = self.settings.lever_rate_window / 2
        window = [h.body_rates for h in hist if abs(h.t - snap.t) <= half]
        omega = self._corrected_rates(np.mean(window, axis=0))
        v_body = cross(omega, self.settings.lever_flu)
        e = tilt_correction.vehicle_to_ground(snap.heading, snap.pitch, snap.roll)
        right_fwd_up = np.array([-v_body[1], v_body[0], v_body[2]])
        return e @ right_fwd_up

    def _output(self):
        s, snap = self.settings, self.history[-1]
        vr, vp = self._attitude_variances()
        vr, vp = min(vr, BIG_VAR), min(vp, BIG_VAR)
        pose_cov = POSE_COV.copy()
        pose_cov[3, 3], pose_cov[4, 4] = vr, vp
        twist_cov = TWIST_COV.copy()
        position = np.zeros(3)
        if self.last_fix is not None:
            position[2] = self.last_fix[1][2]
            pose_cov[2, 2] = self.last_fix[2][2, 2]
        speed, heading_valid, position_valid = self.estimator.output(snap, position, pose_cov, twist_cov)
        # the attitude error that placed every recent fix on base_link is slow: averaging the fixes leaves it
        tilt_var = tilt_correction.tilt_variance(self.lever, vr, vp, 0.0)
        pose_cov[0, 0] += tilt_var
        pose_cov[1, 1] += tilt_var
        rates = self._unbiased_rates(snap.body_rates)
        rpy = np.array([snap.roll, -snap.pitch, math.remainder(math.pi / 2 - snap.heading, 2 * math.pi)])
        dead_reckoning = snap.t - self._last_accepted_t > s.gnss_timeout
        crab = self.estimator.crab() if hasattr(self.estimator, "crab") else None
        return NavState(snap.t, position, rpy, pose_cov, speed, rates, twist_cov,
                        heading_valid, position_valid, dead_reckoning, *(crab or ()))
