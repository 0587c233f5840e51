"""Horizontal navigation EKF: yaw gyro + tilt-corrected GNSS position (and optionally GNSS velocity)
(agnav extension of SPEC §6.3: replaces Kise/drift LSM + dead reckoning with one filter giving covariances).

Thesis conventions: state x = [X east, Y north, phi heading cw from north, b yaw-gyro bias, V speed, A accel,
BX, BY receiver bias]; X' = V sin phi, Y' = V cos phi (as 5.12-5.13), phi' = r - b (r clockwise gyro rate), V' = A,
A' = -A/tau + w; a fix measures (X + BX, Y + BY) + white noise, the bias being the receiver's slow (Gauss-Markov)
error: the track's shape then carries the heading to the precision of the white part, as in the Kise LSM (4.1-4.11).
"""
import math
from dataclasses import dataclass

import numpy as np

from agnav_fusion import kalman

IX, IY, IPHI, IB, IV, IA, IBX, IBY = range(8)
DIAG8 = np.diag_indices(8)


@dataclass
class NavEKFSettings:
    rate_noise: float = 0.003      # rad/s/sqrt(Hz) heading random walk from gyro noise
    bias_walk: float = 1.0e-4      # rad/s/sqrt(s) yaw-gyro bias random walk
    jerk_noise: float = 0.3        # m/s^3/sqrt(Hz) longitudinal jerk
    accel_tau: float = 2.0         # s, longitudinal acceleration is Gauss-Markov (decays to 0 without fixes)
    slip_noise: float = 0.005      # m/sqrt(s) unmodelled position motion (slip, sway)
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

    def split_fix_covariance(self, cov):
        """(white 2x2 covariance, slow-bias variance per axis) of a fix's horizontal covariance; sets the bias
        variance the prediction keeps. Without bias states the whole covariance is white."""
        cov = np.asarray(cov, dtype=float)[:2, :2]
        s = self.settings
        if s.gnss_bias_tau <= 0:
            return cov, 0.0
        total = float(np.trace(cov)) / 2
        self.gnss_bias_var = max(total - s.gnss_white_sigma ** 2, 0.0)
        return cov - self.gnss_bias_var * np.eye(2), self.gnss_bias_var

    def initialise(self, xy, xy_cov, heading, speed=0.0):
        s = self.settings
        self.x = np.array([xy[0], xy[1], heading, 0.0, speed, 0.0, 0.0, 0.0])
        self.P = np.zeros((8, 8))
        self.P[:2, :2] = np.asarray(xy_cov) + self.gnss_bias_var * np.eye(2)
        self.P[IBX, IBX] = self.P[IBY, IBY] = self.gnss_bias_var
        self.P[IX, IBX] = self.P[IBX, IX] = self.P[IY, IBY] = self.P[IBY, IY] = -self.gnss_bias_var
        self.P[IPHI:IBX, IPHI:IBX] = np.diag([s.init_heading_sigma, s.init_bias_sigma, s.init_speed_sigma, 0.5]) ** 2

    def reset_position(self, xy, xy_cov):
        """Re-initialise the position (a fix the gate kept refusing): the old position, and what it implied for the
        other states, is forgotten."""
        self.x[IX], self.x[IY] = xy
        self.P[:2, :] = self.P[:, :2] = 0.0
        self.P[:2, :2] = np.asarray(xy_cov) + self.gnss_bias_var * np.eye(2)
        self.P[IX, IBX] = self.P[IBX, IX] = self.P[IY, IBY] = self.P[IBY, IY] = -self.gnss_bias_var

    def transition(self, dt):
        """Jacobian F of one propagation step at the current state."""
        phi, v = self.x[IPHI], self.x[IV]
        F = np.eye(8)
        F[IX, IPHI], F[IX, IV] = v * math.cos(phi) * dt, math.sin(phi) * dt
        F[IY, IPHI], F[IY, IV] = -v * math.sin(phi) * dt, math.cos(phi) * dt
        F[IPHI, IB] = -dt
        F[IV, IA] = dt
        F[IA, IA] = math.exp(-dt / self.settings.accel_tau)
        tau = self.settings.gnss_bias_tau
        F[IBX, IBX] = F[IBY, IBY] = math.exp(-dt / tau) if tau > 0 else 0.0
        return F

    def predict(self, rate, dt):
        """Propagate with the clockwise yaw rate r (rad/s) over dt (s)."""
        s = self.settings
        F = self.transition(dt)
        phi, v = self.x[IPHI], self.x[IV]
        x = self.x.copy()
        x[IX] += v * math.sin(phi) * dt
        x[IY] += v * math.cos(phi) * dt
        x[IPHI] = math.remainder(phi + (rate - x[IB]) * dt, 2 * math.pi)
        x[IV] += x[IA] * dt
        x[IA] *= F[IA, IA]
        x[IBX:] *= F[IBX, IBX]
        q_bias = self.gnss_bias_var * (1.0 - F[IBX, IBX] ** 2)   # keeps the Gauss-Markov variance stationary
        P = F @ self.P @ F.T
        P[DIAG8] += (s.slip_noise ** 2 * dt, s.slip_noise ** 2 * dt, s.rate_noise ** 2 * dt,
                     s.bias_walk ** 2 * dt, 0.0, s.jerk_noise ** 2 * dt, q_bias, q_bias)
        self.P = P
        self.x = x
        if self.log is not None:
            self.log.append([F, x.copy(), self.P.copy(), x.copy(), self.P.copy()])

    def update(self, y, S, H, R):
        """Apply a (gated) innovation from position_innovation / velocity_innovation."""
        self.x, self.P = kalman.update(self.x, self.P, y, S, H, R)
        self.x[IPHI] = math.remainder(self.x[IPHI], 2 * math.pi)
        if self.log:
            self.log[-1][3:] = [self.x.copy(), self.P.copy()]

    def position_innovation(self, xy, R):
        """(y, S, d2, H) of a horizontal position fix (position + receiver bias; R its white covariance)."""
        H = np.zeros((2, 8))
        H[0, IX] = H[1, IY] = H[0, IBX] = H[1, IBY] = 1.0
        y, S, d2 = kalman.innovation(self.x, self.P, np.asarray(xy, dtype=float), H, R)
        return y, S, d2, H

    def zero_rate_innovation(self, rate, var):
        """(y, S, H, R) of a standstill: the clockwise gyro rate reads the bias b, with variance var (rad/s)^2."""
        H = np.zeros((1, 8))
        H[0, IB] = 1.0
        R = np.array([[var]])
        y, S, _ = kalman.innovation(self.x, self.P, np.array([rate]), H, R)
        return y, S, H, R

    def speed_innovation(self, speed, var):
        """(y, S, d2, H, R) of a ground-speed measurement (m/s) with variance var: no heading needed."""
        H = np.zeros((1, 8))
        H[0, IV] = 1.0
        R = np.array([[var]])
        y, S, d2 = kalman.innovation(self.x, self.P, np.array([speed]), H, R)
        return y, S, d2, H, R

    def standstill_innovation(self, var):
        """(y, S, d2, H, R) of standing still: speed 0 (variance var) and acceleration 0 (var per s^2)."""
        H = np.zeros((2, 8))
        H[0, IV] = H[1, IA] = 1.0
        R = var * np.eye(2)
        y, S, d2 = kalman.innovation(self.x, self.P, np.zeros(2), H, R)
        return y, S, d2, H, R

    def velocity_innovation(self, v_en, R):
        """(y, S, d2, H) of a horizontal velocity (east, north) measurement of the reference point."""
        phi, v = self.x[IPHI], self.x[IV]
        h = np.array([v * math.sin(phi), v * math.cos(phi)])
        H = np.zeros((2, 8))
        H[0, IPHI], H[0, IV] = v * math.cos(phi), math.sin(phi)
        H[1, IPHI], H[1, IV] = -v * math.sin(phi), math.cos(phi)
        y, S, d2 = kalman.innovation(self.x, self.P, np.asarray(v_en, dtype=float), H, R, h=h)
        return y, S, d2, H
