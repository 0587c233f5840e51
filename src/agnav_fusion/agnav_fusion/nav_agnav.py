"""agnav's estimator of the navigation sensor module: two attitude KFs (inclinometer lag + kinematic acceleration
model, attitude_kf.py) and the navigation EKF (nav_ekf.py: position, heading, yaw-gyro bias, speed, acceleration or
accelerometer bias, crab), with standstill and wheel-speed updates, the chord heading start and receiver velocity
fusion. With an accelerometer, its along-track specific force (gravity removed with the estimated pitch, the IMU
lever-arm acceleration removed) drives the speed between fixes. A velocity differenced from fixes is not fused once
the heading is known: it repeats the fixes' own information, late by half its baseline. Thesis conventions
inside (heading clockwise from north, pitch nose up); NavSensorModule converts at its boundary.
"""
import math
from collections import deque

import numpy as np
from agnav_common.frames import cross_floats

from agnav_fusion.attitude_kf import AttitudeKF
from agnav_fusion.heading_chord import HeadingChord
from agnav_fusion.nav_ekf import IA, IB, IC, IPHI, IR, IS, IV, N, NavEKF
from agnav_fusion.nav_settings import GRAVITY, euler_rates, last_at
from agnav_fusion.tilt_correction import antenna_offset, offset_heading_jacobian, tilt_variance

# flat indices of the (x, y, yaw) block of the pose covariance and of the (X, Y, phi) block of P
POSE_XY_YAW = np.ravel_multi_index(np.ix_([0, 1, 5], [0, 1, 5]), (6, 6)).ravel()
EKF_XY_PHI = np.ravel_multi_index(np.ix_([0, 1, IPHI], [0, 1, IPHI]), (N, N)).ravel()
YAW_SIGN = np.array([1, 1, -1, 1, 1, -1, -1, -1, 1])  # heading cw -> yaw ccw flips the cross terms


class AgnavEstimator:
    """Backend of NavSensorModule (`m`: its history, settings, guard and gate)."""

    def __init__(self, m):
        self.m, s = m, m.settings
        self.roll_filter, self.pitch_filter = AttitudeKF(s.roll_kf), AttitudeKF(s.pitch_kf)
        self.ekf = NavEKF(s.ekf)
        self.wheel = None          # latest wheel speed (t, speed, variance) not yet fused
        self.raw_heading = 0.0     # relative yaw before the absolute heading exists (less the yaw bias learnt)
        self.heading_known = False  # absolute heading initialised from the GNSS course
        self.heading_valid = False  # published: within heading_valid_sigma once, not beyond heading_lost_sigma since
        self.chord = HeadingChord(s.chord_max_turn, s.heading_init_distance, s.chord_max_sigma)
        self.still = False         # the latest fix says the vehicle stands still
        self.resting = False       # a fix said still, and no start since
        self.fix_speed = None      # (epoch, EKF speed after the fix): the fixes' own acceleration
        self.last_fix_t = math.inf  # epoch of the latest fix, accepted or not
        self.mark_t = -math.inf    # epoch from which the pitch filter keeps its inputs (re-filtered at the next fix)
        self.coast_after = s.gnss_timeout  # s after last_fix_t the next fix is overdue (its period + coast_margin)
        self.coasting = False      # a fix is overdue: the speed model coasts
        self.path_pitch_t = -math.inf
        self.recent_fixes = deque()  # (epoch, tilt-corrected xy) of the fixes of the last still_baseline s
        self.accel_miss = 0.0      # m/s^2, acceleration the speed model missed before the latest fix
        self.alpha = [0.0, 0.0, 0.0]  # rad/s^2, low-passed angular acceleration (lever-arm acceleration)
        self.fix_accel = 0.0       # m/s^2, the fixes' speed change: compensates the inclinometer (accelerometer mode)

    # ---- per IMU sample ---------------------------------------------------------------------------------
    uses_specific_force = True

    def step(self, t, dt, gyro, prev, roll_incl, pitch_incl, force=None):
        """-> (rate_cw, roll, pitch, heading, raw heading, nav, still, wheel, along-track accel) of this sample;
        force: specific force (base_link FLU m/s^2) or None."""
        s = self.m.settings
        gyro = gyro.tolist()  # per sample on Python floats (the same arithmetic as numpy's, less overhead)
        roll0, pitch0 = (prev.roll, prev.pitch) if prev else (0.0, 0.0)
        # the y gyro's bias (the pitch filter's) enters the yaw rate by sin(roll): a heading drift on cross slopes
        droll, dpitch, dyaw = euler_rates(gyro, roll0, -pitch0, self.pitch_filter.bias)
        rate_cw = -dyaw
        yaw_rate = gyro[2]
        if self.ekf.x is not None:  # the heading-rate bias b and scale error s the EKF learns are the z gyro's
            # (r_true = (1 + s) r + b), which enter the tilt rates by the roll: on a cross slope they tilt the pitch
            dr = float(self.ekf.x[IS]) * yaw_rate + float(self.ekf.x[IB])
            droll -= dr * math.cos(roll0) * math.tan(pitch0)
            dpitch -= dr * math.sin(roll0)
            yaw_rate += dr
        lever_acc = self._lever_acceleration(gyro, prev, dt)
        acc, acc_var = self._kinematic_acceleration(yaw_rate, lever_acc) if s.accel_compensation else ((0.0,) * 3,
                                                                                                      (0.0, 0.0))
        # a pendulum reads roll + a_y/g and (REP-103) pitch - a_x/g, i.e. thesis nose-up pitch + a_x/g
        roll = self.roll_filter.update(droll, roll_incl, dt, acc[1] / GRAVITY, acc_var[1] / GRAVITY ** 2)
        pitch = self.pitch_filter.update(-dpitch, pitch_incl, dt, acc[0] / GRAVITY, acc_var[0] / GRAVITY ** 2)
        self.raw_heading += (rate_cw - (self.ekf.x[IB] if self.ekf.x is not None else 0.0)) * dt  # the bias learnt
        wheel = self.wheel[1:] if self.wheel and 0 <= t - self.wheel[0] <= s.wheel_timeout else None
        self.wheel = None if wheel else self.wheel
        along = None
        if force is not None and roll is not None and pitch is not None:  # pitch: thesis nose up
            along = min(max(float(force[0]) - GRAVITY * math.sin(pitch) - lever_acc[0], -s.max_accel), s.max_accel)
        self.ekf.set_accel_mode(along is not None)
        if self.ekf.x is not None:
            coasting = t - self.last_fix_t > self.coast_after
            if coasting and not self.coasting:
                self.ekf.forget_acceleration()
            self.coasting = coasting
            self.propagate(rate_cw, dt, self.still, wheel, along, roll or 0.0, coasting)
            heading, nav = self.ekf.x[IPHI], (self.ekf.x.copy(), self.ekf.P.copy())
        else:
            heading, nav = self.raw_heading, None
        return rate_cw, roll, pitch, heading, self.raw_heading, nav, self.still, wheel, along

    def propagate(self, rate_cw, dt, still, wheel=None, along=None, roll=0.0, coasting=False):
        """EKF prediction with the yaw rate (the along-track acceleration `along`, roll for the crab model); standing
        still, the gyro reading is its bias (zero-rate update); a wheel speed (speed, variance) measures V. An IMU gap
        is bridged in steps of max_dt, the yaw rate and acceleration it may hide added as noise. coasting: a fix is
        overdue (coast_margin s after the fix period, at most gnss_timeout s)."""
        s, ekf = self.m.settings, self.ekf
        if dt > s.max_dt:
            n = math.ceil(dt / s.max_dt)
            for _ in range(n):
                ekf.P[IPHI, IPHI] += (s.gap_rate_sigma * dt) ** 2 / n
                ekf.P[IV, IV] += (s.gap_accel_sigma * dt) ** 2 / n
                ekf.predict(rate_cw, dt / n, along, roll, coasting)
        else:
            ekf.predict(rate_cw, dt, along, roll, coasting)
        if still:
            ekf.update(*ekf.zero_rate_innovation(rate_cw, s.still_rate_sigma ** 2))
        if wheel is not None:
            self._fuse(ekf.wheel_innovation(*wheel), counter="wheel_gated")

    def _lever_acceleration(self, gyro, prev, dt):
        """Body (FLU) acceleration of the attitude package (and IMU, at incl_lever_flu) relative to base_link:
        alpha x r + w x (w x r), alpha from gyro differences through a lever_accel_tau low-pass (sway passes)."""
        s = self.m.settings
        alpha = self.alpha
        if prev is not None and dt > 0:
            gain = 1.0 - math.exp(-dt / s.lever_accel_tau)
            g0 = prev.body_rates.tolist()
            alpha = self.alpha = [a + gain * ((g - g_) / dt - a) for a, g, g_ in zip(alpha, gyro, g0)]
        r = s.incl_lever_flu
        a, b = cross_floats(alpha, r), cross_floats(gyro, cross_floats(gyro, r))
        return a[0] + b[0], a[1] + b[1], a[2] + b[2]

    def _kinematic_acceleration(self, wz, lever_acc):
        """Body (FLU) acceleration of the inclinometer: forward (accelerometer or A state), centripetal V*wz (the
        corrected z rate), and the lever-arm terms; -> (acceleration, variances of its forward and lateral parts)."""
        ekf = self.ekf
        if ekf.x is None or self.still:  # standing still: no acceleration but the lever's (the gyro's sway)
            return lever_acc, (0.0, 0.0)
        if ekf.accel_mode:  # the fixes' speed change, smoothed: pitch-independent
            accel, accel_var = self.fix_accel, 0.0
        else:
            accel, accel_var = float(ekf.x[IA]), float(ekf.P[IA, IA])
        return ((accel + lever_acc[0], float(ekf.x[IV]) * wz + lever_acc[1], 0.0 + lever_acc[2]),
                (accel_var, float(ekf.P[IV, IV]) * wz ** 2))

    # ---- GNSS fix at its epoch ------------------------------------------------------------------------
    def white_fix_covariance(self, cov2):
        """The receiver's slow error becomes the EKF's bias states; the rest is white."""
        return self.ekf.split_fix_covariance(cov2)[0]

    def fix(self, k, t, xy, R, v_ref, vel, vel_var, speed, differenced=0.0):
        """Fuse a tilt-corrected fix (and its receiver velocity; `differenced`: the baseline in s of a velocity from
        fix differences, 0 for a receiver's) at history sample k; True when the position was accepted."""
        m, s = self.m, self.m.settings
        check_var, baseline = vel_var, differenced  # what tells the tilt filters whether a start was missed
        earlier = self._earlier_fix(t, xy)
        if speed is None and earlier is not None:  # V from tilt-corrected fixes still_baseline s apart
            interval = max(t - earlier[0], 1e-3)
            speed = float(np.hypot(*(xy - earlier[1]))) / interval
            if vel_var is None:  # the interval's mean speed; noise: both fixes' white parts
                check_var, baseline = 2.0 * self._white_variance(R) / interval ** 2, interval
        doppler = not differenced and self._doppler(vel, vel_var)
        # still: slower than stationary_speed, or for a receiver velocity than twice its noise (its norm's bias); a
        # fix difference (antenna sway, jitter) only when the EKF's speed agrees
        still_below = max(s.stationary_speed, 2.0 * s.velocity_sigma) if doppler else s.stationary_speed
        creeping = doppler or self.ekf.x is None or abs(self.ekf.x[IV]) < still_below
        self.still = speed is not None and speed < still_below and creeping
        # a start after rest; by a receiver speed beyond 3x its noise (2x: 14 % of a standing vehicle's fixes)
        started = self.resting and not self.still and (not doppler or speed > 3.0 * s.velocity_sigma)
        self.resting = self.still or (self.resting and not started)
        if self.still:  # (a start taken from noise: no motion bias builds up standing)
            for tilt in (self.roll_filter, self.pitch_filter):
                tilt.end_bias_change()
        # the fix's speed change, as an acceleration over the interval, was missing from the inclinometer's
        # compensation: the pitch is re-filtered with it (unless a chord may set the speed, or an accelerometer is used)
        refilter = (self.heading_known or doppler) and not self.ekf.accel_mode and t > self.mark_t
        prior = m.history[k].nav if refilter else None
        self.accel_miss = self._check_speed_model(k, t, speed, check_var, doppler, baseline, prior is not None)
        accepted = self._fuse_fix(k, t, xy, R, v_ref, vel_var, speed, started, doppler, differenced)
        post, after = m.history[k].nav, len(m.history) - 1 - k  # (samples after the epoch: the EKF's new A)
        if prior is None or post is not prior:  # (a refused fix changed nothing: the interval goes on)
            dv, interval = (post[0][IV] - prior[0][IV], t - self.mark_t) if prior is not None else (math.inf, 0.0)
            if abs(dv) <= s.max_accel * interval:  # (more: a speed reset, no acceleration)
                self.pitch_filter.refilter(dv / interval / GRAVITY, after, (post[0][IA] - prior[0][IA]) / GRAVITY)
            self.pitch_filter.mark(after)
            self.mark_t = t
        if t > self.last_fix_t:
            self.coast_after = min(s.gnss_timeout, t - self.last_fix_t + s.coast_margin)
        self.last_fix_t = t
        return accepted

    def path_pitch(self, k, t, climb, speed, climb_var):
        """The climb rate over the ground speed (m/s; at history sample k, fix epoch t) is the pitch of the path,
        which the vehicle on its wheels shares (sway and short terrain waves aside), free of the accelerations the
        inclinometer reads: a reading of the pitch filter's angle, moved to now by the filter's change since."""
        s, hist = self.m.settings, self.m.history
        if self.still or speed < s.path_pitch_speed or self.ekf.x is None:
            return
        theta = math.atan2(climb, speed) * (1.0 if self.ekf.x[IV] >= 0 else -1.0)
        interval = min(max(t - self.path_pitch_t, 1e-3), 1.0)
        self.path_pitch_t = t
        var = (climb_var * (1.0 + math.tan(theta) ** 2) / speed ** 2
               + s.path_pitch_sigma ** 2 / interval)
        self.pitch_filter.observe(theta + hist[-1].pitch - hist[k].pitch, var)

    def _check_speed_model(self, k, t, speed, vel_var, doppler, baseline=0.0, refilter=False):
        """The GNSS speed tells whether the speed model's acceleration since the last epoch was right (it is also
        what was removed from the inclinometers): beyond doubt wrong (a start, a braking), the tilt filters (the pitch
        one unless `refilter`) go back to their gyro-only copies; agreeing, the copies restart here; in doubt, they
        wait. -> the acceleration a receiver (Doppler) speed says the model missed (m/s^2) when not agreeing, else 0:
        its square joins the A state's variance (a fix-difference speed, the mean over its `baseline` s, is compared
        with the model at the baseline's middle: no such news)."""
        s, hist = self.m.settings, self.m.history
        if baseline:
            mid = hist[k].t - baseline / 2
            if hist[0].t > mid:
                return 0.0
            k = last_at(hist, mid)
        nav = hist[k].nav
        if speed is None or vel_var is None or nav is None:
            return 0.0
        miss, sigma = speed - nav[0][IV], math.sqrt(vel_var + nav[1][IV, IV])
        sigmas = abs(miss) / sigma
        for tilt in (self.roll_filter,) if refilter else (self.roll_filter, self.pitch_filter):
            if sigmas > s.tilt_revert_sigma:
                tilt.revert()
            if sigmas <= s.tilt_keep_sigma or sigmas > s.tilt_revert_sigma:
                tilt.checkpoint()
        news = doppler and sigmas > s.tilt_keep_sigma and t > self.last_fix_t
        # the part of the miss the noise cannot explain (at 5-10 Hz, noise over one interval reads as metres per s^2)
        return math.copysign(abs(miss) - s.tilt_keep_sigma * sigma, miss) / min(t - self.last_fix_t, 1.0) if news \
            else 0.0

    def _fuse_fix(self, k, t, xy, R, v_ref, vel_var, speed, started, doppler, differenced):
        s, hist, ekf = self.m.settings, self.m.history, self.ekf
        snap = hist[k]
        first, verdict, replayed = ekf.x is None, True, []
        if first:  # position and speed from the first fix; heading unknown until moving
            ekf.initialise(xy, R, snap.heading, speed or 0.0)
            ekf.P[IPHI, IPHI] = math.pi ** 2
        else:
            ekf.x, ekf.P = snap.nav[0].copy(), snap.nav[1].copy()
            if ekf.log:  # the samples after the epoch are predicted again below: their log entries go (back if refused)
                cut = max(len(ekf.log) - (len(hist) - 1 - k), 0)
                replayed, ekf.log[cut:] = ekf.log[cut:], []
            if started:  # the gyro biases learnt standing still shift once the vehicle moves; the start's
                ekf.P[IB, IB] += s.motion_bias_sigma ** 2  # acceleration is news to the A state, and the speed
                ekf.P[IV, IV] += (s.start_accel_sigma * min(t - self.last_fix_t, 1.0)) ** 2  # it gave since then
                for tilt in (self.roll_filter, self.pitch_filter):
                    tilt.add_bias_variance(s.motion_bias_sigma ** 2, s.motion_bias_spread)
            ekf.P[IA, IA] += max(self.accel_miss ** 2, s.start_accel_sigma ** 2 if started else 0.0)
            if ekf.bias_changed:
                ekf.restart_bias()
        if not first and not self.heading_known:
            self._fix_before_heading(snap, t, xy, R, v_ref, vel_var, speed, doppler, differenced)
        elif not first:
            jac = offset_heading_jacobian(self.m.lever, snap.heading, snap.pitch, snap.roll)
            y, S, d2, H = ekf.position_innovation(xy, R, jac)
            if d2 > s.gate_chi2 and ekf.absorb_along_track(y, S, R, t - self.last_fix_t, s.max_accel):
                y, S, d2, H = ekf.position_innovation(xy, R, jac)  # the speed model fell behind a braking or start
            verdict = self.m.gate(t, d2)
            if verdict is False and not doppler:  # a refused fix's own difference velocity is no better
                ekf.x, ekf.P = hist[-1].nav[0].copy(), hist[-1].nav[1].copy()
                if replayed:  # (only with a log)
                    ekf.log += replayed
                return False
            if verdict is None:  # fixes refused for long: position and heading diverged; restart both
                ekf.reset_position(xy, R)
                self._forget_heading()
            elif verdict:
                ekf.update(y, S, H, R)
            if self.still:  # standing: zero speed (noise has no direction)
                self._fuse(self._standstill(speed), gated=False)
            elif s.use_gnss_velocity and v_ref is not None and not differenced:  # even when its fix is refused
                Rv = (vel_var + self.m.lever_velocity_variance()) * np.eye(2)
                y, S, d2, H = ekf.velocity_innovation(v_ref, Rv)
                if d2 > s.gate_chi2:  # the speed model fell behind a speed change: V's variance takes the miss
                    ekf.P[IV, IV] += float(y @ H[:, IV]) ** 2  # (H[:, IV]: the course unit vector)
                    y, S, d2, H = ekf.velocity_innovation(v_ref, Rv)
                if d2 <= s.gate_chi2:
                    ekf.update(y, S, H, Rv)
                else:
                    self.m.guard.count("velocity_gated")
            if (ekf.x[IV] < -max(s.heading_init_speed, 3.0 * math.sqrt(ekf.P[IV, IV]))
                    and ekf.P[IPHI, IPHI] > s.heading_valid_sigma ** 2):
                # backwards on a heading known too poorly to tell reversing from the mirror image (phi + pi, -V)
                self._forget_heading()
        snap.nav, snap.heading = (ekf.x.copy(), ekf.P.copy()), ekf.x[IPHI]
        if self.fix_speed is not None and 0 < t - self.fix_speed[0] <= 3.0:
            a = 0.0 if self.still else (ekf.x[IV] - self.fix_speed[1]) / (t - self.fix_speed[0])
            self.fix_accel += s.fix_accel_gain * (a - self.fix_accel)
        self.fix_speed = (t, ekf.x[IV])
        for j in range(k + 1, len(hist)):  # replay the IMU samples received since the epoch
            self.propagate(hist[j].rate_cw, hist[j].dt, hist[j].still, hist[j].wheel, hist[j].accel, hist[j].roll)
            hist[j].nav, hist[j].heading = (ekf.x.copy(), ekf.P.copy()), ekf.x[IPHI]
        return verdict is not False

    def _earlier_fix(self, t, xy):
        """The newest earlier tilt-corrected fix (epoch, xy) at least still_baseline s before t (a 5-10 Hz receiver's
        successive fixes are too close to tell standing from creeping), else the oldest kept; remembers this one."""
        recent = self.recent_fixes
        while len(recent) > 1 and recent[1][0] <= t - self.m.settings.still_baseline:
            recent.popleft()
        earlier = recent[0] if recent else None
        recent.append((t, np.asarray(xy[:2], dtype=float)))
        return earlier

    def _white_variance(self, R):
        """Per-axis variance of a fix's own error in R, less the lever's part from the heading's (common to fixes)."""
        return max(float(np.trace(R)) / 2 - tilt_variance(self.m.lever, 0.0, 0.0, self.ekf.P[IPHI, IPHI]), 0.0)

    def _fix_before_heading(self, snap, t, xy, R, v_ref, vel_var, speed, doppler, baseline):
        """No heading yet: decoupled heading and crab, speed fused, the position follows the fixes; the heading comes
        from the chord of the fixes (heading_chord.py) once it is known within chord_max_sigma (published once the
        filter has it within heading_valid_sigma); the receiver's course is a provisional heading meanwhile."""
        m, s, ekf = self.m, self.m.settings, self.ekf
        white = self._white_variance(R)
        for i, var in ((IPHI, math.pi ** 2), (IB, ekf.P[IB, IB]), (IC, s.ekf.crab_sigma ** 2)):
            ekf.P[i, :] = ekf.P[:, i] = 0.0
            ekf.P[i, i] = var
        if self.still:
            self._fuse(self._standstill(speed), gated=False)
        elif doppler and speed > 3.0 * math.sqrt(vel_var):  # (a slower norm is biased by the noise)
            # needs no heading; ungated: the start of motion outruns the speed model, and nothing is published yet
            self._fuse(ekf.speed_innovation(speed, vel_var), gated=False)
        elif baseline and baseline <= s.history and not ekf.accel_mode and speed > 3.0 * math.sqrt(vel_var):
            self._fuse(ekf.speed_innovation(speed, vel_var, baseline / 2), gated=False)  # mean speed of the baseline
        antenna = xy + antenna_offset(m.lever, snap.heading, snap.pitch, snap.roll)[:2]
        chord = self.chord.add(m.lever, t, antenna, snap.raw_heading, snap.pitch, snap.roll, white)
        jac = None
        if chord is not None:
            course, var, xy, mean_speed = chord
            self._set_course(course, var)
            self.heading_known = True
            if not doppler and ekf.P[IV, IV] > s.ekf.init_speed_sigma ** 2:  # the fixes' mean speed along the chord
                ekf.x[IV], ekf.P[IV, IV] = mean_speed, max(ekf.P[IV, IV], s.ekf.init_speed_sigma ** 2)
            R, jac = white * np.eye(2), offset_heading_jacobian(m.lever, ekf.x[IPHI], snap.pitch, snap.roll)
        elif doppler and speed >= s.heading_init_speed:  # provisional: the course over ground
            self._set_course(math.atan2(*v_ref), s.ekf.init_heading_sigma ** 2)
        ekf.reset_position(xy, R, jac)

    def _forget_heading(self):
        """The heading is no longer known (diverged or reversed): nothing published until a new chord."""
        self.heading_known = self.heading_valid = False
        self.chord.clear()
        self.m.guard.count("heading_restart")

    def _set_course(self, course, var):
        """Heading = course - crab: the crab's variance (and correlation) is added to the course's."""
        ekf = self.ekf
        h, (crab, crab_var) = ekf.crab_jacobian(), ekf.crab()
        ekf.x[IPHI] = math.remainder(course - crab, 2 * math.pi)
        ekf.P[IPHI, :] = ekf.P[:, IPHI] = -ekf.P[:, IC:IR] @ h
        ekf.P[IPHI, IPHI] = var + crab_var
        self.recent_fixes.clear()  # tilt-corrected on the old heading (the lever turned with it): no difference across
        self.m.forget_fix_differences()

    def _standstill(self, speed):
        """Standstill innovation at a receiver speed below the still threshold: zero within that speed (a creeping
        or just stopping vehicle held at exactly zero would have its position pulled back through the track)."""
        return self.ekf.standstill_innovation(self.m.settings.standstill_sigma ** 2 + speed ** 2)

    def _doppler(self, vel, vel_var):
        """True for a receiver velocity (variance at the velocity_sigma floor): it tells standing from creeping."""
        return vel is not None and vel_var <= self.m.settings.velocity_sigma ** 2

    def _fuse(self, innovation, gated=True, counter="velocity_gated"):
        """EKF update from a (y, S, d2, H, R) speed or standstill innovation, gated unless a constraint."""
        y, S, d2, H, R = innovation
        if not gated or d2 <= self.m.settings.gate_chi2:
            self.ekf.update(y, S, H, R)
        else:
            self.m.guard.count(counter)

    # ---- outputs --------------------------------------------------------------------------------------
    def crab(self):
        """(crab angle rad, clockwise: course = heading + crab, variance), or None before the EKF starts."""
        return None if self.ekf.x is None else self.ekf.crab()

    def heading_variance(self):
        """Heading variance the tilt correction adds to a fix's: none once known (the lever Jacobian carries it)."""
        return 0.0 if self.heading_known else float(self.ekf.P[IPHI, IPHI]) if self.ekf.x is not None else math.inf

    def rate_corrections(self):
        """(roll, thesis pitch, clockwise yaw) gyro corrections."""
        return -self.roll_filter.bias, -self.pitch_filter.bias, 0.0 if self.ekf.x is None else -float(self.ekf.x[IB])

    def output(self, snap, position, pose_cov, twist_cov):
        """Fill the navigation part of the output; -> (speed, heading_valid, position_valid)."""
        m, s = self.m, self.m.settings
        if snap.nav is not None:
            x, P = snap.nav
            position[:2] = x[:2]
            pose_cov.put(POSE_XY_YAW, P.take(EKF_XY_PHI) * YAW_SIGN)
            twist_cov[0, 0] = P[IV, IV]
            twist_cov[5, 5] = P[IB, IB] + s.ekf.rate_noise ** 2
            # valid once within heading_valid_sigma, until beyond heading_lost_sigma or forgotten: an IMU gap or an
            # outage widens the published covariance, it does not silence the output
            self.heading_valid = self.heading_known and P[IPHI, IPHI] <= (
                s.heading_lost_sigma if self.heading_valid else s.heading_valid_sigma) ** 2
            return float(x[IV]), self.heading_valid, True
        if m.last_fix is not None:
            position[:2] = m.last_fix[1][:2]
            pose_cov[:2, :2] = m.last_fix[2][:2, :2]
            return 0.0, False, True
        return 0.0, False, False
