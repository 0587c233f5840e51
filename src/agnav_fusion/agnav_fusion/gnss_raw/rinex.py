"""RINEX 3 observation and navigation files through cssrlib's reader, into ObsEpoch arrays and a cssrlib Nav.

Septentrio's sbf2rin writes a receiver-channel pseudo-observable 'X1' first in every system's obs-type list,
which cssrlib's header parser rejects; it is renamed to an SNR code of an unused band ('S9') that no signal plan
selects, so the data columns stay aligned and the channel numbers are skipped.
"""
import io

import numpy as np
from cssrlib.gnss import Nav, rSigRnx, sat2id, time2gpst
from cssrlib.rinex import rnxdec

from agnav_fusion.gnss_raw.observations import SIGNALS, ObsEpoch

OBS_TYPES = ("C", "L", "D", "S")
CHANNEL_PLACEHOLDER = "S9 "


def read_nav(path):
    """Broadcast ephemerides of a RINEX 3 navigation file (cssrlib Nav: .eph for GPS/GAL/QZS/BDS, .geph GLONASS)."""
    nav = Nav()
    rnxdec().decode_nav(str(path), nav)
    return nav


def _header_fixed(path):
    """The file as a text stream with the 'X1' channel pseudo-observable renamed in the obs-type header lines."""
    lines = open(path, "rt").read().splitlines(keepends=True)
    for i, line in enumerate(lines):
        if "END OF HEADER" in line[60:]:
            break
        if "SYS / # / OBS TYPES" in line[60:]:
            lines[i] = line[:60].replace(" X1 ", " " + CHANNEL_PLACEHOLDER) + line[60:]
    return io.StringIO("".join(lines))


def _decoder(path, signals):
    dec = rnxdec()
    dec.setSignals([rSigRnx(sys + t + code) for sys, codes in signals.items() for code in codes
                    for t in OBS_TYPES])
    dec.fobs = _header_fixed(path)
    if dec._decode_obsh() != 0:
        raise ValueError(f"{path}: not a RINEX >= 3.02 observation file")
    return dec


def _epoch(obs, signals):
    ids = [sat2id(s) for s in obs.sat]
    nf = max(len(c) for c in signals.values())
    wl = np.full((len(ids), nf), np.nan)
    for i, sid in enumerate(ids):
        for f, code in enumerate(signals[sid[0]]):
            wl[i, f] = rSigRnx(sid[0] + "L" + code).wavelength()

    def arr(a):
        a = np.array(a, float)[:, :nf]
        a[a == 0.0] = np.nan
        return a
    week, tow = time2gpst(obs.t)
    return ObsEpoch(week=int(week), tow=float(tow), sats=ids, code=arr(obs.P), phase=arr(obs.L),
                    doppler=arr(obs.D), snr=arr(obs.S), lli=np.array(obs.lli)[:, :nf] & 1 == 1, wavelength=wl)


def read_obs(path, signals=SIGNALS, max_epochs=None):
    """Observation epochs of a RINEX 3 file for the systems and frequency slots of `signals`."""
    dec = _decoder(path, signals)
    epochs = []
    while max_epochs is None or len(epochs) < max_epochs:
        obs = dec.decode_obs()
        if obs.t.time == 0:
            break
        epochs.append(_epoch(obs, signals))
    return epochs
