"""Hand-over of the GNSS/INS state (SPEC §7.9) between InsEkf and a tightly coupled filter's INS (gnss_raw.tight,
gnss_raw.switching): what one exports, the other adopts; a mixin of `ekf.InsEkf`, on its attributes."""
import copy

import numpy as np

from . import error_model as em
from .constraints import CRAB


class HandOver:
    """export_state / adopt of InsEkf (its mechanization, P, crab, yaw mount, nhc, hold and history)."""

    def export_state(self):
        """Hand-over (SPEC §7.9): copies of the mechanization, error covariance (n_states, propagated to t), crab,
        time, rate and yaw mount."""
        self._propagate_covariance()
        return {"mech": copy.deepcopy(self.mech), "p": self.p.copy(), "crab": self.crab, "t": self.t,
                "omega_b": self.omega_b.copy(), "mount_yaw": self.mount.yaw,
                "roll_lag": self.nhc.roll_lag if self.nhc else None}

    def adopt(self, mech, p, crab=0.0, t=None, omega_b=None, mount_yaw=0.0, roll_lag=None):
        """Take over an INS state (e.g. export_state() of a tightly coupled filter's INS): P's first n_states
        rows/columns (a 16x16 P gets the crab's steady variance and the scale's initial one), the crab's terrain roll
        (None: from the next roll); the solution history restarts here."""
        self.mech, self.crab, self.t = mech, crab, t
        self.mount.set(mount_yaw)
        k = min(len(p), em.N_INS)
        self.p = np.zeros((em.N_INS, em.N_INS))
        self.p[:k, :k] = np.asarray(p)[:k, :k]
        augmented = (self.s.nhc.crab_var(mech.state.euler()[0]) if self.nhc else 0.0,    # CRAB .. GNSS_BIAS
                     self.s.error.gyro_scale_sigma ** 2, self.s.wheel.scale_sigma ** 2, self.s.mount_yaw_sigma ** 2,
                     *self.gnss_bias.var)
        self.gnss_bias.reset(self.gnss_bias.var)
        for i in range(max(k, CRAB), em.N_INS):     # the states a shorter P lacks: their initial variances
            self.p[i, i] = augmented[i - CRAB]
        if self.nhc:
            self.nhc.reset(roll_lag, mech.state.euler()[0], self.heading_sigma())
        if self.hold:
            self.hold.prev = None
        self.omega_b = np.zeros(3) if omega_b is None else np.array(omega_b, dtype=float)
        self._f, self._cov_dt, self._gap_var, self._pending, self._corr = None, 0.0, None, [], np.zeros(6)
        self._history.clear()
        self._snapshot()
        self._last_accept_t = t
