"""Initial state of the GNSS/INS (SPEC §7.7, in-motion alignment): level from the accelerometers (standing, carried
by the gyros, when a standing stretch was seen), position and velocity from a fix, heading from the guess or, when
unknown, from the course over ground ([IMPL]: the antenna's lever-arm sway removed; fix-difference velocities from
the INS's own fix track when the receiver gives none)."""
import math
from collections import deque

import numpy as np

from . import earth, error_model as em
from .lever_arm import antenna_to_imu_position, antenna_to_imu_velocity, heading_from_course
from .measurements import ENU_TO_NED
from .mechanization import InsState, roll_pitch_from_accel


class FixTrack:
    """Recent fixes; the velocity at the latest one from the mean velocities over the last `baseline` m (alignment
    only): such a mean lags by half its span, so the acceleration from an earlier mean carries it to the fix (the
    earlier mean at least half a span back: the carry never exceeds the difference, which would amplify fix noise)."""

    def __init__(self, baseline=2.0, window=20.0):
        self.baseline, self.window = baseline, window
        self._fixes = deque()
        self._means = deque()       # (mid time, ENU velocity, covariance) of the means since the last stop

    def velocity(self, g):
        """Adds fix g; (ENU velocity, 3x3 covariance) at g from the latest earlier fix at least `baseline` away and
        the previous such mean, or None."""
        rm, rn = earth.radii(g.lat)

        def enu_from(f):
            return np.array([(g.lon - f.lon) * (rn + g.alt) * math.cos(g.lat), (g.lat - f.lat) * (rm + g.alt),
                             g.alt - f.alt])
        base = next(((f, d) for f in reversed(self._fixes) for d in (enu_from(f),)
                     if f.t < g.t and math.hypot(d[0], d[1]) >= self.baseline), None)
        self._fixes.append(g)
        while self._fixes[0].t < g.t - self.window:
            self._fixes.popleft()
        if base is None:
            self._means.clear()     # standing (or a gap): no acceleration across it
            return None
        dt = g.t - base[0].t
        mean = (g.t - dt / 2, base[1] / dt, (np.asarray(g.pos_cov_enu) + base[0].pos_cov_enu) / dt ** 2)
        prev = next((m for m in reversed(self._means) if m[0] <= mean[0] - dt / 2), None)
        self._means.append(mean)
        while self._means[0][0] < mean[0] - 2.0 * dt:
            self._means.popleft()
        if prev is None or prev[0] < mean[0] - 2.0 * dt:
            return None
        k = (g.t - mean[0]) / (mean[0] - prev[0])
        step = k * (mean[1] - prev[1])       # constant acceleration; its size again as the margin for a change
        return mean[1] + step, (1 + k) ** 2 * mean[2] + k ** 2 * prev[2] + np.diag(step ** 2)


def initial_state(s, g, level, heading, heading_var, gyro_bias, roll_pitch=None):
    """(InsState, heading variance) at fix g, or None to wait. s: InsEkfSettings; level: ((t, accel, gyro), ...) of
    the last level_window s; heading_var >= 1: unknown (from the course once moving faster than align_speed);
    roll_pitch: the standing level carried here (else the mean of `level`'s specific force)."""
    if len(level) < 2:
        return None
    if roll_pitch is None:
        roll_pitch = roll_pitch_from_accel(np.mean([a for _, a, _ in level], axis=0))
    roll, pitch = roll_pitch
    lever = np.asarray(s.lever_gnss_frd, dtype=float)
    omega = min(level, key=lambda x: abs(x[0] - g.t))[2] - gyro_bias
    v_ned = np.zeros(3)
    if g.vel_enu is not None:
        v = ENU_TO_NED @ np.asarray(g.vel_enu)
        speed = math.hypot(v[0], v[1])
        if speed > s.align_speed:
            if heading_var >= 1.0 and s.align_from_course:
                sway = 0.0 * omega if g.vel_from_fixes else omega     # fix differences: mostly averaged out
                course = heading_from_course(v, lever - s.lever_base_frd, sway, roll, pitch)
                if course is None:
                    return None             # the antenna's motion is all sway: wait
                heading = course
                sigma = s.align_fix_course_sigma if g.vel_from_fixes else s.align_course_sigma
                heading_var = sigma ** 2 + np.trace(g.vel_cov_enu[:2, :2]) / 2 / speed ** 2
                c_b_ned = InsState.from_geodetic(g.lat, g.lon, g.alt, roll, pitch, heading).c_b_ned()
                v_ned = antenna_to_imu_velocity(v, lever, c_b_ned, omega)
            else:                           # travel along the (guessed) body x axis
                v_ned = np.array([speed * math.cos(heading), speed * math.sin(heading), v[2]])
    if heading_var >= 1.0 and not v_ned.any():
        return None                         # unknown heading: wait until driving (in-motion alignment)
    c_b_ned = InsState.from_geodetic(g.lat, g.lon, g.alt, roll, pitch, heading).c_b_ned()
    lat, lon, h = antenna_to_imu_position(g.lat, g.lon, g.alt, lever, c_b_ned)
    return InsState.from_geodetic(lat, lon, h, roll, pitch, heading, v_ned), heading_var


def initial_variances(s, g, heading_var, crab=True, gyro_bias_var=None, gnss_bias_var=(0.0, 0.0, 0.0)):
    """Diagonal of the initial error covariance, em.N_INS long (the crab's 0 without the constraint; gyro_bias_var:
    of a bias measured standing still, else gyro_bias_sigma0)."""
    r = earth.mean_radius(g.lat) + g.alt
    lever = float(np.linalg.norm(s.lever_gnss_frd[:2]))
    var = np.zeros(em.N_STATES)
    var[[em.RX, em.RY]] = (np.trace(g.pos_cov_enu[:2, :2]) / 2 + lever ** 2) / r ** 2
    var[em.H] = g.pos_cov_enu[2, 2] + 0.1
    var[list(em.V3)] = s.velocity_sigma ** 2
    var[[em.TX, em.TY]] = s.tilt_sigma ** 2
    var[em.BA] = s.accel_bias_sigma0 ** 2
    var[em.BG] = s.gyro_bias_sigma0 ** 2 if gyro_bias_var is None else gyro_bias_var
    if heading_var >= 1.0:      # unknown: γ, β span the whole circle
        var[em.GAMMA], var[em.BETA] = 1.0, 2.0
    else:
        var[em.GAMMA], var[em.BETA] = heading_var, heading_var ** 2 / 2
    return np.append(var, (s.nhc.crab_var(0.0) if crab else 0.0, s.error.gyro_scale_sigma ** 2,
                           s.wheel.scale_sigma ** 2, s.mount_yaw_sigma ** 2, *gnss_bias_var))
