"""Vehicle constraints for the GNSS/INS EKF: non-holonomic constraint with an estimated crab angle ([IMPL]).

A wheeled vehicle's base_link (rear-axle centre on the ground) moves along its body x axis: its body lateral
velocity is speed x crab (side slip, sliding on cross slopes) and its vertical velocity is zero, each up to a
white part (sway, bumps). The crab angle is an augmented Gauss-Markov error state about a roll-driven mean: a tractor
on a cross slope slides downhill, never uphill, by about crab_roll_mean x sin(roll) (tyre side force m g sin(roll)
over the cornering stiffness), the roll being the terrain's (the estimate through a lag: sway rocks the body, it does
not slide it); its steady sigma grows with that roll (the slide's spread: soil, tyres, load). On a
straight line crab and heading are not separable from GNSS: without the mean the course offset goes into the heading.
A wheel or radar speed reads base_link's body forward velocity times (1 + w), w its scale error (rolling radius,
mean slip: an augmented random-walk state learnt while the fixes arrive, which then holds the speed in an outage).
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
WHEEL = em.WHEEL_SCALE      # index of the wheel speed's scale error
MOUNT = em.MOUNT_YAW        # index of the IMU yaw mount error (the body axes' turn off base_link's, + right)


@dataclass
class NhcSettings:
    """Non-holonomic constraint and crab model (sigmas for a tractor on fields and rough tracks)."""

    enabled: bool = True                     # apply the constraint (false: GNSS alone makes heading observable)
    interval: float = 0.2                    # s between constraint updates
    lateral_sigma: float = 0.05              # m/s, white lateral velocity of base_link (sway, steering)
    vertical_sigma: float = 0.08             # m/s, white vertical velocity of base_link (bumps)
    speed_sigma_gain: float = 0.02           # extra sigma per m/s of speed (both axes: rougher when faster)
    crab_sigma: float = 0.0065               # rad (0.37 deg), crab spread on level ground (a steady one reads as yaw mount)
    crab_roll_mean: float = 0.2              # expected crab per sin(roll) (downhill): weight over the tyres' cornering
                                             # stiffness, 3-8 per rad on soil -> 0.12-0.33
    crab_roll_gain: float = 0.15             # rad of crab sigma per rad of roll (spread of that slide)
    crab_roll_tau: float = 3.0               # s, lag from the estimated roll to the terrain roll driving the slide
                                             # (the sway rocks the body without sliding it)
    crab_mean_heading_sigma: float = math.radians(5.0)  # rad, the slide's mean applies once the heading sigma is
                                             # below this (aligning: a course offset is mostly heading error)
    crab_tau: float = 20.0                   # s, crab correlation time

    def crab_mean(self, roll, heading_sigma=0.0):
        """Expected crab at this roll (FRD: + right, roll + right side down) [rad]; 0 while aligning."""
        return self.crab_roll_mean * math.sin(roll) if heading_sigma < self.crab_mean_heading_sigma else 0.0

    def crab_var(self, roll):
        """Steady crab variance at this roll [rad^2]."""
        return self.crab_sigma ** 2 + (self.crab_roll_gain * roll) ** 2


@dataclass
class WheelSettings:
    """Wheel or radar ground speed (/wheel/odometry twist.linear.x): base_link forward speed x (1 + scale)."""

    speed_sigma: float = 0.05                # m/s, noise floor (the message's own covariance when larger)
    slip_sigma: float = 0.03                 # of the speed: slip changes about the learnt scale
    scale_sigma: float = 0.1                 # initial scale error (rolling radius, mean slip on soil)
    scale_walk: float = 0.006                # 1/sqrt(s), change of that scale (slip: a few % within tens of s)
    max_age: float = 0.2                     # s, a speed older than this at the next IMU sample is dropped

    def variance(self, speed, var):
        """Variance of a speed reading whose own variance is var (<= 0 or NaN: unknown)."""
        return max(var if var and var > 0 else 0.0, self.speed_sigma ** 2) + (self.slip_sigma * speed) ** 2


@dataclass
class SpeedHoldSettings:
    """A tractor keeps its speed: in a GNSS outage the INS's own change of base_link's forward speed between two
    constraint updates is measured as zero, up to the speed's random walk; what the accelerometer bias and the pitch
    error add to that change is then learnt instead of integrated into the position. A real speed change (a stop, a
    start) fails the gate and is left to the accelerometers."""

    enabled: bool = True                     # in outages, measure the INS speed change as a tractor's random walk
    after: float = 2.0                       # s without an accepted GNSS epoch before it applies
    walk: float = 0.02                       # m/s/sqrt(s), the speed's random walk (throttle, load, slip)
    white: float = 0.005                     # m/s, white part of each change (gyro noise through the lever, bumps)


def _base_rows(c_b_cbar, v_c, omega_b, lever):
    """base_link body velocity (FRD) and its rows d v_b / d x over _BASE_COLS (written out on floats; the matrix
    form is in test/ins/test_scalar_paths.py): C -> B for the velocity, the tilt correction rotating C-bar by
    (TX, -TY, 0), ω = gyro - bias."""
    c = c_b_cbar.tolist() if isinstance(c_b_cbar, np.ndarray) else c_b_cbar
    (c0, c1, c2), (c3, c4, c5), (c6, c7, c8) = c
    u0, u1, u2 = v_c.tolist() if isinstance(v_c, np.ndarray) else v_c
    u1, u2 = -u1, -u2                                                            # T v
    w0, w1, w2 = omega_b.tolist() if isinstance(omega_b, np.ndarray) else omega_b
    l0, l1, l2 = lever
    vb = (c0 * u0 + c3 * u1 + c6 * u2 + (w1 * l2 - w2 * l1), c1 * u0 + c4 * u1 + c7 * u2 + (w2 * l0 - w0 * l2),
          c2 * u0 + c5 * u1 + c8 * u2 + (w0 * l1 - w1 * l0))
    # row i over (VX, VY, VZ, TX, TY, BG x3): (c_0i, -c_1i, -c_2i, -(c_1i u2 - c_2i u1), c_2i u0 - c_0i u2, -[l x]_i)
    rows = ((c0, -c3, -c6, -(c3 * u2 - c6 * u1), c6 * u0 - c0 * u2, 0.0, l2, -l1),
            (c1, -c4, -c7, -(c4 * u2 - c7 * u1), c7 * u0 - c1 * u2, -l2, 0.0, l0),
            (c2, -c5, -c8, -(c5 * u2 - c8 * u1), c8 * u0 - c2 * u2, l1, -l0, 0.0))
    return vb, rows


class WheelSpeed:
    """Row: (1 + scale) x base_link forward velocity minus the measured speed."""

    name = "wheel"

    def __init__(self, settings, lever_base_frd):
        self.s = settings
        self.lever = tuple(float(v) for v in lever_base_frd)   # IMU -> base_link, body FRD [m]

    def linearize(self, c_b_cbar, v_c, omega_b, scale, speed, var, n_states):
        (vb0, _, _), (j0, _, _) = _base_rows(c_b_cbar, v_c, omega_b, self.lever)
        h = np.zeros((1, n_states))
        h[0, _BASE_COLS] = [(1.0 + scale) * a for a in j0]
        h[0, WHEEL] = vb0
        return Linearized(self.name, np.array([(1.0 + scale) * vb0 - speed]), h,
                          np.array([[self.s.variance(speed, var)]]))


class NonHolonomic:
    """Rows: base_link lateral velocity minus speed x crab, base_link vertical velocity (both ~ 0)."""

    name = "nhc"

    def __init__(self, settings, lever_base_frd):
        self.s = settings
        self.lever = np.asarray(lever_base_frd, dtype=float)   # IMU -> base_link, body FRD [m]
        self.roll_lag = None     # the terrain roll driving the crab (None: restart from the next roll)
        self.crab_mean = 0.0     # the roll-driven mean the crab state deviates from

    def reset(self, roll_lag=None, roll=None, heading_sigma=0.0):
        """Restart the terrain roll (None: from the next roll) and the crab mean (at this roll; None: zero)."""
        self.roll_lag = roll_lag
        self.crab_mean = 0.0 if roll is None else self.s.crab_mean(roll, heading_sigma)

    def propagate_crab(self, crab, roll, dt, heading_sigma):
        """Crab over dt at this estimated roll: its roll-driven mean (at once) plus a first-order Gauss-Markov
        deviation, steady sigma from the terrain roll; returns (crab, its transition, its process noise)."""
        a = min(dt / self.s.crab_tau, 1.0)
        roll = self.terrain_roll(roll, dt)
        mean = self.s.crab_mean(roll, heading_sigma)
        crab = mean + (1.0 - a) * (crab - self.crab_mean)
        self.crab_mean = mean
        return crab, 1.0 - a, 2.0 * a * self.s.crab_var(roll)

    def terrain_roll(self, roll, dt):
        """The roll through a crab_roll_tau lag: the slope slides the vehicle, the sway only rocks it."""
        lag = self.roll_lag
        tau = self.s.crab_roll_tau
        self.roll_lag = roll if lag is None or dt >= tau else lag + dt / tau * (roll - lag)    # tau <= 0: no lag
        return self.roll_lag

    def base_velocity(self, c_b_cbar, v_c, omega_b):
        """base_link velocity in body FRD from the C velocity of the IMU point."""
        return c_b_cbar.T @ (T @ v_c) + cross(omega_b, self.lever)

    def linearize(self, c_b_cbar, v_c, omega_b, crab, n_states):
        (vb0, vb1, vb2), (j0, j1, j2) = _base_rows(c_b_cbar, v_c, omega_b, self.lever.tolist())
        h = np.zeros(2 * n_states)
        cols = _BASE_COLS
        h[cols] = [a - crab * b for a, b in zip(j1, j0)]
        h[n_states + cols] = j2
        h[CRAB] = -vb0
        if n_states > MOUNT:    # body axes turned by δm: base_link's lateral velocity is vb1 - δm vb0
            h[MOUNT] = vb0
        extra = (self.s.speed_sigma_gain * abs(vb0)) ** 2
        r = np.diag([self.s.lateral_sigma ** 2 + extra, self.s.vertical_sigma ** 2 + extra])
        return Linearized(self.name, np.array([vb1 - vb0 * crab, vb2]), h.reshape(2, n_states), r)


_BASE_COLS = np.array([em.VX, em.VY, em.VZ, em.TX, em.TY, em.BG.start, em.BG.start + 1, em.BG.start + 2])


class SpeedHold:
    """Row: the computed change of base_link's forward speed since the last constraint update (`prev`), ~ 0. Its
    error over dt is dt times the forward projection of the velocity-error dynamics (F's velocity rows)."""

    name = "speed_hold"

    def __init__(self, settings, lever_base_frd):
        self.s = settings
        self.lever = tuple(float(v) for v in lever_base_frd)   # IMU -> base_link, body FRD [m]
        self.prev = None    # (t, forward speed after the last constraint update)

    def forward(self, c_b_cbar, v_c, omega_b):
        return _base_rows(c_b_cbar, v_c, omega_b, self.lever)[0][0]

    def linearize(self, c_b_cbar, v_c, omega_b, f_velocity, t, n_states):
        """f_velocity: F's rows VX, VY, VZ (3 x em.N_STATES)."""
        (vb0, _, _), (j0, _, _) = _base_rows(c_b_cbar, v_c, omega_b, self.lever)
        t0, v0 = self.prev
        dt = t - t0
        h = np.zeros((1, n_states))
        h[0, :em.N_STATES] = dt * (j0[0] * f_velocity[0] + j0[1] * f_velocity[1] + j0[2] * f_velocity[2])
        r = self.s.walk ** 2 * dt + self.s.white ** 2
        return Linearized(self.name, np.array([vb0 - v0]), h, np.array([[r]]))
