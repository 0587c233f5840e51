"""GNSS/INS backend with loose / tight / INS-only switching (SPEC §7.7–7.9, Table 5-8-1; estimator `ins_tight`).
ROS-free.

The `ins` backend (nav_ins.InsNavigation: guard, mounts, output, diagnostics) whose InsEkf is driven through
gnss_raw.switching.Switching: RTK fixed receiver -> the InsEkf fuses the fixes (loose); not fixed but >= 2 satellites
common to rover and base -> the TightFilter on double-differenced code / phase and Doppler (tight); nothing usable ->
the InsEkf coasts on its non-holonomic constraint (ins_only). The INS state moves whole between the filters at a
switch. The published NavState and its covariance are the active filter's; the mode, the number of switches and the
last one (with its output jump in sigma) are in `health()` (coupling, coupling_switches, coupling_last_switch).

Inputs beyond `ins`: the receiver status (RTK fixed or not, from /gnss/status) and raw epochs (rover ObsEpoch, the
latest base ObsEpoch, the broadcast ephemerides, the base ECEF position), applied at the current IMU time (the
pipeline hands an epoch over once the IMU has reached its stamp). A base epoch older than `max_base_age` is not
used (no double differences: INS only).
"""
from dataclasses import dataclass, field

from agnav_fusion.gnss_raw.switching import Switching
from agnav_fusion.gnss_raw.tight import TightConfig
from agnav_fusion.nav_ins import SKIP, InsNavigation, InsNavSettings  # noqa: F401 (SKIP: backends.py reads it here)


@dataclass
class InsTightSettings(InsNavSettings):
    fix_timeout: float = 1.5       # s, an RTK fixed receiver fix younger than this keeps the loose mode
    jump_window: float = 3.0       # s after a switch in which output jumps are measured (diagnostics)
    max_base_age: float = 10.0     # s, an older base epoch is not used (RTK differential age)
    tight: TightConfig = field(default_factory=TightConfig)


class InsTightNavigation(InsNavigation):
    """InsNavigation on gnss_raw.switching.Switching (the InsEkf interface of the active filter)."""

    raw_gnss = True      # the pipeline hands it the receiver status and raw epochs

    def set_mounts(self, gnss_lever, incl_lever, imu_lever):
        super().set_mounts(gnss_lever, incl_lever, imu_lever)
        s = self.settings
        self.ekf = Switching(self.ekf, None, s.tight, s.fix_timeout, s.jump_window)

    @property
    def mode(self):
        """loose | tight | ins_only (None before the mounts)."""
        return None if self.ekf is None else self.ekf.mode

    def receiver_status(self, t, rtk_fixed):
        """The receiver's status at epoch t: RTK fixed or not (it decides for the fixes up to fix_timeout after it)."""
        if self.ekf is not None:
            self.ekf.receiver_status(rtk_fixed, t)

    def raw_epoch(self, rover, base, nav, base_pos):
        """One rover ObsEpoch with the latest base ObsEpoch (None: none), the cssrlib Nav and the base ECEF
        position (None: unknown), at the current IMU time; returns the mode after it."""
        if self.ekf is None or base_pos is None:
            return self.mode
        if base is not None and rover.time - base.time > self.settings.max_base_age:
            base = None
        self.ekf.set_base(base_pos)
        mode = self.ekf.add_epoch(rover, base, nav)
        self._filter_events()
        return mode
