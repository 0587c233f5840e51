"""Roll or pitch Kalman filter: gyro + first-order-lag inclinometer with acceleration compensation
(agnav extension of SPEC §6.2; lag model from SPEC §11.6, acceleration model from §11.6 [RECON]).

State x = [theta, gyro bias b, lagged angle theta_l]; theta' = omega_meas - b, b' = w_b,
theta_l' = (theta - theta_l) / tau; the inclinometer (minus its lagged acceleration error) measures theta_l.
The reading's variance grows with what the compensation may get wrong: the acceleration estimate's own variance,
the lag of a sensor whose time constant is off by tau_rel_sigma (error tau_rel_sigma x (a - lagged a)), and the
scale error of the reading, all correlated over the lag (taken as white noise of the same low-frequency density:
variance x 2 tau / dt per sample); the zero error the inclinometer carries is added to the reported variance (nothing
observes it). The time constant is identified online from the gyro where the motion tells it (inclinometer_lag.py;
the configured one is a data-sheet value, and units differ): then its spread is tau_rel_identified. The acceleration
term is what a GNSS epoch corrects late: mark() keeps the inputs from an epoch on, refilter() runs them again with
the correction (a fixed-lag re-filter; the gyro-only copy of checkpoint()/revert() is the cruder alternative).
Angles rad, rates rad/s, any consistent sign convention.
"""
import math
from dataclasses import dataclass, field

import numpy as np

from agnav_fusion.inclinometer_lag import LagIdentifier, LagIdentifierSettings

LAG_MIN_TAU = 0.1  # s; a shorter configured time constant means "no lag": not identified


@dataclass
class AttitudeKFSettings:
    tau: float = 1.1                # s, inclinometer first-order time constant (D5R, SPEC §11.6)
    gyro_noise: float = 5.0e-4      # rad/sqrt(s) angle random walk (ENV-05F 0.25 deg/s white at 100 Hz ~ 4.4e-4)
    bias_walk: float = 5.0e-4       # rad/s/sqrt(s), gyro bias random walk (motion-induced bias changes) [IMPL]
    incl_noise: float = 0.02        # rad, inclinometer noise incl. coloured residuals (scale, cross-axis) [IMPL]
    init_bias_sigma: float = 0.01   # rad/s, initial gyro bias uncertainty (~0.6 deg/s)
    init_angle_sigma: float = 0.05  # rad
    gate: float = 16.0              # squared Mahalanobis gate for inclinometer samples (1 dof)
    tau_rel_sigma: float = 0.5      # relative spread of the true time constant about tau (units differ, D5R 0.3-1.5 s)
    scale_sigma: float = 0.03       # relative scale error of the reading (D5R 3 %)
    zero_sigma: float = 0.003       # rad, zero error left after calibration (reported, not estimated)
    identify_tau: bool = True       # estimate the time constant online from the gyro (inclinometer_lag.py)
    tau_rel_identified: float = 0.2  # relative spread of the time constant once identified
    lag: LagIdentifierSettings = field(default_factory=LagIdentifierSettings)
    gyro_hold: float = 3.0          # s, longest a gyro-only copy waits for the GNSS to confirm the compensation


class AttitudeKF:
    """Linear KF of one tilt axis; update() per IMU sample, with or without an inclinometer reading. The 3 states and
    the 6 distinct covariance entries are plain floats (the per-sample path; `x`, `P` give them as arrays)."""

    def __init__(self, settings=None):
        self.settings = settings or AttitudeKFSettings()
        self._x = None   # (angle, bias, lagged angle)
        self._p = None   # (P00, P01, P02, P11, P12, P22)
        self._acc_lag = 0.0
        self.rejected = 0
        self.log = None  # list of (F, x_pred, P_pred, x_filt, P_filt) per step, for kalman.smooth_log
        s = self.settings
        self.lag = LagIdentifier(s.tau, s.lag) if s.identify_tau and s.tau >= LAG_MIN_TAU else None
        self._gyro_only = None  # [x, p, age] since the last checkpoint, propagated by the gyro alone
        self._inputs = None  # inputs since mark(), each with the state before it: re-filtered by refilter()
        self._held = 0.0     # s of IMU samples in them
        self._walk = None    # (extra bias variance per s, s left) of a bias change still under way

    def _init(self, incl):
        s = self.settings
        angle, bias = s.init_angle_sigma ** 2, s.init_bias_sigma ** 2
        self._x, self._p = (incl, 0.0, incl), (angle, 0.0, 0.0, bias, 0.0, angle)

    def update(self, rate, incl, dt, accel_error=0.0, accel_var=0.0):
        """Propagate with the gyro rate over dt, then fuse incl (rad, or None) whose acceleration error
        accel_error (rad, the unlagged a/g term the inclinometer adds; variance accel_var) is removed through the
        same lag."""
        s = self.settings
        if self._x is None:
            if incl is None:
                return None
            self._init(incl)
            self._acc_lag = accel_error
        tau_id = self.lag.update(rate - self._x[1], incl, accel_error, dt) if self.lag else None
        tau, tau_rel = (tau_id, s.tau_rel_identified) if tau_id else (s.tau, s.tau_rel_sigma)
        if self._inputs is not None:  # (kept for gyro_hold s at most)
            self._inputs.append((self._state(), rate, incl, dt, accel_error, accel_var, tau, tau_rel))
            self._held += dt
            self._inputs = self._inputs if self._held <= s.gyro_hold else None
        return self._step(rate, incl, dt, accel_error, accel_var, tau, tau_rel)

    def _step(self, rate, incl, dt, accel_error, accel_var, tau, tau_rel):
        s = self.settings
        a = 1.0 - math.exp(-dt / tau) if tau > 0 else 1.0  # exact first-order lag: stable for any dt (IMU gaps)
        walk = s.bias_walk ** 2 * dt
        if self._walk is not None:
            per_s, left = self._walk
            walk += per_s * min(dt, left)
            self._walk = (per_s, left - dt) if left > dt else None
        x, p = self._predict(self._x, self._p, a, rate, dt, walk)
        if self._gyro_only is not None:
            age = self._gyro_only[2] + dt
            self._gyro_only = [*self._predict(*self._gyro_only[:2], a, rate, dt, walk), age] \
                if age <= s.gyro_hold else None
        lag_miss = tau_rel * (accel_error - self._acc_lag)
        self._acc_lag += a * (accel_error - self._acc_lag)
        x_pred, p_pred = x, p
        if incl is not None:
            # coloured errors (correlated over the lag): as white noise of the same low-frequency density
            coloured = accel_var + lag_miss ** 2 + (s.scale_sigma * incl) ** 2
            r = s.incl_noise ** 2 + coloured * 2.0 * max(tau, dt) / max(dt, 1e-3)
            x, p = self._update(x, p, incl - self._acc_lag, r, 2)
        self._x, self._p = x, p
        if self.log is not None:
            F = np.array([[1.0, -dt, 0.0], [0.0, 1.0, 0.0], [a, 0.0, 1.0 - a]])
            self.log.append((F, np.array(x_pred), _matrix(p_pred), self.x, self.P))
        return x[0]

    def _predict(self, x, p, a, rate, dt, walk):
        """x <- F x + (rate dt, 0, 0), P <- F P F^T + Q for F = [[1, -dt, 0], [0, 1, 0], [a, 0, 1 - a]]; walk: the
        bias variance the step adds."""
        s, b = self.settings, 1.0 - a
        p00, p01, p02, p11, p12, p22 = p
        r00, r02 = p00 - dt * p01, p02 - dt * p12       # (F P) row 0, columns 0 and 2
        r20 = a * p00 + b * p02                         # (F P) row 2, column 0
        q00 = r00 - dt * (p01 - dt * p11) + s.gyro_noise ** 2 * dt
        q01 = p01 - dt * p11
        q02 = a * r00 + b * r02
        q12 = a * p01 + b * p12
        q22 = a * r20 + b * (a * p02 + b * p22)
        x0, x1, x2 = x
        return (x0 - dt * x1 + rate * dt, x1, a * x0 + b * x2), (q00, q01, q02, p11 + walk, q12, q22)

    def _update(self, x, p, z, r, j):
        """The reading z (variance r) of state j (0 angle, 2 lagged angle), gated (a refused reading is counted)."""
        p00, p01, p02, p11, p12, p22 = p
        c0, c1, c2 = (p00, p01, p02) if j == 0 else (p02, p12, p22)  # P's column j
        S = c2 + r if j else c0 + r
        y = z - x[j]
        if y * y / S > self.settings.gate:
            self.rejected += 1
            return x, p
        k0, k1, k2 = c0 / S, c1 / S, c2 / S
        return ((x[0] + k0 * y, x[1] + k1 * y, x[2] + k2 * y),
                (p00 - k0 * c0, p01 - k0 * c1, p02 - k0 * c2, p11 - k1 * c1, p12 - k1 * c2, p22 - k2 * c2))

    def observe(self, angle, var):
        """A direct reading of the angle (variance var, rad^2), gated like the inclinometer's."""
        if self._x is not None:
            if self._inputs is not None:
                self._inputs.append((self._state(), angle, var))
            self._x, self._p = self._update(self._x, self._p, angle, var, 0)

    def checkpoint(self):
        """Keep a gyro-only copy from here (at a GNSS epoch that confirmed the acceleration compensation)."""
        if self._x is not None:
            self._gyro_only = [self._x, self._p, 0.0]

    def _state(self):
        return self._x, self._p, self._acc_lag, self.rejected, self._walk

    def mark(self, after=0):
        """Keep the inputs from the `after`-th last IMU sample on (a GNSS epoch `after` samples ago: the speed
        model's acceleration, which the readings were compensated for, is what the next epoch corrects)."""
        inputs, imu = self._inputs, [i for i, e in enumerate(self._inputs or ()) if _is_imu(e)]
        if imu and after:  # (all of them when fewer: the window reaches the epochs again from the next fix)
            self._inputs = inputs[imu[-min(after, len(imu))]:]
            self._held = sum(e[3] for e in self._inputs if _is_imu(e))
        elif self._x is not None:
            self._inputs, self._held = [], 0.0

    def refilter(self, change, after=0, change_after=0.0):
        """The acceleration term removed from the readings since mark() was off by `change` (rad, a/g: the speed
        model's acceleration as a later GNSS epoch corrected it), on the last `after` IMU samples (after that epoch)
        by `change_after`: the filter runs again from the mark with them (and its direct readings)."""
        if not self._inputs:
            return
        inputs = self._inputs
        (self._x, self._p, self._acc_lag, self.rejected, self._walk), self._gyro_only = inputs[0][0], None
        imu = sum(map(_is_imu, inputs))
        if self.log is not None:
            del self.log[len(self.log) - imu:]
        self._inputs = kept = []
        step, n, last_before = self._step, 0, imu - after
        for entry in inputs:  # (the per-fix path: no unpacking into lists)
            if not _is_imu(entry):
                self.observe(*entry[1:])
                continue
            _, rate, incl, dt, accel_error, accel_var, tau, tau_rel = entry
            n += 1
            accel_error += change if n <= last_before else change_after
            kept.append((self._state(), rate, incl, dt, accel_error, accel_var, tau, tau_rel))
            step(rate, incl, dt, accel_error, accel_var, tau, tau_rel)

    def add_bias_variance(self, var, spread=0.0):
        """The gyro bias may move by this much (rad/s)^2 (a vibratory gyro's motion bias at a start) over the next
        `spread` s (evenly: 0 at once); the gyro-only copy and the marked state take it too."""
        if spread > 0.0:
            self._set_walk((var / spread, spread))
            return

        def added(p):
            return p if p is None else (p[0], p[1], p[2], p[3] + var, p[4], p[5])
        self._p = added(self._p)
        if self._gyro_only is not None:
            self._gyro_only[1] = added(self._gyro_only[1])
        if self._inputs:  # the marked state
            (x, p, *rest), *entry = self._inputs[0]
            self._inputs[0] = ((x, added(p), *rest), *entry)

    def end_bias_change(self):
        """The bias change under way (add_bias_variance with a spread) stops: the vehicle stands again (from the
        marked state on, which a re-filter starts from)."""
        self._set_walk(None)

    def _set_walk(self, walk):
        self._walk = walk
        if self._inputs:  # the marked state
            (*state, _), *entry = self._inputs[0]
            self._inputs[0] = ((*state, walk), *entry)

    def revert(self):
        """The acceleration removed from the readings since the checkpoint was wrong (a start or a braking seen late
        by the GNSS): the gyro-only copy replaces the filter, so the gyro bias is not bent by it."""
        if self._gyro_only is not None:
            self._x, self._p = self._gyro_only[:2]
            self._gyro_only = None

    @property
    def x(self):
        return None if self._x is None else np.array(self._x)

    @property
    def P(self):
        return None if self._p is None else _matrix(self._p)

    @property
    def angle(self):
        return None if self._x is None else self._x[0]

    @property
    def variance(self):
        return math.inf if self._p is None else self._p[0] + self.settings.zero_sigma ** 2

    @property
    def bias(self):
        return 0.0 if self._x is None else self._x[1]


def _is_imu(entry):
    """A kept input is an IMU sample (state before it, rate, incl, dt, accel_error, accel_var, tau, tau_rel) or a
    direct reading (state before it, angle, var)."""
    return len(entry) > 3


def _matrix(p):
    p00, p01, p02, p11, p12, p22 = p
    return np.array([[p00, p01, p02], [p01, p11, p12], [p02, p12, p22]])
