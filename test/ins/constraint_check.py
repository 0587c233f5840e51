"""Shared check of the INS vehicle-constraint models' rows (test_nhc, test_wheel_speed): H x equals h(computed) -
h(computed corrected by x) for small velocity, tilt, azimuth, gyro bias and augmented-state errors."""
import copy

import numpy as np

from agnav_fusion.ins import error_model as em, feedback
from agnav_fusion.ins.mechanization import InsState, Mechanization

LEVER_BASE = (-0.8, 0.1, 1.2)       # IMU -> base_link, FRD [m]


def assert_rows_match_feedback(linearize, augmented):
    """linearize(c_b_cbar, v_c, omega_b, x) -> Linearized with the augmented states corrected by the error x;
    augmented: [(index, step)] of the model's augmented states."""
    st = InsState.from_geodetic(0.75, 2.4, 30.0, 0.05, -0.08, 2.2, (1.5, -3.0, 0.2))
    mech = Mechanization(st)
    omega = np.array([0.02, -0.03, 0.15])
    lin = linearize(st.c_b_cbar(), st.v, omega, np.zeros(em.N_INS))
    for i in range(3):                      # ω = gyro - bias turns the lever to base_link
        x = np.zeros(em.N_INS)
        x[em.BG.start + i] = 1e-4
        true = linearize(st.c_b_cbar(), st.v, omega - x[em.BG], x)
        np.testing.assert_allclose(lin.z - true.z, lin.h @ x, atol=1e-10)
    for i, step in [(em.VX, 0.01), (em.VY, 0.01), (em.VZ, 0.01), (em.TX, 1e-4), (em.TY, 1e-4), (em.GAMMA, 1e-4),
                    *augmented]:
        x = np.zeros(em.N_INS)
        x[i] = step
        m = copy.deepcopy(mech)
        feedback.apply(m, x)
        true = linearize(m.state.c_b_cbar(), m.state.v, omega, x)
        np.testing.assert_allclose(lin.z - true.z, lin.h[:, i] * step, atol=2e-3 * step, err_msg=str(i))
