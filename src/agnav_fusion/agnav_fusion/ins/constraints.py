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

CRAB = em.N_STATES          # index of the augmented crab state (rad, + body velocity to the right, FRD)


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
        v_b = self.base_velocity(c_b_cbar, v_c, omega_b)
        j = np.zeros((3, n_states))                     # d v_b / d x
        j[:, list(em.V3)] = c_b_cbar.T @ T              # C -> B
        m = -c_b_cbar.T @ skew(T @ v_c)                 # tilt correction rotates C-bar by (TX, -TY, 0)
        j[:, em.TX], j[:, em.TY] = m[:, 0], -m[:, 1]
        j[:, em.BG] = -skew(self.lever)                 # ω = gyro - bias
        h = np.stack([j[1] - crab * j[0], j[2]])
        h[0, CRAB] = -v_b[0]
        extra = (self.s.speed_sigma_gain * abs(v_b[0])) ** 2
        r = np.diag([self.s.lateral_sigma ** 2 + extra, self.s.vertical_sigma ** 2 + extra])
        return Linearized(self.name, np.array([v_b[1] - v_b[0] * crab, v_b[2]]), h, r)
