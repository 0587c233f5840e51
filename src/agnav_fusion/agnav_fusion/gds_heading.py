"""Fluxgate GDS heading: geomagnetic-circle calibration, tilt compensation, heading (SPEC §3.1–3.2, §4.4).

Thesis vehicle frame inside this module: x right, y forward, z up; roll θ_r right side down +,
pitch θ_p nose up +; heading φ clockwise from (magnetic) north. Angles in rad.
"""
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import sqrtm


@dataclass
class CircleCalibration:
    """Geomagnetic-circle correction b' = W (b − c) in the horizontal (x, y) plane (SPEC §3.2 step 1)."""

    center: np.ndarray = field(default_factory=lambda: np.zeros(2))      # (a, b) hard iron
    soft_iron: np.ndarray = field(default_factory=lambda: np.eye(2))     # W (identity = circle only)
    radius: float = float("nan")                                          # r of (2.5) after correction
    z_offset: float = 0.0                                                  # not observable from a level turn

    def apply(self, b: np.ndarray) -> np.ndarray:
        """Correct (..., 3) field samples (x, y, z)."""
        b = np.array(b, dtype=float)
        b[..., :2] = (b[..., :2] - self.center) @ self.soft_iron.T
        b[..., 2] -= self.z_offset
        return b


def fit_circle(bx: np.ndarray, by: np.ndarray) -> CircleCalibration:
    """Kåsa fit of the geomagnetic circle (2.5): min Σ(Bx²+By²−2aBx−2bBy−c)², r² = c+a²+b² (SPEC §3.2)."""
    bx, by = np.asarray(bx, float), np.asarray(by, float)
    a_mat = np.column_stack([2 * bx, 2 * by, np.ones_like(bx)])
    (a, b, c), *_ = np.linalg.lstsq(a_mat, bx**2 + by**2, rcond=None)
    return CircleCalibration(center=np.array([a, b]), radius=float(np.sqrt(c + a * a + b * b)))


def fit_ellipse(bx: np.ndarray, by: np.ndarray) -> CircleCalibration:
    """Soft-iron extension of §3.2: least-squares conic A x²+B xy+C y²+D x+E y = 1, mapped back to a circle.

    W = r·sqrtm(M/k) with M the conic's quadratic form at the centre, so W is symmetric (no rotation of
    the heading reference) and r is the geometric-mean radius of the ellipse.
    """
    bx, by = np.asarray(bx, float), np.asarray(by, float)
    scale = np.sqrt(np.mean(bx**2 + by**2))  # condition the design matrix
    x, y = bx / scale, by / scale
    design = np.column_stack([x * x, x * y, y * y, x, y])
    (qa, qb, qc, qd, qe), *_ = np.linalg.lstsq(design, np.ones_like(x), rcond=None)
    m = np.array([[qa, qb / 2], [qb / 2, qc]])
    if np.linalg.det(m) <= 0:
        raise ValueError("field samples do not lie on an ellipse (turn through 360°)")
    center = np.linalg.solve(2 * m, -np.array([qd, qe]))
    m_unit = m / (1 + center @ m @ center)          # (b − c)ᵀ m_unit (b − c) = 1
    radius = np.linalg.det(m_unit) ** -0.25
    soft = radius * np.real(sqrtm(m_unit))
    return CircleCalibration(center=center * scale, soft_iron=soft, radius=float(radius * scale))


def with_vertical_offset(cal: CircleCalibration, bz_level: np.ndarray, expected_up: float) -> CircleCalibration:
    """z offset of a level calibration turn from the WMM vertical field (up component −F sin I) [IMPL]."""
    return CircleCalibration(cal.center, cal.soft_iron, cal.radius, float(np.mean(bz_level)) - expected_up)


def tilt_compensate(b: np.ndarray, roll: float, pitch: float) -> np.ndarray:
    """Level a (…, 3) field with B' = F₂(−θ_p) F₁(−θ_r) B (SPEC §3.2 step 2, rotations of eq 4.18–4.19)."""
    b = np.asarray(b, float)
    cr, sr, cp, sp = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch)
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    xl = cr * bx + sr * bz
    zr = -sr * bx + cr * bz                      # z after undoing roll
    yl = cp * by - sp * zr
    zl = sp * by + cp * zr
    return np.stack([xl, yl, zl], axis=-1)


def magnetic_heading(b_level: np.ndarray) -> np.ndarray:
    """φ_mag = atan2(−B′x, B′y), clockwise from magnetic north (SPEC §3.1 (2.2)–(2.4) with errata 1, §3.2 step 3)."""
    b_level = np.asarray(b_level, float)
    return np.arctan2(-b_level[..., 0], b_level[..., 1])


def inclination(b_level: np.ndarray) -> np.ndarray:
    """Dip angle I below the horizontal (SPEC §3.1), from a levelled field (z up)."""
    b_level = np.asarray(b_level, float)
    return np.arctan2(-b_level[..., 2], np.hypot(b_level[..., 0], b_level[..., 1]))
