"""Base-station raw observations from RTCM3 (MSM4/5/7 of GPS, Galileo, QZSS, BeiDou) and its antenna reference
point (1005/1006), parsed with pyrtcm into the UBX driver's GnssObservations events: the base is published and
consumed exactly like the rover's RXM-RAWX (u-blox gnssId/sigId numbering, agnav_msgs GnssObservations).

One MSM message per system arrives per epoch; `RtcmBase.feed` collects them and emits the epoch when the MSM
'multiple message' bit is clear (the last of the epoch). No week number is in RTCM: the caller supplies it
(from the rover or the clock). Signals without a u-blox sigId are skipped (the rover cannot pair them).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pyrtcm.rtcmhelpers import parse_msm

from .ubx import GnssObservation, GnssObservations

CLIGHT = 299792458.0
RANGE_MS = CLIGHT * 1e-3                      # metres per millisecond of range
BDT_TO_GPST = 14.0                            # s
SYSTEM = {"GPS": ("G", 0), "GALILEO": ("E", 2), "QZSS": ("J", 5), "BEIDOU": ("C", 3)}  # pyrtcm GNSSMAP names
# RINEX signal code -> u-blox sigId (RXM-RAWX numbering; the inverse of gnss_raw.raw_input.UBX_SIGNAL)
SIG_ID = {"G": {"1C": 0, "2L": 3, "2S": 4, "5I": 6, "5Q": 7},
          "E": {"1C": 0, "1B": 1, "5I": 3, "5Q": 4, "7I": 5, "7Q": 6, "6B": 8, "6C": 9},
          "C": {"2I": 0, "7I": 2, "1P": 5, "1D": 6, "5P": 7, "5D": 8},
          "J": {"1C": 0, "1Z": 1, "2S": 4, "2L": 5, "5I": 8, "5Q": 9}}
# carrier frequency [Hz] per system and RINEX band digit
FREQ = {"G": {"1": 1575.42e6, "2": 1227.60e6, "5": 1176.45e6},
        "J": {"1": 1575.42e6, "2": 1227.60e6, "5": 1176.45e6, "6": 1278.75e6},
        "E": {"1": 1575.42e6, "5": 1176.45e6, "7": 1207.14e6, "8": 1191.795e6, "6": 1278.75e6},
        "C": {"2": 1561.098e6, "1": 1575.42e6, "5": 1176.45e6, "7": 1207.14e6, "6": 1268.52e6}}
# "not available" values of the MSM fields after pyrtcm's scaling (RTCM 10403.3, DF397-DF406)
INVALID = {"DF397": 255, "DF400": -2 ** 14 * 2 ** -24, "DF401": -2 ** 21 * 2 ** -29, "DF405": -2 ** 19 * 2 ** -29,
           "DF406": -2 ** 23 * 2 ** -31, "DF399": -8192, "DF404": -16384 * 0.0001}


@dataclass
class BasePosition:
    station: int
    ecef: np.ndarray          # antenna reference point, m
    antenna_height: float     # m (1006; 0 for 1005)


def lock_time_s(cell):
    """Minimum lock time [s] of an MSM cell: DF402 (MSM4/5, 4-bit) or DF407 (MSM7, 10-bit extended)."""
    if "DF407" in cell:
        i = int(cell["DF407"])
        if i < 64:
            return i * 1e-3
        k = min(i // 32 - 1, 21)
        return 2 ** k * (i - 32 * k) * 1e-3
    i = int(cell.get("DF402", 0))
    return 0.0 if i == 0 else 2 ** (i + 4) * 1e-3


def _valid(d, key):
    return key in d and d[key] is not None and d[key] != INVALID.get(key, None)


def msm_observations(msg):
    """(system letter, receiver time of week [s, GPS], [GnssObservation]) of one pyrtcm MSM4/5/7 message;
    None for other messages or systems."""
    if not getattr(msg, "ismsm", False) or msg.identity[-1] not in "457":
        return None
    meta, sats, cells = parse_msm(msg)
    system = SYSTEM.get(meta["gnss"])
    if system is None:
        return None
    letter, gnss_id = system
    tow = meta["epoch"] * 1e-3 + (BDT_TO_GPST if letter == "C" else 0.0)
    rough = {int(s["PRN"]): s for s in sats}
    out = []
    for c in cells:
        prn, code = int(c["CELLPRN"]), str(c["CELLSIG"])
        sig_id, sat = SIG_ID[letter].get(code), rough.get(prn)
        freq = FREQ[letter].get(code[0])
        if sig_id is None or sat is None or freq is None or not _valid(sat, "DF397"):
            continue
        base_ms = sat["DF397"] + sat.get("DF398", 0.0)
        fine_pr, fine_cp = ("DF405", "DF406") if "DF405" in c else ("DF400", "DF401")
        pr_ok, cp_ok = _valid(c, fine_pr), _valid(c, fine_cp)
        lam = CLIGHT / freq
        doppler = 0.0
        if _valid(sat, "DF399") and _valid(c, "DF404"):
            # sign checked on the real ZED-F9T log: code and phase ranges change by −(DF399 + DF404) per second
            doppler = (sat["DF399"] + c["DF404"]) / lam            # Hz, positive when approaching
        out.append(GnssObservation(
            gnss_id, prn, sig_id, 0, (base_ms + c[fine_pr]) * RANGE_MS if pr_ok else 0.0,
            (base_ms + c[fine_cp]) * RANGE_MS / lam if cp_ok else 0.0, doppler,
            int(round(c.get("DF408", c.get("DF403", 0.0)))), lock_time_s(c), 0.0, 0.0, 0.0, pr_ok, cp_ok,
            not c.get("DF420", 0), False))
    return letter, tow, out


def base_position(msg):
    """BasePosition of a pyrtcm 1005/1006 message, else None."""
    if getattr(msg, "identity", None) not in ("1005", "1006"):
        return None
    return BasePosition(int(msg.DF003), np.array([msg.DF025, msg.DF026, msg.DF027], float),
                        float(getattr(msg, "DF028", 0.0)))


class RtcmBase:
    """Collects the MSM messages of one base epoch into a GnssObservations event; remembers the base position."""

    def __init__(self):
        self.position = None
        self._tow, self._obs = None, []

    def feed(self, msg, week, host_time=0.0):
        """One parsed pyrtcm message -> list of events (GnssObservations at the end of an epoch, BasePosition)."""
        pos = base_position(msg)
        if pos is not None:
            self.position = pos
            return [pos]
        parsed = msm_observations(msg)
        if parsed is None:
            return []
        events = []
        _, tow, obs = parsed
        if self._tow is not None and abs(tow - self._tow) > 1e-3:    # a new epoch without the closing bit
            events.append(self._flush(week, host_time))
        self._tow = tow
        self._obs += obs
        if not getattr(msg, "DF393", 0):                              # multiple-message bit clear: epoch done
            events.append(self._flush(week, host_time))
        return events

    def _flush(self, week, host_time):
        event = GnssObservations(host_time, self._tow, int(week), 18, False, False, self._obs)
        self._tow, self._obs = None, []
        return event
