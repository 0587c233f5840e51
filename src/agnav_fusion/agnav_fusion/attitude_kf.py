"""Roll or pitch Kalman filter: gyro + first-order-lag inclinometer with acceleration compensation
(agnav extension of SPEC §6.2; lag model from SPEC §11.6, acceleration model from §11.6 [RECON]).

State x = [theta, gyro bias b, lagged angle theta_l]; theta' = omega_meas - b, b' = w_b,
theta_l' = (theta - theta_l) / tau; the inclinometer (minus its lagged acceleration error) measures theta_l.
The reading's variance grows with what the compensation may get wrong: the acceleration estimate's own variance,
the lag of a sensor whose time constant is off by tau_rel_sigma (error tau_rel_sigma x (a - lagged a)), and the
scale error of the reading, all correlated over the lag (taken as white noise of the same low-frequency density:
variance x 2 tau / dt per sample); the zero error the inclinometer carries is added to the reported variance (nothing
observes it). The time constant is identified online from the gyro where the motion tells it (inclinometer_lag.py;
the configured one is a data-sheet value, and units differ): then its spread is tau_rel_identified.
Angles rad, rates rad/s, any consistent sign convention.
"""
import math
from dataclasses import dataclass, field

import numpy as np

from agnav_fusion import kalman
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
    """Linear KF of one tilt axis; update() per IMU sample, with or without an inclinometer reading."""

    def __init__(self, settings=None):
        self.settings = settings or AttitudeKFSettings()
        self.x = None
        self.P = None
        self._acc_lag = 0.0
        self.rejected = 0
        self.log = None  # list of (F, x_pred, P_pred, x_filt, P_filt) per step, for kalman.smooth_log
        s = self.settings
        self.lag = LagIdentifier(s.tau, s.lag) if s.identify_tau and s.tau >= LAG_MIN_TAU else None
        self._gyro_only = None  # [x, P, age] since the last checkpoint, propagated by the gyro alone

    def _init(self, incl):
        s = self.settings
        self.x = np.array([incl, 0.0, incl])
        self.P = np.diag([s.init_angle_sigma ** 2, s.init_bias_sigma ** 2, s.init_angle_sigma ** 2])

    def update(self, rate, incl, dt, accel_error=0.0, accel_var=0.0):
        """Propagate with the gyro rate over dt, then fuse incl (rad, or None) whose acceleration error
        accel_error (rad, the unlagged a/g term the inclinometer adds; variance accel_var) is removed through the
        same lag."""
        s = self.settings
        if self.x is None:
            if incl is None:
                return None
            self._init(incl)
            self._acc_lag = accel_error
        tau_id = self.lag.update(rate - self.x[1], incl, accel_error, dt) if self.lag else None
        tau, tau_rel = (tau_id, s.tau_rel_identified) if tau_id else (s.tau, s.tau_rel_sigma)
        a = 1.0 - math.exp(-dt / tau) if tau > 0 else 1.0  # exact first-order lag: stable for any dt (IMU gaps)
        F = np.array([[1.0, -dt, 0.0], [0.0, 1.0, 0.0], [a, 0.0, 1.0 - a]])
        x, P = self._predict(self.x, self.P, F, rate, dt)
        if self._gyro_only is not None:
            age = self._gyro_only[2] + dt
            self._gyro_only = [*self._predict(*self._gyro_only[:2], F, rate, dt), age] if age <= s.gyro_hold else None
        lag_miss = tau_rel * (accel_error - self._acc_lag)
        self._acc_lag += a * (accel_error - self._acc_lag)
        x_pred, P_pred = x, P
        if incl is not None:
            # coloured errors (correlated over the lag): as white noise of the same low-frequency density
            coloured = accel_var + lag_miss ** 2 + (s.scale_sigma * incl) ** 2
            r = s.incl_noise ** 2 + coloured * 2.0 * max(tau, dt) / max(dt, 1e-3)
            x, P, d2 = kalman.update_state(x, P, 2, incl - self._acc_lag, r, s.gate)
            self.rejected += d2 > s.gate
        self.x, self.P = x, P
        if self.log is not None:
            self.log.append((F, x_pred, P_pred, x, P))
        return x[0]

    def _predict(self, x, P, F, rate, dt):
        s = self.settings
        x, P = kalman.predict(x, P, F, 0.0)
        P[0, 0] += s.gyro_noise ** 2 * dt
        P[1, 1] += s.bias_walk ** 2 * dt
        x[0] += rate * dt
        return x, P

    def checkpoint(self):
        """Keep a gyro-only copy from here (at a GNSS epoch that confirmed the acceleration compensation)."""
        if self.x is not None:
            self._gyro_only = [self.x.copy(), self.P.copy(), 0.0]

    def revert(self):
        """The acceleration removed from the readings since the checkpoint was wrong (a start or a braking seen late
        by the GNSS): the gyro-only copy replaces the filter, so the gyro bias is not bent by it."""
        if self._gyro_only is not None:
            self.x, self.P = self._gyro_only[:2]
            self._gyro_only = None

    @property
    def angle(self):
        return None if self.x is None else float(self.x[0])

    @property
    def variance(self):
        return math.inf if self.P is None else float(self.P[0, 0]) + self.settings.zero_sigma ** 2

    @property
    def bias(self):
        return 0.0 if self.x is None else float(self.x[1])
