"""16-state wander-azimuth INS error model with large azimuth error (SPEC §7.3, §7.4).

Continuous dynamics x' = F x + u, evaluated at x = 0 (the filter is closed-loop: every update is
fed back and the error state reset, §7.11), so the bilinear gamma/beta terms contribute only their
linear part. Index constants below are the state layout of Table 5-6-1 (0-based).
"""
import math
from dataclasses import dataclass

import numpy as np

from . import earth
from .mechanization import T

RX, RY, VX, VY, TX, TY, H, VZ = range(8)
BA = slice(8, 11)
BG = slice(11, 14)
GAMMA, BETA = 14, 15
N_STATES = 16
V3 = (VX, VY, VZ)


@dataclass
class ErrorModelSettings:
    """Process-noise PSDs U (5-6-1) and Gauss-Markov correlation times (5-4-41..46)."""

    accel_vrw: float = 0.003        # accelerometer white noise [m/s^2/sqrt(Hz)]
    gyro_arw: float = 3.0e-4         # gyro white noise [rad/s/sqrt(Hz)]
    accel_bias_sigma: float = 0.03   # steady-state GM sigma of the accelerometer bias state [m/s^2] (scale errors too)
    gyro_bias_sigma: float = 2.0e-4  # steady-state GM sigma of the gyro bias state [rad/s]
    accel_bias_tau: float = 600.0    # [s]
    gyro_bias_tau: float = 600.0     # [s]
    position_psd: float = 1.0e-18    # unmodelled position error u_r [rad^2/s]
    height_psd: float = 1.0e-4       # u_h [m^2/s]

    def psd(self):
        """Diagonal U of (5-6-1), continuous-time (Q = U dt, SPEC §9 #32)."""
        u = np.zeros(N_STATES)
        u[[RX, RY]] = self.position_psd
        u[[VX, VY, VZ]] = self.accel_vrw ** 2
        u[[TX, TY, GAMMA]] = self.gyro_arw ** 2
        u[H] = self.height_psd
        u[BA] = 2.0 * self.accel_bias_sigma ** 2 / self.accel_bias_tau
        u[BG] = 2.0 * self.gyro_bias_sigma ** 2 / self.gyro_bias_tau
        u[BETA] = 1e-12
        return u


def dynamics(settings, v, f_c, rho, omega, c_b_c, lat, h, alpha):
    """F = d(x')/dx at x = 0 for computed velocity v, specific force f_c (both in C), transport rate
    rho, earth rate omega, body->C DCM c_b_c (5-4-10..40, 5-4-41..46)."""
    r = earth.mean_radius(lat) + h
    big_omega = earth.OMEGA
    sl, cl, sa, ca = math.sin(lat), math.cos(lat), math.sin(alpha), math.cos(alpha)
    f = np.zeros((N_STATES, N_STATES))
    # error rows of transport rate and earth rate (5-4-10, 5-4-11, 5-4-26); Δλ = sa δr_x + ca δr_y
    d_rho = np.zeros((3, N_STATES))
    d_rho[0, VY], d_rho[0, H] = -1.0 / r, v[1] / r ** 2
    d_rho[1, VX], d_rho[1, H] = 1.0 / r, -v[0] / r ** 2
    d_om = np.zeros((3, N_STATES))
    d_om[0, [GAMMA, BETA, RX, RY]] = big_omega * np.array([-cl * sa, cl * ca, -sl * ca * sa, -sl * ca * ca])
    d_om[1, [GAMMA, BETA, RX, RY]] = big_omega * np.array([-cl * ca, -cl * sa, sl * sa * sa, sl * sa * ca])
    d_om[2, [RX, RY]] = big_omega * cl * np.array([sa, ca])
    # position (5-4-12..14)
    f[RX] = d_rho[0]
    f[RX, GAMMA] -= rho[1]
    f[RX, BETA] -= rho[0]
    f[RY] = d_rho[1]
    f[RY, GAMMA] += rho[0]
    f[RY, BETA] -= rho[1]
    f[H, VZ] = 1.0
    # velocity (5-4-15..24): f x δθ + C b - (δρ + 2δΩ) x v - (ρ + 2Ω) x δv + (2g/R') δh
    w = d_rho + 2.0 * d_om
    f[VX] += v[1] * w[2] - v[2] * w[1]
    f[VY] += v[2] * w[0] - v[0] * w[2]
    f[VZ] += v[0] * w[1] - v[1] * w[0]
    f[VX, TY] += -f_c[2]
    f[VY, TX] += f_c[2]
    f[VZ, TX] += -f_c[1]
    f[VZ, TY] += f_c[0]
    p = rho + 2.0 * omega
    f[VX, VY] += p[2]
    f[VX, VZ] += -p[1]
    f[VY, VZ] += p[0]
    f[VY, VX] += -p[2]
    f[VZ, VX] += p[1]
    f[VZ, VY] += -p[0]
    for i, row in enumerate(V3):
        f[row, BA] = c_b_c[i]
    # [IMPL] the z gyro bias turns the body yaw, hence the "true C" frame in which v^C is counted:
    # the velocity error absorbs that rotation, so a straight constant-velocity run carries no heading
    # information (without this row the model claims gyro-z drift is visible in the GNSS velocity)
    f[VX, BG] += v[1] * c_b_c[2]
    f[VY, BG] -= v[0] * c_b_c[2]
    f[VZ, H] += 2.0 * earth.gravity(lat, h) / r
    # attitude (5-4-25..29): δρ + δΩ - (ρ + Ω) x δθ - C d, δθ_z = 0
    wr = rho + omega
    f[TX] = d_rho[0] + d_om[0]
    f[TX, TY] += wr[2]
    f[TX, BG] = -c_b_c[0]
    f[TY] = d_rho[1] + d_om[1]
    f[TY, TX] += -wr[2]
    f[TY, BG] = -c_b_c[1]
    # azimuth (5-4-30..39): δα' = -δΩ_z + (ρ_x+Ω_x)δθ_y - (ρ_y+Ω_y)δθ_x + (C d)_z; γ' = δα', β' = 0 at x = 0
    f[GAMMA] = -d_om[2]
    f[GAMMA, TY] += wr[0]
    f[GAMMA, TX] += -wr[1]
    f[GAMMA, BG] = c_b_c[2]
    # sensor errors, first-order Gauss-Markov (5-4-41..46)
    f[BA, BA] = -np.eye(3) / settings.accel_bias_tau
    f[BG, BG] = -np.eye(3) / settings.gyro_bias_tau
    return f


def body_to_c(c_b_cbar):
    """C_B^C = T C_B^Cbar."""
    return T @ c_b_cbar
