"""Selectable absolute-heading estimators behind heading_node (SPEC §3.5, §3.6, §4.5–4.7, §5.1–5.2).

ROS-free; thesis conventions: heading clockwise from true north, yaw rate clockwise +, rad and s.
Inputs arrive as gyro samples (on_gyro), GDS headings at their epochs (on_gds) and GNSS positions (on_fix);
each returns the newest (stamp, heading, variance) to publish, or None.
A GDS sample flagged disturbed (heading_gate) is not fused: from the last clean output the heading follows the
gyro alone (with the estimated drift) and its variance grows (heading_gate.propagation_variance) until clean GDS
samples are fused again. The variance of a GDS-based heading includes `gds_systematic_sigma`, the GDS error no
averaging removes (WMM declination, calibration residual, local anomalies).
"""
import bisect
import math
from collections import deque
from dataclasses import dataclass, field

from agnav_common.frames import wrap_angle
from agnav_fusion.gds_drift_lsm import DelayedVwaSettings, DriftLsmSettings, GdsGyroSystem, Unwrapper
from agnav_fusion.gds_gyro_kf import GdsGyroKalmanFilter, KfSettings
from agnav_fusion.gnss_heading_lsm import GnssGyroHeading
from agnav_fusion.heading_gate import GyroErrorSettings, propagation_variance
from agnav_common.variance_weighted_average import VariableTargetVwa, VwaSettings

ESTIMATORS = ("gds_kf", "vwa", "gds_gyro_lsm", "gnss_gyro_lsm")
MIN_VARIANCE = math.radians(0.05) ** 2
DRIFT_WINDOW_S = 10.0   # the gyro-only heading uses the mean LSM drift of this span (one estimate is noisy)


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
    gds_systematic_sigma: float = math.radians(0.4)   # absolute GDS heading error (WMM D ≈ 0.3–0.4° r.m.s.) [IMPL]
    gyro: GyroErrorSettings = field(default_factory=GyroErrorSettings)   # gyro-only propagation while disturbed


class GyroHistory:
    """Integrated gyro heading over time for look-ups at GDS and GNSS epochs: raw (h) and with the drift estimate
    of each step added to the rate (hc, the gyro-only heading)."""

    def __init__(self, horizon_s: float = 30.0):
        self.t: deque = deque()
        self.h: deque = deque()
        self.hc: deque = deque()
        self._horizon = horizon_s
        self._rate = (0.0, 0.0)

    def add(self, t: float, rate: float, drift: float = 0.0):
        if self.t:
            dt = t - self.t[-1]
            self.h.append(self.h[-1] + rate * dt)
            self.hc.append(self.hc[-1] + (rate + drift) * dt)
        else:
            self.h.append(0.0)
            self.hc.append(0.0)
        self._rate = (rate, rate + drift)
        self.t.append(t)
        while self.t[0] < t - self._horizon:
            self.t.popleft()
            self.h.popleft()
            self.hc.popleft()

    def at(self, t: float, extrapolate: bool = False, corrected: bool = False) -> float | None:
        """Linear interpolation of the integrated heading at t (None outside the history; with extrapolate, a t
        after the newest sample continues at the newest rate); corrected: the drift-corrected one."""
        h = self.hc if corrected else self.h
        if not self.t or t < self.t[0]:
            return None
        if t > self.t[-1]:
            return h[-1] + self._rate[corrected] * (t - self.t[-1]) if extrapolate else None
        i = bisect.bisect_left(self.t, t)
        if self.t[i] == t:
            return h[i]
        f = (t - self.t[i - 1]) / (self.t[i] - self.t[i - 1])
        return h[i - 1] + f * (h[i] - h[i - 1])


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
        self._lsm = None
        if s.estimator == "gds_gyro_lsm":
            dt = 1.0 / s.imu_rate_hz
            delay = int(round(s.gds_delay_s * s.imu_rate_hz))
            self._lsm = GdsGyroSystem(
                DriftLsmSettings(window=max(1, int(round(s.lsm_window_s * s.imu_rate_hz))), delay=delay, dt=dt),
                DelayedVwaSettings(window=s.lsm_vwa.window, interval=s.lsm_vwa.interval, delay=delay, dt=dt))
        self.drift = 0.0
        self._drifts: deque = deque()   # (t, LSM drift) of the last DRIFT_WINDOW_S s on clean GDS
        self.disturbed = False    # the GDS is flagged: the heading follows the gyro alone
        self._clean = None        # (t, heading, variance, gyro-only heading) of the last output on clean GDS
        self._clean_gds = None    # (GDS heading, gyro-only heading) of the last clean GDS sample
        self._settle = None       # (until, variance): after a disturbance, the window-statistics estimators'
        # variance is not below the gyro-only one until their window holds clean samples again

    def on_gyro(self, t: float, rate: float, dt: float):
        """Yaw rate (clockwise rad/s) at t; returns (t, heading, variance) for the per-sample estimators."""
        self.gyro.add(t, rate, self._drift_mean()[0])
        self._rate = rate
        if self._gnss is not None:
            heading = self._gnss.on_gyro(rate, dt)
            self.drift = self._gnss.drift or 0.0
            if heading is None:
                return None
            var = self._gnss.kise.variance(self._fix[3]) if self._fix else math.inf
            return t, heading, max(var, MIN_VARIANCE)
        if self.s.estimator == "gds_gyro_lsm" and self._last_gds is not None:
            heading, var, drift = self._lsm.update(rate, self._last_gds)
            if self.disturbed:      # the LSM runs on the gyro-propagated GDS; the output is the gyro's
                return self._hold(t)
            self.drift = drift
            self._drifts.append((t, drift))
            while self._drifts[0][0] <= t - DRIFT_WINDOW_S:
                self._drifts.popleft()
            return self._clean_output(t, heading, var if math.isfinite(var) else math.radians(2.0) ** 2)
        return None

    def on_gds(self, t: float, heading: float, disturbed: bool = False):
        """True GDS heading at epoch t; returns (t, heading, variance) for the GDS-epoch estimators.

        disturbed: the sample is flagged (heading_gate) and is not fused."""
        gyro, corrected = self.gyro.at(t), self.gyro.at(t, corrected=True)
        if disturbed:
            self.disturbed = True
            if self._clean_gds is not None and gyro is not None:   # LSM input: the last clean GDS + gyro turn
                # (with the mean drift: the LSM's drift stays near it)
                self._last_gds = wrap_angle(self._clean_gds[0] + corrected - self._clean_gds[1])
            return self._hold(t) if self._lsm is None and gyro is not None else None
        if self.disturbed:
            self._recover(t)
        self._last_gds = heading
        if gyro is None:
            return None
        self._clean_gds = (heading, corrected)
        if self._kf is None and self._vwa is None:
            return None
        if self._vwa is not None:
            out = self._vwa.update(t, self._unwrap(heading), gyro)
            return None if out is None else self._clean_output(t, wrap_angle(out[1]), out[2])
        prev, self._prev_gds = self._prev_gds, (t, heading, gyro)
        if prev is None:
            return None
        dt = t - prev[0]
        # predictor form (2.16): y(k−1) and the gyro turn over (t_{k−1}, t_k] give x̂(k) at t_k
        self._kf.update(prev[1], prev[2], (gyro - prev[2]) / dt, self.speed * dt, dt)
        return self._clean_output(t, self._kf.heading, self._kf.heading_variance)

    def _clean_output(self, t, heading, variance):
        """Output of the estimator on clean GDS: its variance plus the GDS systematic error; kept for _hold."""
        var = max(variance, MIN_VARIANCE) + self.s.gds_systematic_sigma ** 2
        if self._settle is not None:
            if t < self._settle[0]:
                var = max(var, self._settle[1])
            else:
                self._settle = None
        gyro = self.gyro.at(t, corrected=True)
        if gyro is not None:
            self._clean = (t, heading, var, gyro)
        return t, heading, var

    def _drift_mean(self):
        """(mean, spread) of the recent LSM drift estimates (0, 0 for the estimators without one)."""
        if not self._drifts:
            return 0.0, 0.0
        d = [x for _, x in self._drifts]
        mean = sum(d) / len(d)
        return mean, math.sqrt(sum((x - mean) ** 2 for x in d) / len(d))

    def _hold(self, t):
        """Gyro-only heading from the last clean output (gyro with the mean drift), variance grown by the gyro
        errors and the drift's spread since."""
        gyro = self.gyro.at(t, corrected=True)
        if self._clean is None or gyro is None:
            return None
        t0, h0, v0, g0 = self._clean
        tau = t - t0
        var = v0 + propagation_variance(self.s.gyro, tau) + (self._drift_mean()[1] * tau) ** 2
        return t, wrap_angle(h0 + gyro - g0), var

    def _recover(self, t):
        """First clean GDS after a disturbance: the KF's drift state μ has not been observed since its last GDS."""
        self.disturbed = False
        if self._kf is not None and self._kf.x is not None and self._prev_gds is not None:
            self._kf.p[2, 2] += propagation_variance(self.s.gyro, t - self._prev_gds[0])
        vwa = self.s.vwa if self._vwa else (self.s.lsm_vwa if self._lsm else None)
        window = 0.0 if vwa is None else vwa.window + vwa.interval    # statistics of clean samples only
        hold = self._hold(t)
        self._settle = (t + window, hold[2]) if hold is not None and window > 0 else None

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
