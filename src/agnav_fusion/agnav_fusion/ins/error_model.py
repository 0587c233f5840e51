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
CRAB, GYRO_SCALE, WHEEL_SCALE, MOUNT_YAW = 16, 17, 18, 19  # augmented (ekf): crab (constraints), z gyro scale-factor
#                   error [-], wheel speed scale error [-] (constraints.WheelSpeed), IMU yaw mount error [rad] (ekf)
GNSS_BIAS = slice(20, 23)   # the receiver's slow error, east, north and up [m] (gnss_bias)
N_INS = 23
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
    gyro_scale_sigma: float = 0.005  # initial sigma of the z gyro scale-factor error (data sheet), learnt in turns
    gyro_scale_tau: float = 3600.0   # [s], random walk reaching gyro_scale_sigma over this time (temperature)
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


def vehicle_heading_var(p):
    """Variance of base_link's heading from P: the body axes' (γ, true - computed) and their turn off base_link's
    (the yaw mount state, computed - true) both subtract from it."""
    g, m = GAMMA, MOUNT_YAW
    return p.item(g, g) + p.item(m, m) + 2.0 * p.item(g, m) if len(p) > m else p.item(g, g)


def dynamics(settings, v, f_c, rho, omega, c_b_c, lat, h, alpha):
    """F = d(x')/dx at x = 0 (see dynamics_values)."""
    f = np.zeros(N_STATES * N_STATES)
    f[_F_INDEX] = dynamics_values(settings, v, f_c, rho, omega, c_b_c, lat, h, alpha)
    return f.reshape(N_STATES, N_STATES)


def transition(settings, v, f_c, rho, omega, c_b_c, lat, h, alpha, dt, n=N_STATES):
    """Φ = I + F dt as an n x n matrix (n >= N_STATES: identity beyond the error states)."""
    if n not in _PHI_INDEX:
        _PHI_INDEX[n] = np.array([(i // N_STATES) * n + i % N_STATES for i in _F_INDEX])
    phi = np.zeros(n * n)
    phi[_PHI_INDEX[n]] = dynamics_values(settings, v, f_c, rho, omega, c_b_c, lat, h, alpha)
    phi *= dt
    phi[::n + 1] += 1.0
    return phi.reshape(n, n)


def dynamics_values(settings, v, f_c, rho, omega, c_b_c, lat, h, alpha):
    """The nonzero entries (order of _F_INDEX) of F = d(x')/dx at x = 0 for computed velocity v, specific force f_c
    (both in C), transport rate rho, earth rate omega, body->C DCM c_b_c (5-4-10..40, 5-4-41..46). Arrays or
    Python floats, written out in scalars (the term-by-term form is `dynamics_terms` in the tests)."""
    v0, v1, v2 = _floats(v)
    f0, f1, f2 = _floats(f_c)
    r0, r1, r2 = _floats(rho)
    o0, o1, o2 = _floats(omega)
    (c0, c1, c2), (c3, c4, c5), (c6, c7, c8) = c_b_c.tolist() if isinstance(c_b_c, np.ndarray) else c_b_c
    r = earth.mean_radius(lat) + h
    om = earth.OMEGA
    sl, cl, sa, ca = math.sin(lat), math.cos(lat), math.sin(alpha), math.cos(alpha)
    ir, vr1, vr0 = 1.0 / r, v1 / r ** 2, v0 / r ** 2
    # error rows of transport rate and earth rate (5-4-10, 5-4-11, 5-4-26); Δλ = sa δr_x + ca δr_y
    og0, ob0, ox0, oy0 = om * (-cl * sa), om * (cl * ca), om * (-sl * ca * sa), om * (-sl * ca * ca)
    og1, ob1, ox1, oy1 = om * (-cl * ca), om * (-cl * sa), om * (sl * sa * sa), om * (sl * sa * ca)
    ox2, oy2 = om * cl * sa, om * cl * ca
    p0, p1, p2 = r0 + 2.0 * o0, r1 + 2.0 * o1, r2 + 2.0 * o2        # rho + 2 omega
    wr0, wr1, wr2 = r0 + o0, r1 + o1, r2 + o2                       # rho + omega
    # rows of w = δρ + 2δΩ (w2: RX, RY only) for the velocity's -(δρ + 2δΩ) x v
    wg0, wb0, wx0, wy0 = 2.0 * og0, 2.0 * ob0, 2.0 * ox0, 2.0 * oy0
    wg1, wb1, wx1, wy1 = 2.0 * og1, 2.0 * ob1, 2.0 * ox1, 2.0 * oy1
    wx2, wy2 = 2.0 * ox2, 2.0 * oy2
    g2 = 2.0 * earth.gravity(lat, h) / r
    ta, tg = -1.0 / settings.accel_bias_tau, -1.0 / settings.gyro_bias_tau
    vals = (
        # position (5-4-12..14)
        -ir, vr1, -r1, -r0,                                                   # RX: VY, H, GAMMA, BETA
        ir, -vr0, r0, -r1,                                                    # RY: VX, H, GAMMA, BETA
        1.0,                                                                  # H: VZ
        # velocity (5-4-15..24, [IMPL] z gyro bias rows: see the term form)
        -(v2 * ir), p2, -p1, -(v2 * -vr0), -(v2 * wg1), -(v2 * wb1), v1 * wx2 - v2 * wx1, v1 * wy2 - v2 * wy1,
        -f2, c0, c1, c2, v1 * c6, v1 * c7, v1 * c8,
        -p2, v2 * -ir, p0, v2 * vr1, v2 * wg0, v2 * wb0, v2 * wx0 - v0 * wx2, v2 * wy0 - v0 * wy2,
        f2, c3, c4, c5, -(v0 * c6), -(v0 * c7), -(v0 * c8),
        v0 * ir + p1, -(v1 * -ir) + -p0, v0 * -vr0 - v1 * vr1 + g2, v0 * wg1 - v1 * wg0, v0 * wb1 - v1 * wb0,
        v0 * wx1 - v1 * wx0, v0 * wy1 - v1 * wy0, -f1, f0, c6, c7, c8,
        # attitude (5-4-25..29): δρ + δΩ - (ρ + Ω) x δθ - C d, δθ_z = 0
        -ir, vr1, og0, ob0, ox0, oy0, wr2, -c0, -c1, -c2,
        ir, -vr0, og1, ob1, ox1, oy1, -wr2, -c3, -c4, -c5,
        # azimuth (5-4-30..39): δα' = -δΩ_z + (ρ_x+Ω_x)δθ_y - (ρ_y+Ω_y)δθ_x + (C d)_z
        -ox2, -oy2, wr0, -wr1, c6, c7, c8,
        # sensor errors, first-order Gauss-Markov (5-4-41..46)
        ta, ta, ta, tg, tg, tg)
    return vals


def _floats(x):
    """A vector as Python floats (tuples of floats pass through)."""
    return x.tolist() if isinstance(x, np.ndarray) else x


def _flat(entries):
    return np.array([i * N_STATES + j for i, j in entries])


BA0, BG0 = BA.start, BG.start
_PHI_INDEX = {}     # n -> flat indices of _F_INDEX's entries in an n x n matrix
_F_INDEX = _flat(
    [(RX, VY), (RX, H), (RX, GAMMA), (RX, BETA),
     (RY, VX), (RY, H), (RY, GAMMA), (RY, BETA),
     (H, VZ)]
    + [(VX, VX), (VX, VY), (VX, VZ), (VX, H), (VX, GAMMA), (VX, BETA), (VX, RX), (VX, RY), (VX, TY)]
    + [(VX, BA0 + k) for k in range(3)] + [(VX, BG0 + k) for k in range(3)]
    + [(VY, VX), (VY, VY), (VY, VZ), (VY, H), (VY, GAMMA), (VY, BETA), (VY, RX), (VY, RY), (VY, TX)]
    + [(VY, BA0 + k) for k in range(3)] + [(VY, BG0 + k) for k in range(3)]
    + [(VZ, VX), (VZ, VY), (VZ, H), (VZ, GAMMA), (VZ, BETA), (VZ, RX), (VZ, RY), (VZ, TX), (VZ, TY)]
    + [(VZ, BA0 + k) for k in range(3)]
    + [(TX, VY), (TX, H), (TX, GAMMA), (TX, BETA), (TX, RX), (TX, RY), (TX, TY)] + [(TX, BG0 + k) for k in range(3)]
    + [(TY, VX), (TY, H), (TY, GAMMA), (TY, BETA), (TY, RX), (TY, RY), (TY, TX)] + [(TY, BG0 + k) for k in range(3)]
    + [(GAMMA, RX), (GAMMA, RY), (GAMMA, TY), (GAMMA, TX)] + [(GAMMA, BG0 + k) for k in range(3)]
    + [(BA0 + k, BA0 + k) for k in range(3)] + [(BG0 + k, BG0 + k) for k in range(3)])


def body_to_c(c_b_cbar):
    """C_B^C = T C_B^Cbar (rows of an array or of row tuples: the same rows, the last two negated)."""
    if isinstance(c_b_cbar, np.ndarray):
        return T @ c_b_cbar
    a, b, c = c_b_cbar
    return a, tuple(-x for x in b), tuple(-x for x in c)
