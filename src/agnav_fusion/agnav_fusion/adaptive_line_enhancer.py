"""Adaptive line enhancer (LMS linear predictor) for inclinometer denoising (SPEC §4.3, eq 3.11–3.13)."""
from collections import deque
from dataclasses import dataclass

import numpy as np


@dataclass
class AleSettings:
    """ALE parameters (SPEC §4.3 table); μ is not given by the thesis and is a tuning value."""

    n_taps: int = 50          # N, predictor coefficients
    delay: int = 1            # L, decorrelation delay (white noise -> 1)
    mu: float = 0.002         # step size (normalised by ||x||^2 when `normalized`)
    normalized: bool = True   # NLMS: robust to the large DC part of tilt angles (SPEC §4.3 [IMPL])
    eps: float = 1e-9         # NLMS regulariser


class AdaptiveLineEnhancer:
    """Causal ALE: y(n) = Σ h_k(n) u(n−L−k) (3.11), LMS update (3.12) with e = u − y (3.13, sign per errata 9)."""

    def __init__(self, settings: AleSettings | None = None, taps: np.ndarray | None = None):
        self.s = settings or AleSettings()
        n = self.s.n_taps
        self.h = np.full(n, 1.0 / n) if taps is None else np.array(taps, dtype=float)
        if self.h.shape != (n,):
            raise ValueError(f"taps must have length {n}")
        self._u = deque(maxlen=n + self.s.delay)  # newest first: u(n), u(n−1), ...
        self.adapt = True

    def reset(self):
        """Forget the signal history (keeps the learned taps)."""
        self._u.clear()

    def update(self, u: float) -> float:
        """Feed u(n), return the enhanced y(n); the history is pre-filled with the first sample."""
        if not self._u:
            self._u.extend([u] * self._u.maxlen)
        x = np.fromiter(self._u, float, self._u.maxlen)[self.s.delay - 1:self.s.delay - 1 + self.s.n_taps]
        # x[k] = u(n−L−k) once u(n) is pushed; the buffer still holds u(n−1) at index 0 here.
        y = float(self.h @ x)
        if self.adapt:
            e = u - y
            step = self.s.mu / (self.s.eps + x @ x) if self.s.normalized else self.s.mu
            self.h += step * e * x
        self._u.appendleft(u)
        return y

    def filter(self, u: np.ndarray) -> np.ndarray:
        """Run update() over a record."""
        return np.array([self.update(float(v)) for v in np.asarray(u, dtype=float)])

    def delay_samples(self) -> float:
        """Low-frequency group delay of the predictor in samples: L + Σ k h_k / Σ h_k."""
        k = np.arange(self.s.n_taps)
        return self.s.delay + float(k @ self.h / self.h.sum())


def two_pass(u: np.ndarray, settings: AleSettings | None = None, adapt_second_pass: bool = False):
    """Thesis' offline procedure (SPEC §4.3): pass 1 learns h_k from h(0)=1/N, pass 2 filters the same record.

    Returns (y, ale) — the pass-2 output and the enhancer holding the learned taps.
    """
    ale = AdaptiveLineEnhancer(settings)
    ale.filter(u)
    ale.reset()
    ale.adapt = adapt_second_pass
    return ale.filter(u), ale
