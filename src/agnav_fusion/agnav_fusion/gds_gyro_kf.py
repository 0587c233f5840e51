"""GDS + gyro Kalman filter for straight driving (SPEC §3.5, eq 2.12–2.30, Table 2.3).

State x = (ε, η, μ): lateral deviation [m], η = sin φ (gyro heading deviation from the target),
μ = sin δ (gyro drift as a heading offset); the true deviation is φ + δ. Headings in rad, clockwise.
"""
import math
from dataclasses import dataclass, field

import numpy as np

from agnav_common.frames import wrap_angle as _wrap

# Table 2.3 as printed except P(0)₁₁, printed negative: its magnitude is used (SPEC errata 5).
P0_TABLE_2_3 = [[43.593211, 0.000068, 0.000062], [0.000068, 0.047277, 0.000001], [0.000062, 0.000001, 0.000001]]
# Default: its diagonal. ε is unobservable in (2.30), so the printed ε–η/μ cross terms feed every innovation into
# ε from the first step (synthetic 80 s run: lateral r.m.s. 0.53 m with them, 0.02 m without).
P0_DIAGONAL = [[P0_TABLE_2_3[i][j] if i == j else 0.0 for j in range(3)] for i in range(3)]


@dataclass
class KfSettings:
    """Table 2.3 values; Q's rate term is read as (°/s)² (SPEC §3.5 [DERIVED/AMBIG]) and converted to rad."""

    q_speed: float = 0.003335                       # (m/s)²
    q_rate: float = 0.039741 * (math.pi / 180) ** 2  # (rad/s)²
    r_gds: float = 0.0000527340                      # (sin φ_GDS)²
    r_gyro: float = 0.0000010695                     # (sin φ_FOG)²
    p0: list = field(default_factory=lambda: [row[:] for row in P0_DIAGONAL])
    drift_noise: float = 0.0                         # μ random walk, 1/s (thesis: 0; [IMPL] SPEC §3.5 pitfall)
    retarget_limit: float = math.radians(20.0)      # re-anchor the target beyond this deviation (cos φ ≈ 1 model)


class GdsGyroKalmanFilter:
    """One-step predictor KF (2.16)–(2.18) on the model (2.22), (2.25), (2.30)."""

    C = np.array([[0.0, 1.0, 1.0], [0.0, 1.0, 0.0]])

    def __init__(self, settings: KfSettings | None = None):
        self.s = settings or KfSettings()
        self.x: np.ndarray | None = None
        self.p = np.array(self.s.p0, dtype=float)
        self.target = 0.0          # absolute target heading; deviations are taken from it

    def start(self, heading_gds: float, heading_gyro: float, target: float | None = None):
        """Initialise on the target (default: current GDS heading); μ starts at the GDS−gyro offset (SPEC §3.5)."""
        self.target = heading_gds if target is None else target
        eta = math.sin(_wrap(heading_gyro - self.target))
        self.x = np.array([0.0, eta, math.sin(_wrap(heading_gds - self.target)) - eta])
        self.p = np.array(self.s.p0, dtype=float)

    @property
    def deviation(self) -> float:
        """Estimated true heading deviation φ + δ from the target [rad]."""
        return math.asin(max(-1.0, min(1.0, self.x[1] + self.x[2])))

    @property
    def heading(self) -> float:
        """Estimated absolute heading [rad, wrapped]."""
        return _wrap(self.target + self.deviation)

    @property
    def heading_variance(self) -> float:
        """Variance of η + μ mapped to the heading (rad²)."""
        g = np.array([0.0, 1.0, 1.0]) / max(math.cos(self.deviation), 1e-3)
        return float(g @ self.p @ g)

    def update(self, heading_gds: float, heading_gyro: float, rate: float, dd: float, dt: float,
               r_gds_scale: float = 1.0) -> np.ndarray:
        """Absorb y(k) (absolute GDS and gyro headings, rad) and propagate with r(k) [rad/s], Δd(k) [m], dt.

        Returns x̂(k+1) (2.16). r_gds_scale inflates R_GDS (magnetic disturbance de-weighting).
        """
        if self.x is None:
            self.start(heading_gds, heading_gyro)
        y = np.array([math.sin(_wrap(heading_gds - self.target)), math.sin(_wrap(heading_gyro - self.target))])
        eps, eta, mu = self.x
        c_r, s_r = math.cos(rate * dt), math.sin(rate * dt)
        a = np.array([[1.0, dd, dd], [0.0, c_r, 0.0], [0.0, 0.0, 1.0]])                      # (2.22)
        u = np.array([0.0, s_r, 0.0])
        b = np.array([[(eta + mu) * dt, 0.0], [0.0, (c_r - eta * s_r) * dt], [0.0, 0.0]])    # (2.25)
        q = np.diag([self.s.q_speed, self.s.q_rate])
        r = np.diag([self.s.r_gds * r_gds_scale, self.s.r_gyro])
        c = self.C
        s_inv = np.linalg.inv(r + c @ self.p @ c.T)
        k = a @ self.p @ c.T @ s_inv                                                            # (2.17)
        self.x = a @ self.x + u + k @ (y - c @ self.x)                                          # (2.16)
        self.p = a @ (self.p - self.p @ c.T @ s_inv @ c @ self.p) @ a.T + b @ q @ b.T           # (2.18)
        self.p[2, 2] += self.s.drift_noise * dt
        self.p = 0.5 * (self.p + self.p.T)
        if abs(self.deviation) > self.s.retarget_limit:
            self._retarget()
        return self.x

    def _retarget(self):
        """Move the target to the current heading so that cos φ ≈ 1 holds again (turns; [IMPL])."""
        dev = self.deviation
        drift = math.asin(max(-1.0, min(1.0, self.x[2])))
        self.target = _wrap(self.target + dev)
        self.x = np.array([0.0, math.sin(-drift), self.x[2]])
        self.p[0, :] = self.p[:, 0] = 0.0
        self.p[0, 0] = self.s.p0[0][0]

