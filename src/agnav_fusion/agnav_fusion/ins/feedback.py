"""Closed-loop correction of the INS with the estimated errors (SPEC §7.11)."""
import math

import numpy as np

from . import error_model as em, quaternion
from .mechanization import mat3, orthonormalize, rotation_rows


def azimuth_error(gamma, beta):
    """δα = atan2(γ, 1 − β) (5-4-40)."""
    return math.atan2(gamma, 1.0 - beta)


def apply(mech, x):
    """Feed the error estimate x back into the mechanization (§7.11 steps 1–5); returns δα. (3x3 products on
    Python floats; the matrix form is in test/ins/test_scalar_paths.py.)"""
    s = mech.state
    x = x[:em.N_STATES].tolist() if isinstance(x, np.ndarray) else [float(v) for v in x[:em.N_STATES]]
    rx, ry = x[em.RX], x[em.RY]
    d_alpha = azimuth_error(x[em.GAMMA], x[em.BETA])
    # frame: C_E^C <- (I + [δr x]) M_z(-δα) C_E^C, δr = (δr_x, δr_y, 0)
    ca, sa = math.cos(d_alpha), math.sin(d_alpha)
    m = ((ca, -sa, ry), (sa, ca, -rx), (-ry * ca + rx * sa, ry * sa + rx * ca, 1.0))
    s.c_ec = orthonormalize(mat3(m, s.c_ec.tolist()))
    s.h -= x[em.H]
    v0, v1, v2 = s.v.tolist()
    s.v = np.array((v0 - x[em.VX], v1 - x[em.VY], v2 - x[em.VZ]))
    # attitude: C_B^Cbar <- (I + [(T δθ) x]) C_B^Cbar
    s.q = quaternion.from_dcm(mat3(rotation_rows(x[em.TX], -x[em.TY], 0.0), s.dcm_rows()))
    ba, bg = em.BA.start, em.BG.start
    mech.accel_bias = mech.accel_bias + x[ba:ba + 3]
    mech.gyro_bias = mech.gyro_bias + x[bg:bg + 3]
    return d_alpha


def azimuth_reset_jacobian(gamma, beta, n_states):
    """J of the covariance reset after moving δα̂ into α: the new γ is the residual azimuth error
    (linearised atan2), the new β is second order and dropped."""
    j = np.eye(n_states)
    j[em.GAMMA, em.GAMMA], j[em.GAMMA, em.BETA] = _reset_gains(gamma, beta)
    j[em.BETA, :] = 0.0
    return j


def _reset_gains(gamma, beta):
    den = max(gamma * gamma + (1.0 - beta) ** 2, 0.25)   # far off the unit circle: bounded gain
    return (1.0 - beta) / den, gamma / den


def azimuth_reset(p, gamma, beta):
    """J P Jᵀ with J = azimuth_reset_jacobian (a new array): only the γ and β rows and columns change."""
    jgg, jgb = _reset_gains(float(gamma), float(beta))
    g, b = em.GAMMA, em.BETA
    p = p.copy()
    p[g] = jgg * p[g] + jgb * p[b]
    p[b] = 0.0
    p[:, g] = jgg * p[:, g] + jgb * p[:, b]
    p[:, b] = 0.0
    return p


def bound_heading(p):
    """P no worse than an unknown heading: γ's row and column scaled to σ ≤ 1 rad, β's variance with it (in place)."""
    if p[em.GAMMA, em.GAMMA] > 1.0:
        scale = 1.0 / math.sqrt(p[em.GAMMA, em.GAMMA])
        p[em.GAMMA, :] *= scale
        p[:, em.GAMMA] *= scale
        p[em.BETA, em.BETA] = 0.5 * p[em.GAMMA, em.GAMMA] ** 2 + 1e-12
    return p
