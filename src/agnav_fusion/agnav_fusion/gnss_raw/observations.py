"""One receiver's observation epoch as plain arrays (rover or base), and the signal plan it is read with.

Rows are satellites ('G05', 'E11', 'J03', 'C23'), columns the frequency slots of SIGNALS (slot 0 = L1/E1/B1I,
slot 1 = the second frequency). Missing values are NaN; `lli` is the loss-of-lock flag (bit 0 of the RINEX LLI).
"""
from dataclasses import dataclass, field

import numpy as np

CLIGHT = 299792458.0
# system letter -> RINEX signal code per frequency slot (code/phase/Doppler/SNR share the 2-character code)
SIGNALS = {"G": ("1C", "2W"), "E": ("1C", "5Q"), "J": ("1C", "2L"), "C": ("2I", "7I")}


@dataclass
class ObsEpoch:
    """Observations of one receiver at one epoch (receiver time, GPS week + time of week)."""
    week: int
    tow: float
    sats: list
    code: np.ndarray        # (n, nf) pseudorange [m]
    phase: np.ndarray       # (n, nf) carrier phase [cycles]
    doppler: np.ndarray     # (n, nf) Doppler [Hz], positive when approaching
    snr: np.ndarray         # (n, nf) C/N0 [dB-Hz]
    lli: np.ndarray         # (n, nf) loss-of-lock flag (bool)
    wavelength: np.ndarray  # (n, nf) carrier wavelength [m]
    index: dict = field(init=False, repr=False)

    def __post_init__(self):
        self.index = {s: i for i, s in enumerate(self.sats)}

    @property
    def time(self):
        """GPS seconds since the GPS epoch (for ordering and matching; keep week/tow for ephemeris maths)."""
        return self.week * 604800.0 + self.tow

    def row(self, sat):
        return self.index.get(sat)

    def first_code(self):
        """(n,) the first available pseudorange of each satellite (signal travel time), NaN if none."""
        out = np.full(len(self.sats), np.nan)
        for f in range(self.code.shape[1] - 1, -1, -1):
            ok = np.isfinite(self.code[:, f])
            out[ok] = self.code[ok, f]
        return out


def match_epochs(rover, base, tolerance=0.01):
    """Pairs (rover_epoch, base_epoch) of equal receiver time (within `tolerance` s), in rover order."""
    by_time = {round(b.time / tolerance): b for b in base}
    return [(r, by_time[round(r.time / tolerance)]) for r in rover if round(r.time / tolerance) in by_time]
