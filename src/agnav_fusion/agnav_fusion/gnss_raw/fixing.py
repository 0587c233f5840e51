"""Integer ambiguity resolution: LAMBDA (lambda_search) on the DD ambiguities in cycles, the ratio test, and
the fixed baseline conditioned on the integers (b̌ = b̂ − Q_ba Q_aa⁻¹ (â − ǎ), metres)."""
from dataclasses import dataclass

import numpy as np

from agnav_fusion.gnss_raw.lambda_search import SearchBudgetExceeded, lambda_ils

RATIO_THRESHOLD = 3.0   # second-best / best squared norm (RTKLIB's default validation threshold)
MIN_AMBIGUITIES = 4


@dataclass
class FixResult:
    ok: bool
    ratio: float
    n: int                    # ambiguities in the search
    pos: np.ndarray = None    # fixed position states (n_fixed,)
    cov: np.ndarray = None    # their covariance
    integers: np.ndarray = None


def fix(x, P, n_fixed, wavelength, threshold=RATIO_THRESHOLD):
    """Fix all ambiguities x[n_fixed:] (metres, DDs of wavelength `wavelength`) of the state (x, P)."""
    a, lam = x[n_fixed:], np.asarray(wavelength, float)
    if len(a) < MIN_AMBIGUITIES:
        return FixResult(False, 0.0, len(a))
    Q_aa = P[n_fixed:, n_fixed:]
    try:
        cands, s = lambda_ils(a / lam, Q_aa / np.outer(lam, lam), ncands=2)
    except (np.linalg.LinAlgError, SearchBudgetExceeded):
        return FixResult(False, 0.0, len(a))
    ratio = float(s[1] / s[0]) if s[0] > 0 else float("inf")
    if ratio < threshold:
        return FixResult(False, ratio, len(a))
    a_fix = cands[:, 0] * lam
    K = np.linalg.solve(Q_aa, P[n_fixed:, :n_fixed]).T     # Q_ba Q_aa⁻¹
    pos = x[:n_fixed] - K @ (a - a_fix)
    cov = P[:n_fixed, :n_fixed] - K @ P[n_fixed:, :n_fixed]
    return FixResult(True, ratio, len(a), pos, cov, cands[:, 0])
