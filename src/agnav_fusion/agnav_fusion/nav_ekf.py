"""Horizontal navigation EKF: yaw gyro + tilt-corrected GNSS position (and optionally GNSS velocity)
(agnav extension of SPEC §6.3: replaces Kise/drift LSM + dead reckoning with one filter giving covariances).

Thesis conventions: state x = [X east, Y north, phi heading cw from north, b yaw-gyro bias, V speed, A accel,
BX, BY receiver bias, beta crab residual, k crab per sin(roll), rho terrain roll, w wheel-speed scale error,
s yaw-gyro scale error];
the course over ground is
phi + crab, crab = beta + k sin(rho) (non-holonomic constraint with side slip: the vehicle moves along its heading
turned by the crab), X' = V sin(phi + crab), Y' = V cos(phi + crab) (as 5.12-5.13), phi' = (1 + s) r - b (r clockwise
gyro rate; s is learnt in turns while fixes arrive and keeps a U-turn in an outage on course). A tractor slides downhill on a cross slope: the slide k sin(rho) follows the terrain roll rho (the estimated
roll through a lag that drops the sway; an input, no variance) with a gain k learnt online (prior crab_roll_gain);
it is what separates the crab from the heading: a course offset that flips with the roll when the vehicle turns
on the slope is crab, one that stays is heading. beta, the slide left unexplained, is Gauss-Markov. Speed: without an accelerometer V' = A + w_V, A' = -A/tau + w (a tractor keeps
its speed); with one V' = a - A + w_V, A being the along-track accelerometer bias (random walk; it also takes the
pitch error of the gravity compensation). A fix measures (X + BX, Y + BY) + white noise, the bias being the
receiver's slow (Gauss-Markov) error: the track's shape then carries the heading to the precision of the white part,
as in the Kise LSM (4.1-4.11).
"""
import math
from dataclasses import dataclass

import numpy as np

from agnav_fusion import kalman

IX, IY, IPHI, IB, IV, IA, IBX, IBY, IC, IK, IR, IW, IS = range(13)
N = 13
F_AT = np.ravel_multi_index(np.array([(IX, IPHI), (IX, IC), (IY, IPHI), (IY, IC), (IX, IK), (IY, IK), (IX, IV), (IY, IV),
                                      (IPHI, IB), (IPHI, IS), (IV, IA), (IA, IA), (IBX, IBX), (IBY, IBY), (IC, IC),
                                      (IR, IR)]).T, (N, N))  # F's entries that predict() fills


def same_error_class(slow_var, other):
    """Two fixes' slow-error variances of one receiver class (within 4x): across a class change (RTK fixed <->
    float, DGPS) the slow error jumps, so neither it nor a difference of fixes carries over."""
    return 0.25 * slow_var <= other <= 4.0 * slow_var


@dataclass
class NavEKFSettings:
    rate_noise: float = 0.003      # rad/s/sqrt(Hz) heading random walk from gyro noise
    bias_walk: float = 1.0e-4      # rad/s/sqrt(s) yaw-gyro bias random walk
    jerk_noise: float = 0.05       # m/s^3/sqrt(Hz) longitudinal jerk (no accelerometer)
    accel_tau: float = 6.0         # s, longitudinal acceleration is Gauss-Markov (starts and stops last seconds)
    coast_accel_tau: float = 2.0   # s, its correlation time once a fix is overdue (coasting), which forgets the
    #                                acceleration the fixes no longer confirm (no extrapolation through an outage)
    speed_walk: float = 0.02       # m/s/sqrt(s) speed random walk (throttle, load, wheel slip changes)
    accel_noise: float = 0.1       # m/s^2/sqrt(Hz) along-track accelerometer: vibration and sway residuals
    accel_bias_walk: float = 0.005  # m/s^2/sqrt(s) accelerometer bias + gravity-compensation (pitch) error walk
    accel_bias_sigma: float = 0.1  # m/s^2, initial accelerometer bias (MEMS zero-g offset + pitch error)
    crab_sigma: float = 0.009      # rad, crab (side-slip) spread the roll model leaves (0.5 deg: draft, toe-in)
    crab_tau: float = 30.0         # s, crab correlation time (slope and soil change slowly)
    crab_roll_gain: float = 0.2    # crab per sin(roll) (rad): expected downhill slide, the learnt gain's prior
    crab_gain_sigma: float = 0.3   # rad, spread of that gain (soil, tyres, load)
    crab_gain_walk: float = 0.002  # rad/sqrt(s), change of that gain (soil)
    crab_roll_tau: float = 3.0     # s, lag from the estimated roll to the terrain roll driving the crab (no sway)
    slip_noise: float = 0.005      # m/sqrt(s) unmodelled position motion (slip, sway)
    wheel_scale_sigma: float = 0.1  # wheel/radar speed scale error (wheel slip, rolling radius): reads V (1 + w)
    wheel_scale_walk: float = 0.002  # 1/sqrt(s), change of that scale (soil, load)
    gyro_scale_sigma: float = 0.01  # yaw-gyro scale error (ENV-05 class: 1 %)
    gyro_scale_walk: float = 1.0e-5  # 1/sqrt(s), change of that scale (temperature)
    init_heading_sigma: float = 0.2  # rad, heading from a first course over ground (before the chord)
    init_bias_sigma: float = 0.005  # rad/s
    init_speed_sigma: float = 0.5    # m/s, speed at the first fix
    gnss_bias_tau: float = 0.0     # s, correlation time of the receiver's slow error; 0: fixes are white (no bias)
    gnss_white_sigma: float = 0.025  # m per axis, fix-to-fix part of the receiver error; the rest of a fix's
    #                                  covariance is the slow bias (used when gnss_bias_tau > 0)


class NavEKF:
    """predict() per IMU sample, update_position()/update_velocity() per GNSS epoch; x, P public."""

    def __init__(self, settings=None):
        self.settings = settings or NavEKFSettings()
        self.x = None
        self.P = None
        self.log = None  # (F, x_pred, P_pred, x_filt, P_filt) per predict+updates, for kalman.smooth_log
        self.gnss_bias_var = 0.0  # m^2 per axis, the receiver's slow-error variance (split_fix_covariance)
        self.accel_mode = False   # A is the accelerometer bias (set_accel_mode)
        self.bias_changed = False  # the latest fix's slow-error variance is under a quarter or over 4x the one before
        self._F = np.eye(N)  # the transition matrix, refilled per step
        self._decay_key, self._decay_f = None, None
        self._q_key, self._q = None, None

    def split_fix_covariance(self, cov):
        """(white 2x2 covariance, slow-bias variance per axis) of a fix's horizontal covariance; sets the bias
        variance the prediction keeps. Without bias states the whole covariance is white."""
        cov = np.asarray(cov, dtype=float)[:2, :2]
        s = self.settings
        if s.gnss_bias_tau <= 0:
            return cov, 0.0
        total = float(np.trace(cov)) / 2
        old, self.gnss_bias_var = self.gnss_bias_var, max(total - s.gnss_white_sigma ** 2, 0.0)
        self.bias_changed = not same_error_class(old, self.gnss_bias_var)
        return cov - self.gnss_bias_var * np.eye(2), self.gnss_bias_var

    def bias_change_variance(self, interval):
        """Per-axis variance (m^2) of the receiver's slow error's change over `interval` s: what a difference of
        two fixes carries besides their white parts (an RTK float error wanders decimetres in seconds)."""
        tau = self.settings.gnss_bias_tau
        return -2.0 * self.gnss_bias_var * math.expm1(-interval / tau) if tau > 0 else 0.0

    def restart_bias(self):
        """The receiver's error class changed (RTK fixed <-> float, DGPS): the slow error learnt is its old one, the
        new one starts at zero with the new variance (the position keeps what it knew). A rise matters as much as a
        drop: left at the fixed class's variance, the bias state would let the first float fixes pull the position."""
        self.x[IBX:IC] = 0.0
        self.P[IBX:IC, :] = self.P[:, IBX:IC] = 0.0
        self.P[IBX, IBX] = self.P[IBY, IBY] = self.gnss_bias_var
        self.bias_changed = False

    def initialise(self, xy, xy_cov, heading, speed=0.0):
        s = self.settings
        self.x = np.array([xy[0], xy[1], heading, 0.0, speed, 0.0, 0.0, 0.0, 0.0, s.crab_roll_gain, 0.0, 0.0, 0.0])
        self.P = np.zeros((N, N))
        self.P[:2, :2] = np.asarray(xy_cov) + self.gnss_bias_var * np.eye(2)
        self.P[IBX, IBX] = self.P[IBY, IBY] = self.gnss_bias_var
        self.P[IX, IBX] = self.P[IBX, IX] = self.P[IY, IBY] = self.P[IBY, IY] = -self.gnss_bias_var
        a_sigma = s.accel_bias_sigma if self.accel_mode else 0.5
        self.P[IPHI:IBX, IPHI:IBX] = np.diag([s.init_heading_sigma, s.init_bias_sigma, s.init_speed_sigma, a_sigma]) ** 2
        self.P[IC, IC] = s.crab_sigma ** 2
        self.P[IK, IK] = s.crab_gain_sigma ** 2
        self.P[IW, IW] = s.wheel_scale_sigma ** 2
        self.P[IS, IS] = s.gyro_scale_sigma ** 2

    def set_accel_mode(self, on):
        """Switch A between the Gauss-Markov acceleration and the accelerometer bias (a new, uncorrelated start)."""
        if on == self.accel_mode:
            return
        self.accel_mode = on
        self._decay_key = None
        if self.x is not None:
            self._restart_a(self.settings.accel_bias_sigma ** 2 if on else 0.5 ** 2)

    def _restart_a(self, variance):
        """A from scratch: mean 0, this variance, uncorrelated with the other states."""
        self.x[IA] = 0.0
        self.P[IA, :] = self.P[:, IA] = 0.0
        self.P[IA, IA] = variance

    def crab_jacobian(self):
        """d crab / d (beta, k)."""
        return np.array([1.0, math.sin(self.x[IR])])

    def crab(self):
        """(crab rad, variance): h x and h P h^T for h = crab_jacobian(), on floats in numpy's order of operations."""
        x, P = self.x, self.P
        k = math.sin(x[IR])
        pcc, pck, pkc, pkk = P[IC, IC], P[IC, IK], P[IK, IC], P[IK, IK]
        return float(x[IC] + k * x[IK]), float((pcc + k * pkc) + (pck + k * pkk) * k)

    def _process_noise(self, dt, fb, fc, coasting):
        """Diagonal Q of one step (cached: dt, mode and receiver-bias variance repeat); coasting keeps A's stationary
        variance (jerk_noise^2 accel_tau / 2) with the shorter correlation time."""
        key = (dt, self.accel_mode, self.gnss_bias_var, coasting)
        if key != self._q_key:
            s = self.settings
            q_bias = self.gnss_bias_var * (1.0 - fb ** 2)   # keeps the Gauss-Markov variance stationary
            q_v = s.speed_walk ** 2 + (s.accel_noise ** 2 if self.accel_mode else 0.0)
            q_a = s.accel_bias_walk ** 2 if self.accel_mode else s.jerk_noise ** 2 * (
                s.accel_tau / s.coast_accel_tau if coasting else 1.0)
            self._q_key = key
            self._q = np.array((s.slip_noise ** 2 * dt, s.slip_noise ** 2 * dt, s.rate_noise ** 2 * dt,
                                s.bias_walk ** 2 * dt, q_v * dt, q_a * dt, q_bias, q_bias,
                                s.crab_sigma ** 2 * (1.0 - fc ** 2), s.crab_gain_walk ** 2 * dt, 0.0,
                                s.wheel_scale_walk ** 2 * dt, s.gyro_scale_walk ** 2 * dt))
        return self._q

    def course(self):
        return self.x[IPHI] + self.crab_jacobian() @ self.x[IC:IR]

    def reset_position(self, xy, xy_cov, lever_jacobian=None):
        """Re-initialise the position (a fix the gate kept refusing, or the fix that starts the heading): the old
        position, and what it implied for the other states, is forgotten. lever_jacobian: d(antenna offset)/d(heading)
        of a fix moved to the reference point with the current heading, whose error it then shares (a later fix
        must not read the antenna lever's placement as news about the heading)."""
        self.x[IX], self.x[IY] = xy
        P = self.P
        P[:2, :] = P[:, :2] = 0.0
        P[:2, :2] = np.asarray(xy_cov) + self.gnss_bias_var * np.eye(2)
        P[IX, IBX] = P[IBX, IX] = P[IY, IBY] = P[IBY, IY] = -self.gnss_bias_var
        if lever_jacobian is not None:
            j = np.asarray(lever_jacobian, dtype=float)
            cross = -np.outer(j, P[IPHI, 2:])  # position error = -j x heading error (+ the fix's own)
            P[:2, 2:] += cross
            P[2:, :2] += cross.T
            P[:2, :2] += np.outer(j, j) * P[IPHI, IPHI]

    def forget_acceleration(self):
        """A fix is overdue: the acceleration estimated from the fixes (mostly their noise at a steady speed) is not
        extrapolated; A returns to its prior (mean 0, stationary variance, uncorrelated). No-op with an accelerometer."""
        if self.x is not None and not self.accel_mode:
            self._restart_a(self.settings.jerk_noise ** 2 * self.settings.accel_tau / 2.0)

    def _decay(self, dt, coasting):
        """(A, receiver bias, crab, terrain roll) Gauss-Markov factors over dt (cached: dt repeats)."""
        if (dt, coasting) != self._decay_key:
            s = self.settings
            self._decay_key = (dt, coasting)
            tau = s.coast_accel_tau if coasting else s.accel_tau
            self._decay_f = (1.0 if self.accel_mode else math.exp(-dt / tau),
                             math.exp(-dt / s.gnss_bias_tau) if s.gnss_bias_tau > 0 else 0.0,
                             math.exp(-dt / s.crab_tau), math.exp(-dt / s.crab_roll_tau))
        return self._decay_f

    def predict(self, rate, dt, accel=None, roll=0.0, coasting=False):
        """Propagate with the clockwise yaw rate r (rad/s) over dt (s); accel: along-track acceleration (m/s^2,
        gravity-compensated) in accelerometer mode; roll (rad, right side down) drives the crab model; coasting: no
        fix for a while (the acceleration decays with coast_accel_tau)."""
        x = self.x.tolist()  # Python floats: the same IEEE arithmetic as numpy scalars, a fraction of the cost
        fa, fb, fc, fr = self._decay(dt, coasting)
        v, sin_rho = x[IV], math.sin(x[IR])
        c = x[IPHI] + (x[IC] + sin_rho * x[IK])
        sin_c, cos_c = math.sin(c), math.cos(c)
        # Jacobian F at the state before the step: one matrix refilled (a new one per step while logging)
        F = self._F if self.log is None else np.eye(N)
        vc, vs = v * cos_c * dt, -v * sin_c * dt
        F.ravel()[F_AT] = (vc, vc, vs, vs, vc * sin_rho, vs * sin_rho, sin_c * dt, cos_c * dt, -dt, rate * dt,
                           -dt if self.accel_mode else dt, fa, fb, fb, fc, fr)
        x[IX] += v * sin_c * dt
        x[IY] += v * cos_c * dt
        x[IPHI] = math.remainder(x[IPHI] + ((1.0 + x[IS]) * rate - x[IB]) * dt, 2 * math.pi)
        if self.accel_mode:
            x[IV] += ((accel or 0.0) - x[IA]) * dt
        elif (v + x[IA] * dt) * v < 0.0:  # braking ends at rest: the model never reverses, only a measurement does
            x[IV] = x[IA] = 0.0
        else:
            x[IV] += x[IA] * dt
        x[IA] *= fa
        x[IBX] *= fb
        x[IBY] *= fb
        x[IC] *= fc
        x[IR] = roll + fr * (x[IR] - roll)
        P = np.dot(np.dot(F, self.P), F.T)  # np.dot: the same dgemm as @, less overhead
        P.ravel()[::N + 1] += self._process_noise(dt, fb, fc, coasting)
        self.P = P
        self.x = x = np.array(x)
        if self.log is not None:
            self.log.append([F, x.copy(), self.P.copy(), x.copy(), self.P.copy()])

    def update(self, y, S, H, R):
        """Apply a (gated) innovation from position_innovation / velocity_innovation."""
        self.x, self.P = kalman.update(self.x, self.P, y, S, H, R)
        self.x[IPHI] = math.remainder(self.x[IPHI], 2 * math.pi)
        if self.log:
            self.log[-1][3:] = [self.x.copy(), self.P.copy()]

    def position_innovation(self, xy, R, lever_jacobian=(0.0, 0.0)):
        """(y, S, d2, H) of a horizontal position fix (position + receiver bias; R its white covariance), the fix
        moved to the reference point with the current heading: lever_jacobian = d(antenna offset)/d(heading)."""
        H = np.zeros((2, N))
        H[0, IX] = H[1, IY] = H[0, IBX] = H[1, IBY] = 1.0
        H[:, IPHI] = lever_jacobian  # about the current heading: no term in the prediction
        h = self.x[IX:IPHI] + self.x[IBX:IC]
        y, S, d2 = kalman.innovation(self.x, self.P, np.asarray(xy, dtype=float), H, R, h=h)
        return y, S, d2, H

    def absorb_along_track(self, y, S, R, dt, max_accel):
        """A fix missed along the track by m = y . u (beyond 3 sigma of its own noise R): taken as an acceleration
        the speed model did not foresee, held over the dt since the last fix (braking, starting) when at most
        max_accel explains it; the variance it lacked (m^2 - u S u) enters the position along the course and the
        speed, correlated. -> True when absorbed."""
        c = self.course()
        u = np.array([math.sin(c), math.cos(c)])
        miss = float(np.asarray(y) @ u)
        lacking = miss * miss - float(u @ S @ u)
        if dt <= 0 or abs(miss) > 0.5 * max_accel * dt * dt or miss * miss <= 9.0 * float(u @ R @ u) or lacking <= 0:
            return False
        J = np.zeros(N)
        J[IX:IPHI], J[IV] = 0.5 * dt * dt * u, dt
        self.P += np.outer(J, J) * lacking / (0.25 * dt ** 4)
        return True

    def zero_rate_innovation(self, rate, var):
        """(y, S, H, R) of a standstill: the clockwise gyro rate reads the bias b, with variance var (rad/s)^2."""
        H = np.zeros((1, N))
        H[0, IB] = 1.0
        R = np.array([[var]])
        y, S, _ = kalman.innovation(self.x, self.P, np.array([rate]), H, R)
        return y, S, H, R

    def speed_innovation(self, speed, var, lag=0.0):
        """(y, S, d2, H, R) of a ground-speed measurement (m/s) with variance var, of the speed `lag` s before the
        state's time (V - A lag): no heading needed."""
        H = np.zeros((1, N))
        H[0, IV], H[0, IA] = 1.0, -lag
        R = np.array([[var]])
        y, S, d2 = kalman.innovation(self.x, self.P, np.array([speed]), H, R)
        return y, S, d2, H, R

    def wheel_innovation(self, speed, var):
        """(y, S, d2, H, R) of a wheel or radar speed (m/s) with variance var: it reads V (1 + w)."""
        H = np.zeros((1, N))
        H[0, IV], H[0, IW] = 1.0 + self.x[IW], self.x[IV]
        R = np.array([[var]])
        y, S, d2 = kalman.innovation(self.x, self.P, np.array([speed]), H, R, h=H[0, IV] * self.x[IV])
        return y, S, d2, H, R

    def standstill_innovation(self, var):
        """(y, S, d2, H, R) of standing still: speed 0 (variance var) and acceleration 0 (var per s^2)."""
        H = np.zeros((2, N))
        H[0, IV] = 1.0
        H[1, IA] = 0.0 if self.accel_mode else 1.0
        R = var * np.eye(2)
        y, S, d2 = kalman.innovation(self.x, self.P, np.zeros(2), H, R)
        return y, S, d2, H, R

    def velocity_innovation(self, v_en, R):
        """(y, S, d2, H) of a horizontal velocity (east, north) measurement of the reference point: along the course
        phi + beta."""
        c, v = self.course(), self.x[IV]
        h = np.array([v * math.sin(c), v * math.cos(c)])
        H = np.zeros((2, N))
        H[0, IPHI], H[1, IPHI] = v * math.cos(c), -v * math.sin(c)
        H[:, IC:IR] = np.outer(H[:, IPHI], self.crab_jacobian())
        H[0, IV], H[1, IV] = math.sin(c), math.cos(c)
        y, S, d2 = kalman.innovation(self.x, self.P, np.asarray(v_en, dtype=float), H, R, h=h)
        return y, S, d2, H
