"""GNSS/INS backend of the navigation pipeline (SPEC §7, loosely coupled; estimator `ins`). ROS-free.

The wander-azimuth strapdown INS with the 16-state error EKF (+ crab, z gyro scale and wheel speed scale;
`agnav_fusion.ins.InsEkf`) runs on the base_link axes at the imu_link origin. The front end (agnav_fusion.pipeline)
hands it what it hands NavSensorModule: mounts, map-ENU fixes paired with their /gnss/vel, base_link gyro rates, wheel
speeds; as a `strapdown` backend also the specific force, the IMU translation, the map plane and the velocity's 3x3
covariance. The filter starts once the mounts are known; the heading may be unknown (in-motion alignment). Late fixes
are applied against the INS history; IMU gaps are bridged with covariance growth. Input rules are the front end's
InputGuard (INS clocks: GNSS stamps within [IMU time - history, IMU time + max_gnss_lead]); EKF rejections become
guard events (`filter_*`). The output is the NavState every navigation backend gives (REP-103, base_link), published
once the yaw sigma has been below heading_valid_sigma; `dead_reckoning` is the INS-only (outage) mode.
"""
import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np
from agnav_common.input_guard import StreamClockSettings

from agnav_fusion.front_end import InputGuard, InputGuardSettings, Overdue
from agnav_fusion.ins import GnssSample, InsEkf, InsEkfSettings
from agnav_fusion.ins.frames import FastPlane, Mounts, base_link_state, ekf_base_link_state
from agnav_fusion.ins.mechanization import _floats
from agnav_fusion.nav_settings import NavState

SKIP = ("lever_gnss_frd", "lever_base_frd", "initial_heading", "initial_heading_sigma", "guard.gnss_max_lead")  # TF / REP-103 / ekf


@dataclass
class InsNavSettings:
    initial_yaw: float = 0.0               # rad, REP-103 (CCW from east): best guess of the start heading
    initial_yaw_sigma: float = 0.0         # rad; 0: unknown heading (in-motion alignment from the GNSS velocity)
    gnss_timeout: float = 1.5              # s without an accepted fix -> INS-only (outage) mode, dead_reckoning
    default_fix_sigma: float = 1.0         # m, a fix whose covariance is all zero before the receiver gave a good one
    default_vel_sigma: float = 0.05        # m/s, a velocity whose covariance is all zero
    min_vel_sigma: float = 0.01            # m/s, smaller velocity sigmas are raised to this
    imu_max_jump: float = 0.5              # s, a larger forward step of the IMU stamps needs 3 more to be believed
    gnss_overdue_periods: float = 1.5      # fix periods without a fix: gnss_overdue (diagnostics)
    imu_overdue_periods: float = 20.0      # IMU periods without a sample at a GNSS epoch: imu_overdue (diagnostics)
    mount_tilt_sigma: float = math.radians(0.1)   # rad, IMU roll/pitch mount error beyond TF (bracket levelled by
                                           # hand): unobservable (the filter levels the IMU), added to roll/pitch var
    heading_valid_sigma: float = math.radians(1.5)  # rad: nothing is published before the yaw sigma (mount's included)
                                           # is below this once (an outage's growing sigma later stays published)
    ekf: InsEkfSettings = field(default_factory=InsEkfSettings)
    guard: InputGuardSettings = field(default_factory=lambda: InputGuardSettings(
        max_stamp_jump=1.0, min_fix_sigma=0.01, diagnostic_window=5.0))


class InsNavigation:
    """The navigation backend protocol (guard, counters, set_mounts, imu, inclinometer, gnss, wheel_speed, state)
    around InsEkf."""

    strapdown = True

    def __init__(self, settings=None):
        self.settings = s = settings or InsNavSettings()
        s.ekf.initial_heading = math.pi / 2 - s.initial_yaw
        s.ekf.initial_heading_sigma = s.initial_yaw_sigma if s.initial_yaw_sigma > 0 else math.inf
        gnss_clock = StreamClockSettings(max_jump=s.guard.max_stamp_jump, max_lag=s.ekf.history,
                                         max_lead=s.ekf.max_gnss_lead, vouch=True)
        self.guard = InputGuard(s.guard, clocks={"imu": StreamClockSettings(max_jump=s.imu_max_jump),
                                                 "gnss": gnss_clock, "vel": gnss_clock})
        self.gnss_overdue = Overdue(s.gnss_overdue_periods)
        self.imu_overdue = Overdue(s.imu_overdue_periods)
        self.ekf = None
        self.mounts = None
        self.plane = self.enu_plane = None
        self.filter_seen = {}       # EKF rejection counts already turned into guard events
        self._state = None
        self._heading_valid = False     # the yaw sigma has been below heading_valid_sigma

    @property
    def counters(self):
        """Totals of every input and rejection event since the start (guard.recent(): the last seconds only)."""
        return Counter(self.guard.totals)

    def set_mounts(self, gnss_lever, incl_lever, imu_lever):
        """base_link -> gnss_link and -> imu_link translations (base_link FLU, m); starts the filter."""
        self.mounts = Mounts.from_tf(imu_lever, np.eye(3), gnss_lever)
        self.mounts.tilt_var = self.settings.mount_tilt_sigma ** 2
        self.settings.ekf.lever_gnss_frd = tuple(self.mounts.lever_gnss_frd)
        self.settings.ekf.lever_base_frd = tuple(-self.mounts.lever_imu_frd)
        self.ekf = InsEkf(self.settings.ekf)

    def set_plane(self, plane):
        """The map's LocalTangentPlane (fixes arrive in it; the INS integrates geodetic)."""
        self.plane, self.enu_plane = plane, FastPlane(plane)

    def _imu_clock(self):
        return self.guard.clocks["imu"].last

    def _filter_events(self):
        """EKF rejections since the last call -> guard events: input-level ones keep their name, the rest filter_*."""
        for name, count in self.ekf.stats["rejected"].items():
            for _ in range(count - self.filter_seen.get(name, 0)):
                self.guard.count(name if name.startswith(("imu_", "gnss_")) else f"filter_{name}")
            self.filter_seen[name] = count

    # ---- inputs -------------------------------------------------------------------------------------------
    def imu(self, t, gyro_flu, accel_flu):
        """base_link gyro (rad/s) and specific force (m/s^2) at epoch t; returns the new NavState (None: unused)."""
        if not self.guard.accept("imu", t, gyro_flu, accel_flu):   # a stuck IMU is dropped here: bridged as a gap
            return None
        self.imu_overdue.arrived(t)
        if self.gnss_overdue.check(t):
            self.guard.count("gnss_overdue")
        if self.ekf is None:
            return None
        self.guard.count("imu")
        (g0, g1, g2), (a0, a1, a2) = _floats(gyro_flu), _floats(accel_flu)
        reason = self.ekf.add_imu(t, (g0, -g1, -g2), (a0, -a1, -a2))    # FLU -> FRD (FRD * x)
        self._filter_events()
        if reason is not None:
            return None
        if self.ekf.last_gap > 0.0:
            self.guard.count("imu_gap_bridged")
        state = self._output()
        if state is not None:
            self._state = state
        return state

    def gnss(self, t, antenna_enu, cov, vel_enu=None, vel_cov=None):
        """Antenna fix (map ENU m, 3x3 m^2) at its epoch, with the ENU velocity of that epoch (m/s) and its 3x3
        covariance (None: unknown; a scalar: a fix-difference velocity, ignored: the EKF's own FixTrack carries its
        lag to the fix; the pipeline sends none to a strapdown backend)."""
        if not self.guard.accept("gnss", t, antenna_enu, ref=self._imu_clock()):
            return False
        if self.imu_overdue.check(t):
            self.guard.count("imu_overdue")
        s = self.settings
        cov = self.guard.fix_covariance(cov, np.eye(3) * s.default_fix_sigma ** 2)
        if cov is None or self.ekf is None or self.plane is None:
            return False
        self.gnss_overdue.arrived(t, self._imu_clock())
        lat, lon, alt = self.enu_plane.to_geodetic(*(float(v) for v in antenna_enu))
        g = GnssSample(t, math.radians(lat), math.radians(lon), float(alt), cov)
        if np.ndim(vel_cov) == 0 and vel_cov is not None:
            vel_enu = None      # a fix-difference velocity: the EKF differences its fixes itself
        if vel_enu is not None and self.guard.accept("vel", t, vel_enu, ref=self._imu_clock()):
            if vel_cov is None:
                vel_cov = np.eye(3) * s.default_vel_sigma ** 2
            else:
                vel_cov = self.guard.velocity_covariance(vel_cov, s.min_vel_sigma ** 2, s.default_vel_sigma ** 2)
            if vel_cov is not None:
                g.vel_enu, g.vel_cov_enu = np.asarray(vel_enu, dtype=float), vel_cov
        self.guard.count("gnss")
        self.ekf.add_gnss(g)
        self._filter_events()
        return True

    def inclinometer(self, t, roll, pitch):
        """Not used: the INS levels itself from the accelerometers."""
        return False

    def wheel_speed(self, t, speed, var=None):
        """Forward ground speed (m/s, negative reversing) of base_link from wheel odometry or a radar with its
        variance (None: ekf.wheel.speed_sigma) at its epoch: fused with the learnt scale at the next IMU sample."""
        if not self.guard.accept("wheel", t, speed, 0.0 if var is None else var) or self.ekf is None:
            return False
        self.guard.count("wheel")
        self.ekf.add_wheel(t, speed, var)
        return True

    def state(self):
        return self._state

    # ---- output -------------------------------------------------------------------------------------------
    def _output(self):
        """NavState of base_link (None before initialisation, or counted output_invalid when not publishable)."""
        if self.plane is None:
            return None
        rate_var = (self.settings.ekf.error.gyro_arw ** 2 / self.ekf.imu_period,) * 3   # gyro white noise in its band
        if type(self.ekf) is InsEkf:        # without the NavSolution's arrays (the same values)
            if self.ekf.mech is None:
                return None
            b, crab, crab_var = ekf_base_link_state(self.ekf, self.mounts, self.enu_plane, rate_var)
        else:
            sol = self.ekf.solution()
            if sol is None:
                return None
            b, crab, crab_var = base_link_state(sol, self.mounts, self.enu_plane, rate_var), sol.crab, sol.crab_var
        if not (b.finite() and b.positive_definite()):   # published covariances must be
            self.guard.count("output_invalid")
            return None
        outage = self.ekf.gnss_age() > self.settings.gnss_timeout
        self._heading_valid = self._heading_valid or b.pose_cov[5, 5] <= self.settings.heading_valid_sigma ** 2
        return NavState(b.t, b.position, b.rpy, b.pose_cov, float(b.velocity[0]), b.rates, b.twist_cov,
                        self._heading_valid, True, outage, crab, crab_var)

    def health(self):
        """Filter health for the diagnostics: alignment, mode, NIS means, counts, GNSS age, heading sigma."""
        if self.ekf is None:
            return {"alignment": "not started (mounts)"}
        h = self.ekf.health()
        h["mode"] = "uninitialized" if self.ekf.mech is None else (
            "ins_only_outage" if self.ekf.gnss_age() > self.settings.gnss_timeout else "gnss_aided")
        return h
