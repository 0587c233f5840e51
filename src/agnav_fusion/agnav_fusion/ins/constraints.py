"""Vehicle constraints for the GNSS/INS EKF: non-holonomic constraint with an estimated crab angle ([IMPL]).

A wheeled vehicle's base_link (rear-axle centre on the ground) moves along its body x axis: its body lateral
velocity is speed x crab (side slip, sliding on cross slopes) and its vertical velocity is zero, each up to a
white part (sway, bumps). The crab angle is an augmented Gauss-Markov error state about a roll-driven mean: a tractor
on a cross slope slides downhill, never uphill, by about crab_roll_mean x sin(roll) (tyre side force m g sin(roll)
over the cornering stiffness); its steady sigma grows with the roll (the slide's spread: soil, tyres, load). On a
straight line crab and heading are not separable from GNSS: without the mean the course offset goes into the heading.
Same closed-loop conventions as `measurements`: x = computed - true, z = h(x̂) - measured, so the INS velocity and
attitude rows follow from how `feedback.apply` corrects the state.
"""
import math
from dataclasses import dataclass

import numpy as np
from agnav_common.frames import cross

from . import error_model as em
from .measurements import Linearized
from .mechanization import T, skew

CRAB = em.CRAB              # index of the augmented crab state (rad, + body velocity to the right, FRD)


@dataclass
class NhcSettings:
    """Non-holonomic constraint and crab model (sigmas for a tractor on fields and rough tracks)."""

    enabled: bool = True                     # apply the constraint (false: GNSS alone makes heading observable)
    interval: float = 0.2                    # s between constraint updates
    lateral_sigma: float = 0.05              # m/s, white lateral velocity of base_link (sway, steering)
    vertical_sigma: float = 0.08             # m/s, white vertical velocity of base_link (bumps)
    speed_sigma_gain: float = 0.02           # extra sigma per m/s of speed (both axes: rougher when faster)
    crab_sigma: float = math.radians(0.5)    # rad, steady crab on level ground
    crab_roll_mean: float = 0.2              # expected crab per sin(roll) (downhill): weight over the tyres' cornering
                                             # stiffness, 3-8 per rad on soil -> 0.12-0.33
    crab_roll_gain: float = 0.15             # rad of crab sigma per rad of roll (spread of that slide)
    crab_mean_heading_sigma: float = math.radians(5.0)  # rad, the slide's mean applies once the heading sigma is
                                             # below this (aligning: a course offset is mostly heading error)
    crab_tau: float = 20.0                   # s, crab correlation time

    def crab_mean(self, roll, heading_sigma=0.0):
        """Expected crab at this roll (FRD: + right, roll + right side down) [rad]; 0 while aligning."""
        return self.crab_roll_mean * math.sin(roll) if heading_sigma < self.crab_mean_heading_sigma else 0.0

    def crab_var(self, roll):
        """Steady crab variance at this roll [rad^2]."""
        return self.crab_sigma ** 2 + (self.crab_roll_gain * roll) ** 2


class NonHolonomic:
    """Rows: base_link lateral velocity minus speed x crab, base_link vertical velocity (both ~ 0)."""

    name = "nhc"

    def __init__(self, settings, lever_base_frd):
        self.s = settings
        self.lever = np.asarray(lever_base_frd, dtype=float)   # IMU -> base_link, body FRD [m]

    def base_velocity(self, c_b_cbar, v_c, omega_b):
        """base_link velocity in body FRD from the C velocity of the IMU point."""
        return c_b_cbar.T @ (T @ v_c) + cross(omega_b, self.lever)

    def linearize(self, c_b_cbar, v_c, omega_b, crab, n_states):
        """Rows of d v_b / d x (written out on floats; the matrix form is in test/ins/test_scalar_paths.py):
        C -> B for the velocity, the tilt correction rotating C-bar by (TX, -TY, 0), ω = gyro - bias."""
        c = c_b_cbar.tolist() if isinstance(c_b_cbar, np.ndarray) else c_b_cbar
        (c0, c1, c2), (c3, c4, c5), (c6, c7, c8) = c
        u0, u1, u2 = v_c.tolist() if isinstance(v_c, np.ndarray) else v_c
        u1, u2 = -u1, -u2                                                        # T v
        w0, w1, w2 = omega_b.tolist() if isinstance(omega_b, np.ndarray) else omega_b
        l0, l1, l2 = self.lever.tolist()
        vb0 = c0 * u0 + c3 * u1 + c6 * u2 + (w1 * l2 - w2 * l1)
        vb1 = c1 * u0 + c4 * u1 + c7 * u2 + (w2 * l0 - w0 * l2)
        vb2 = c2 * u0 + c5 * u1 + c8 * u2 + (w0 * l1 - w1 * l0)
        # row i of j over (VX, VY, VZ, TX, TY, BG x3): (c_0i, -c_1i, -c_2i, -(c_1i u2 - c_2i u1), c_2i u0 - c_0i u2,
        # -[l x]_i)
        j0 = (c0, -c3, -c6, -(c3 * u2 - c6 * u1), c6 * u0 - c0 * u2, 0.0, l2, -l1)
        j1 = (c1, -c4, -c7, -(c4 * u2 - c7 * u1), c7 * u0 - c1 * u2, -l2, 0.0, l0)
        j2 = (c2, -c5, -c8, -(c5 * u2 - c8 * u1), c8 * u0 - c2 * u2, l1, -l0, 0.0)
        h = np.zeros(2 * n_states)
        cols = _NHC_COLS
        h[cols] = [a - crab * b for a, b in zip(j1, j0)]
        h[n_states + cols] = j2
        h[CRAB] = -vb0
        extra = (self.s.speed_sigma_gain * abs(vb0)) ** 2
        r = np.diag([self.s.lateral_sigma ** 2 + extra, self.s.vertical_sigma ** 2 + extra])
        return Linearized(self.name, np.array([vb1 - vb0 * crab, vb2]), h.reshape(2, n_states), r)


_NHC_COLS = np.array([em.VX, em.VY, em.VZ, em.TX, em.TY, em.BG.start, em.BG.start + 1, em.BG.start + 2])
