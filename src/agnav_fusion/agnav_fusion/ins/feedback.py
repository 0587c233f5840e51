"""Closed-loop correction of the INS with the estimated errors (SPEC §7.11)."""
import math

import numpy as np

from . import error_model as em, quaternion
from .mechanization import orthonormalize, rotation, skew


def azimuth_error(gamma, beta):
    """δα = atan2(γ, 1 − β) (5-4-40)."""
    return math.atan2(gamma, 1.0 - beta)


def apply(mech, x):
    """Feed the error estimate x back into the mechanization (§7.11 steps 1–5); returns δα."""
    s = mech.state
    d_alpha = azimuth_error(x[em.GAMMA], x[em.BETA])
    # frame: C_E^C <- (I + [δr x]) M_z(-δα) C_E^C
    ca, sa = math.cos(d_alpha), math.sin(d_alpha)
    mz_t = np.array([[ca, -sa, 0.0], [sa, ca, 0.0], [0.0, 0.0, 1.0]])
    s.c_ec = orthonormalize((np.eye(3) + skew([x[em.RX], x[em.RY], 0.0])) @ mz_t @ s.c_ec)
    s.h -= x[em.H]
    s.v = s.v - x[list(em.V3)]
    # attitude: C_B^Cbar <- (I + [(T δθ) x]) C_B^Cbar
    s.q = quaternion.from_dcm(rotation([x[em.TX], -x[em.TY], 0.0]) @ s.c_b_cbar())
    mech.accel_bias = mech.accel_bias + x[em.BA]
    mech.gyro_bias = mech.gyro_bias + x[em.BG]
    return d_alpha


def azimuth_reset_jacobian(gamma, beta, n_states):
    """J of the covariance reset after moving δα̂ into α: the new γ is the residual azimuth error
    (linearised atan2), the new β is second order and dropped."""
    j = np.eye(n_states)
    den = max(gamma * gamma + (1.0 - beta) ** 2, 0.25)   # far off the unit circle: bounded gain
    j[em.GAMMA, em.GAMMA] = (1.0 - beta) / den
    j[em.GAMMA, em.BETA] = gamma / den
    j[em.BETA, :] = 0.0
    return j
