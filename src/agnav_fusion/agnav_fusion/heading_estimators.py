"""Selectable absolute-heading estimators behind heading_node (SPEC §3.5, §3.6, §4.5–4.7, §5.1–5.2).

ROS-free; thesis conventions: heading clockwise from true north, yaw rate clockwise +, rad and s.
Inputs arrive as gyro samples (on_gyro), GDS headings at their epochs (on_gds) and GNSS positions (on_fix);
each returns the newest (stamp, heading, variance) to publish, or None.
"""
import bisect
import math
from collections import deque
from dataclasses import dataclass, field

from agnav_common.frames import wrap_angle
from agnav_fusion.gds_drift_lsm import DelayedVwaSettings, DriftLsmSettings, GdsGyroSystem, Unwrapper
from agnav_fusion.gds_gyro_kf import GdsGyroKalmanFilter, KfSettings
from agnav_fusion.gnss_heading_lsm import GnssGyroHeading
from agnav_fusion.variance_weighted_average import VariableTargetVwa, VwaSettings

ESTIMATORS = ("gds_kf", "vwa", "gds_gyro_lsm", "gnss_gyro_lsm")
MIN_VARIANCE = math.radians(0.05) ** 2


@dataclass
class EstimatorSettings:
    estimator: str = "gds_kf"
    kf: KfSettings = field(default_factory=lambda: KfSettings(drift_noise=1e-7))   # long runs drift: [IMPL]
    vwa: VwaSettings = field(default_factory=VwaSettings)
    lsm_window_s: float = 3.5         # M of (3.18) as time (175 samples at 50 Hz)
    lsm_vwa: VwaSettings = field(default_factory=lambda: VwaSettings(window=15.0, interval=5.0))
    gds_delay_s: float = 0.0          # latency of the GDS heading (ALE tilt: its delay)
    imu_rate_hz: float = 50.0
    nominal_speed: float = 0.5        # KF Δd when no GNSS speed is known (SPEC §3.4)


class GyroHistory:
    """Integrated gyro heading over time for look-ups at GDS and GNSS epochs."""

    def __init__(self, horizon_s: float = 30.0):
        self.t: deque = deque()
        self.h: deque = deque()
        self._horizon = horizon_s

    def add(self, t: float, rate: float):
        if self.t:
            self.h.append(self.h[-1] + rate * (t - self.t[-1]))
        else:
            self.h.append(0.0)
        self.t.append(t)
        while self.t[0] < t - self._horizon:
            self.t.popleft()
            self.h.popleft()

    def at(self, t: float) -> float | None:
        """Linear interpolation of the integrated heading at t (None outside the history)."""
        if not self.t or t < self.t[0] or t > self.t[-1]:
            return None
        i = bisect.bisect_left(self.t, t)
        if self.t[i] == t:
            return self.h[i]
        f = (t - self.t[i - 1]) / (self.t[i] - self.t[i - 1])
        return self.h[i - 1] + f * (self.h[i] - self.h[i - 1])


class HeadingEstimator:
    """One of ESTIMATORS fed by gyro, GDS and GNSS streams."""

    def __init__(self, s: EstimatorSettings):
        if s.estimator not in ESTIMATORS:
            raise ValueError(f"estimator must be one of {ESTIMATORS}")
        self.s = s
        self.gyro = GyroHistory()
        self.speed = s.nominal_speed
        self._last_gds = None
        self._rate = 0.0
        self._kf = GdsGyroKalmanFilter(s.kf) if s.estimator == "gds_kf" else None
        self._vwa = VariableTargetVwa(s.vwa) if s.estimator == "vwa" else None
        self._gnss = GnssGyroHeading() if s.estimator == "gnss_gyro_lsm" else None
        self._fix = None          # (t, x, y, position variance) of the last GNSS fix
        self._prev_gds = None     # (t, heading, gyro heading) of the previous GDS epoch (KF predictor form)
        self._unwrap = Unwrapper()
        if s.estimator == "gds_gyro_lsm":
            dt = 1.0 / s.imu_rate_hz
            delay = int(round(s.gds_delay_s * s.imu_rate_hz))
            self._lsm = GdsGyroSystem(
                DriftLsmSettings(window=max(1, int(round(s.lsm_window_s * s.imu_rate_hz))), delay=delay, dt=dt),
                DelayedVwaSettings(window=s.lsm_vwa.window, interval=s.lsm_vwa.interval, delay=delay, dt=dt))
        self.drift = 0.0

    def on_gyro(self, t: float, rate: float, dt: float, gds_variance_scale: float = 1.0):
        """Yaw rate (clockwise rad/s) at t; returns (t, heading, variance) for the per-sample estimators."""
        self.gyro.add(t, rate)
        self._rate = rate
        if self._gnss is not None:
            heading = self._gnss.on_gyro(rate, dt)
            self.drift = self._gnss.drift or 0.0
            if heading is None:
                return None
            var = self._gnss.kise.variance(self._fix[3]) if self._fix else math.inf
            return t, heading, max(var, MIN_VARIANCE)
        if self.s.estimator == "gds_gyro_lsm" and self._last_gds is not None:
            heading, var, self.drift = self._lsm.update(rate, self._last_gds, gds_variance_scale)
            return t, heading, max(var, MIN_VARIANCE) if math.isfinite(var) else math.radians(2.0) ** 2
        return None

    def on_gds(self, t: float, heading: float, gds_variance_scale: float = 1.0):
        """True GDS heading at epoch t; returns (t, heading, variance) for the GDS-epoch estimators."""
        self._last_gds = heading
        gyro = self.gyro.at(t)
        if gyro is None or (self._kf is None and self._vwa is None):
            return None
        if self._vwa is not None:
            out = self._vwa.update(t, self._unwrap(heading), gyro, gds_variance_scale)
            return None if out is None else (t, wrap_angle(out[1]), max(out[2], MIN_VARIANCE))
        prev, self._prev_gds = self._prev_gds, (t, heading, gyro)
        if prev is None:
            return None
        dt = t - prev[0]
        # predictor form (2.16): y(k−1) and the gyro turn over (t_{k−1}, t_k] give x̂(k) at t_k
        self._kf.update(prev[1], prev[2], (gyro - prev[2]) / dt, self.speed * dt, dt, gds_variance_scale)
        return t, self._kf.heading, max(self._kf.heading_variance, MIN_VARIANCE)

    def on_fix(self, t: float, x: float, y: float, position_variance: float, speed: float | None = None):
        """GNSS position (map ENU m) at epoch t; feeds the GNSS–gyro LSM and the KF speed."""
        prev, self._fix = self._fix, (t, x, y, position_variance)
        if prev is None or t <= prev[0]:
            return
        dt = t - prev[0]
        self.speed = speed if speed is not None else math.hypot(x - prev[1], y - prev[2]) / dt
        if self._gnss is None:
            return
        raw = self.gyro.at(t)
        if raw is None:
            return
        turn_since = self.gyro.h[-1] - raw          # gyro turn between the fix epoch and now (latency)
        corrected = None if self._gnss.heading is None else self._gnss.heading - turn_since
        self._gnss.on_fix(x, y, self.speed, self._gnss.raw_heading - turn_since, corrected, dt)
