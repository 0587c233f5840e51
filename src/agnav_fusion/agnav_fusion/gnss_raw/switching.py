"""Loose / tight / INS-only mode switching with state hand-over (SPEC §7.9, Table 5-8-1, (5-8-1)–(5-8-3)).

Mode (`select_mode`): the receiver in RTK fixed (its latest fix no older than `fix_timeout`) → LOOSE (the InsEkf
fuses the fixes); not fixed but ≥ 2 satellites common to rover and base in one system (≥ 1 double difference)
→ TIGHT (TightFilter on the raw observations); nothing usable → INS_ONLY (the InsEkf coasting on its
non-holonomic constraint, no fixes). Decided at each raw epoch, and at a fixed receiver fix (→ LOOSE at once).

Hand-over: the INS state (mechanization, 16 error states + crab, their covariance) moves whole between the two
filters (InsEkf.export_state / adopt), so the output is continuous at the switch itself. Loose → tight augments P
with the clock drift and the DD ambiguities (zero cross-covariance at the switch): (5-8-1) each ambiguity starts
at Δ_Φ − h(r̂) with a wide σ, (5-8-3) the drift at the first epoch's median Doppler residual; their covariances and
cross-covariances with the INS states come from the first updates ([IMPL] of (5-8-2)). Tight → loose drops them
(marginalising a Gaussian keeps the INS block of P as it is).

Output jumps: for `jump_window` s after each switch, every step's change of the antenna output beyond its
dead-reckoned motion (p₁ − p₀ − v₀Δt) is divided by the larger σ along it of the outputs before and after
(√(uᵀ C u); a loose output's C includes the receiver's slowly drifting error, the InsEkf's GNSS bias states: a
tight solution handed back meets fixes offset by it); `transitions` keeps the largest ratio per switch.

Switching also offers the InsEkf interface nav_ins.InsNavigation drives (add_imu, add_gnss, solution, gnss_age,
health, ...: the backend of estimator `ins_tight`, agnav_fusion.nav_ins_tight): the solution and its covariance are
the active filter's. There the base position may come later (`set_base`; no tight mode before it), raw epochs wait
for the loosely coupled filter's heading alignment, and the receiver's RTK status comes from its own messages
(`receiver_status`, the latest one) instead of each fix's `fix_type`.
"""
import math

import numpy as np

from agnav_fusion.ins.ekf import ALIGNED
from agnav_fusion.gnss_raw.tight import TightConfig, TightFilter, antenna_jacobians, antenna_state

LOOSE, TIGHT, INS_ONLY = "loose", "tight", "ins_only"
RTK_FIXED = 4             # GnssSample.fix_type of an RTK fixed receiver solution (GGA quality 4)


def select_mode(receiver_fixed, rover, base):
    """Table 5-8-1 from the receiver status and the observations of one rover + base epoch."""
    if receiver_fixed:
        return LOOSE
    per_system = {}
    if rover is not None and base is not None:
        for i, sid in enumerate(rover.sats):
            k = base.row(sid)
            if k is not None and np.isfinite(rover.code[i, 0]) and np.isfinite(base.code[k, 0]):
                per_system[sid[0]] = per_system.get(sid[0], 0) + 1
    return TIGHT if max(per_system.values(), default=0) >= 2 else INS_ONLY


class Switching:
    """Drives an InsEkf and, when tightly coupled, a TightFilter; feed add_imu / add_gnss / add_epoch in time
    order (the loosely coupled filter aligned before the first switch)."""

    def __init__(self, ekf, base_pos=None, config=None, fix_timeout=1.5, jump_window=3.0):
        self.ekf, self.config = ekf, config or TightConfig()
        self.base_pos = None if base_pos is None else np.asarray(base_pos, float)
        self.lever = np.asarray(ekf.s.lever_gnss_frd, float)
        self.tight, self.mode = None, LOOSE
        self.fix_timeout, self.jump_window = fix_timeout, jump_window
        self._last_fixed_t = -math.inf
        self.transitions = []     # {t, from, to, jump_sigma, jump_m}
        self.last_solution = None  # TightSolution of the last tight epoch
        self._receiver_fixed = None  # latest receiver_status (None: each fix's fix_type)
        self._status_t = -math.inf   # its stamp
        self._last_raw_t = -math.inf  # last tight epoch with an update
        self._aligned = False       # the loose filter's heading has aligned once (raw epochs wait for it)

    @property
    def t(self):
        return self.tight.t if self.mode == TIGHT else self.ekf.t

    def output(self):
        """(antenna ECEF position, velocity, 3x3 position covariance) of the active filter."""
        f = self.tight if self.mode == TIGHT else self.ekf
        omega = f.ins.omega_b if self.mode == TIGHT else f.omega_b
        pos, vel = antenna_state(f.mech, self.lever, omega)
        jp = antenna_jacobians(f.mech, self.lever, omega, len(f.p))[0]
        return pos, vel, jp @ f.p @ jp.T

    def add_imu(self, t, gyro_frd, accel_frd):
        """-> the active filter's rejection reason (None: used)."""
        f = self.tight if self.mode == TIGHT else self.ekf
        return self._watched(f.add_imu, t, gyro_frd, accel_frd)

    def set_base(self, base_pos):
        """Base antenna ECEF [m] (a tight filter running keeps its own until the next switch)."""
        self.base_pos = np.asarray(base_pos, float)

    def receiver_status(self, fixed, t):
        """The receiver's status at epoch t: RTK fixed or not; it decides for the fixes up to fix_timeout after it
        (a fix after a longer silence is no fixed one until a status says so: its own status may follow it)."""
        self._receiver_fixed, self._status_t = bool(fixed), t

    def add_gnss(self, g):
        """A receiver fix (GnssSample); fused only while loosely coupled."""
        if self._receiver_fixed is None:
            fixed = g.fix_type == RTK_FIXED
        else:
            fixed = self._receiver_fixed and g.t - self._status_t <= self.fix_timeout
        if fixed:
            self._last_fixed_t = g.t
            self._switch(LOOSE)
        if self.mode == LOOSE:
            self._watched(self.ekf.add_gnss, g)

    def add_epoch(self, rover, base, nav):
        """One rover + base observation epoch at the current IMU time; returns the mode after it (ignored before a
        base position and the loose filter's first heading alignment)."""
        self._aligned = self._aligned or self.ekf.alignment == ALIGNED
        if self.base_pos is None or not self._aligned:
            return self.mode
        fixed = self.t - self._last_fixed_t <= self.fix_timeout
        self._switch(select_mode(fixed, rover, base))
        if self.mode == TIGHT:
            self.last_solution = self._watched(self.tight.add_epoch, rover, base, nav)
            if self.last_solution is not None:
                self._last_raw_t = self.t
        return self.mode

    def _switch(self, mode):
        if mode == self.mode:
            return
        t = self.t
        if mode == TIGHT:               # loose / INS-only -> tight: augment (5-8-1)–(5-8-3)
            self.tight = TightFilter.from_ins(self.ekf, self.base_pos, self.config)
        elif self.mode == TIGHT:        # tight -> loose / INS-only: the INS part back
            self.ekf.adopt(**self.tight.export_state())
            self.tight = None
        self.transitions.append({"t": t, "from": self.mode, "to": mode, "jump_sigma": 0.0, "jump_m": 0.0})
        self.mode = mode

    def _watched(self, fn, *args):
        rec = self.transitions[-1] if self.transitions else None
        if rec is None or self.t - rec["t"] > self.jump_window:
            return fn(*args)
        t0, (p0, v0, c0) = self.t, self.output()
        out = fn(*args)
        p1, _, c1 = self.output()
        d = p1 - p0 - v0 * (self.t - t0)
        size = float(np.linalg.norm(d))
        if size > 0.0:
            u = d / size
            ratio = size / math.sqrt(max(float(u @ c0 @ u), float(u @ c1 @ u), 1e-12))
            if ratio > rec["jump_sigma"]:
                rec["jump_sigma"], rec["jump_m"] = ratio, size
        return out

    # ---- the InsEkf interface of nav_ins.InsNavigation (estimator ins_tight) -----------------------------------
    @property
    def mech(self):
        return self.tight.mech if self.mode == TIGHT else self.ekf.mech

    @property
    def alignment(self):
        return self.ekf.alignment

    @property
    def stats(self):
        return self.ekf.stats

    @property
    def imu_period(self):
        return self.ekf.imu_period

    @property
    def last_gap(self):
        return 0.0 if self.mode == TIGHT else self.ekf.last_gap

    def gnss_age(self):
        """s since the last fix fused (loose, INS only) or raw epoch used (tight)."""
        return self.t - self._last_raw_t if self.mode == TIGHT else self.ekf.gnss_age()

    def solution(self):
        """NavSolution of the active filter: its INS state and covariance."""
        return self.tight.solution() if self.mode == TIGHT else self.ekf.solution()

    def health(self):
        """The loose filter's health with the coupling mode, the switches and the last one."""
        h = dict(self.ekf.health(), coupling=self.mode, coupling_switches=len(self.transitions))
        if self.transitions:
            tr = self.transitions[-1]
            h["coupling_last_switch"] = (f"{tr['from']} -> {tr['to']} at {tr['t']:.2f} s, "
                                         f"jump {tr['jump_sigma']:.2f} sigma ({tr['jump_m'] * 100:.1f} cm)")
        if self.mode == TIGHT and self.last_solution is not None:
            h.update(tight_dd=self.last_solution.n_dd, tight_fixed=self.last_solution.fixed,
                     tight_slips=self.tight.stats["slips"], tight_height_aided=self.last_solution.height_aided)
        return h
