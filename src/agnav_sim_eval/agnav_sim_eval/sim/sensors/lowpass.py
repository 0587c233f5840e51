"""Discrete first-order low-pass (exact for a held input), shared by the sensor models."""
import math

import numpy as np


class FirstOrderLag:
    """y' = (u - y)/τ; tau_s <= 0 passes the input through. Initialised on the first sample."""

    def __init__(self, tau_s):
        self.tau = tau_s
        self.y = None

    @classmethod
    def from_bandwidth(cls, hz):
        """Lag with -3 dB corner at hz (None: no lag)."""
        return cls(1.0 / (2 * math.pi * hz) if hz else 0.0)

    def update(self, u, dt):
        """Advance by dt with input u (scalar or array); returns the output."""
        u = np.asarray(u, dtype=float)
        if self.y is None or self.tau <= 0:
            self.y = u.copy()
        else:
            self.y = self.y + (1.0 - math.exp(-dt / self.tau)) * (u - self.y)
        return self.y
