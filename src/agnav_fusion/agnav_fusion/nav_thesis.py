"""The thesis' estimator of the navigation sensor module (SPEC §6.3): attitude LSM (5.1-5.11) per tilt axis, each
axis independent as in the thesis, Kise LSM + drift LSM heading (4.1-4.17) and dead reckoning between fixes
(5.12-5.13). Thesis conventions inside (heading clockwise from north, pitch nose up).
"""
import numpy as np

from agnav_fusion.attitude_lsm import AttitudeLSM
from agnav_fusion.dead_reckoning import DeadReckoning
from agnav_fusion.gnss_heading_lsm import GnssGyroHeading


class ThesisEstimator:
    """Backend of NavSensorModule (`m`: its history, settings, guard and gate)."""

    def __init__(self, m):
        s = m.settings
        self.m = m
        self.roll_filter, self.pitch_filter = AttitudeLSM(s.roll_lsm), AttitudeLSM(s.pitch_lsm)
        self.heading_lsm = GnssGyroHeading(s.heading)
        self.dr = DeadReckoning(s.dead_reckoning)
        self.speed = 0.0  # travel speed V for dead reckoning
        self.wheel = None  # (not fused by the thesis' module)
        self._heading_var = None  # (last_fix it was computed for, variance): changes only at a fix

    def step(self, t, dt, gyro, prev, roll_incl, pitch_incl):
        """-> (rate_cw, roll, pitch, heading, raw heading, nav, still, wheel) of this sample."""
        droll, dpitch, dyaw = gyro.tolist()  # the thesis treats each axis independently (SPEC §6.2 pitfall)
        rate_cw = -dyaw
        roll = self.roll_filter.update(droll, roll_incl, dt)
        pitch = self.pitch_filter.update(-dpitch, pitch_incl, dt)
        heading = self.heading_lsm.on_gyro(rate_cw, dt)
        heading = self.heading_lsm.raw_heading if heading is None else heading
        nav = None if self.dr.xy is None else self.dr.step(heading, self.speed, dt)
        return rate_cw, roll, pitch, heading, self.heading_lsm.raw_heading, nav, False, None

    def white_fix_covariance(self, cov2):
        return cov2

    def fix(self, k, t, xy, R, v_ref, vel, vel_var, speed, differenced=0.0):
        """Gate (once the heading is known), Kise/drift LSM epoch, dead reckoning restarted at the fix and replayed
        to now; True when the position was accepted (`differenced`, a fix-difference velocity's baseline: unused)."""
        m = self.m
        hist = m.history
        snap = hist[k]
        if snap.nav is not None and self.heading_lsm.heading is not None:  # no gate on a heading not yet known
            y = xy - snap.nav[0]
            S = snap.nav[1] + R
            if m.gate(t, float(y @ np.linalg.solve(S, y))) is False:
                return False
        dt_fix = t - m.last_fix[0] if m.last_fix else 1.0
        if speed is None:  # V from successive tilt-corrected fixes (SPEC §6.3 [IMPL])
            speed = float(np.hypot(*(xy - m.last_fix[1][:2]))) / dt_fix if m.last_fix else 0.0
        self.speed = speed
        self.heading_lsm.on_fix(xy[0], xy[1], speed, snap.raw_heading, snap.heading, dt_fix)
        self._heading_var = None
        self.dr.reset(xy, R)
        snap.nav = (xy.copy(), R.copy())
        for j in range(k + 1, len(hist)):  # (5.12)-(5.13) from the fix epoch to now
            hist[j].nav = self.dr.step(hist[j].heading, speed, hist[j].dt)
        return True

    def heading_variance(self):
        fix = self.m.last_fix
        if self._heading_var is None or self._heading_var[0] is not fix:
            pos_var = float(np.trace(fix[2][:2, :2])) / 2 if fix else 1.0
            self._heading_var = (fix, self.heading_lsm.kise.variance(pos_var) + 1e-6)
        return self._heading_var[1]

    def rate_corrections(self):
        """(roll, thesis pitch, clockwise yaw) gyro corrections."""
        return self.roll_filter.drift, self.pitch_filter.drift, self.heading_lsm.drift

    def output(self, snap, position, pose_cov, twist_cov):
        """Fill the navigation part of the output; -> (speed, heading_valid, position_valid)."""
        position_valid = snap.nav is not None
        if position_valid:
            position[:2] = snap.nav[0]
            pose_cov[:2, :2] = snap.nav[1]
        heading_valid = self.heading_lsm.heading is not None
        if heading_valid:
            pose_cov[5, 5] = self.heading_variance()
        return self.speed, heading_valid, position_valid
