"""u-blox-numbered observations (UBX driver events / agnav_msgs GnssObservations, duck-typed) into ObsEpoch:
satellite ids, frequency slots and wavelengths, loss of lock from a falling lock time, half cycles left out."""
from types import SimpleNamespace

import numpy as np

from agnav_fusion.gnss_raw.raw_input import epochs_from_events, satellite_id


def _obs(gnss_id, sv_id, sig_id, lock, half=True, pr=2.2e7):
    return SimpleNamespace(gnss_id=gnss_id, sv_id=sv_id, sig_id=sig_id, pseudorange=pr, carrier_phase=1.1e8,
                           doppler=-500.0, cno=42, lock_time=lock, pseudorange_valid=True,
                           carrier_phase_valid=True, half_cycle_resolved=half)


def _event(tow, obs, reset=False):
    return SimpleNamespace(week=2380, receiver_tow=tow, observations=obs, clock_reset=reset)


def test_ids_slots_and_lock():
    assert satellite_id(5, 194) == "J02" and satellite_id(5, 3) == "J03" and satellite_id(6, 4) is None
    first = [_obs(0, 5, 0, 10.0), _obs(0, 5, 3, 10.0), _obs(2, 11, 0, 10.0), _obs(3, 23, 0, 10.0, half=False),
             _obs(6, 4, 0, 10.0), _obs(0, 5, 6, 10.0)]            # GLONASS and GPS L5 are not in the plan
    second = [_obs(0, 5, 0, 10.5), _obs(0, 5, 3, 0.2), _obs(2, 11, 0, 10.5), _obs(3, 23, 0, 10.5)]
    a, b = epochs_from_events([_event(100.0, first), _event(101.0, second)])
    assert a.sats == ["C23", "E11", "G05"] and a.code.shape == (3, 2)
    g = a.row("G05")
    assert np.isclose(a.wavelength[g, 0], 299792458.0 / 1575.42e6)
    assert np.isclose(a.wavelength[g, 1], 299792458.0 / 1227.60e6)
    assert np.isnan(a.phase[a.row("C23"), 0]) and np.isfinite(a.code[a.row("C23"), 0])   # half cycle
    assert a.lli[g].all()                                      # first sight: no continuity known
    assert not b.lli[b.row("G05"), 0] and b.lli[b.row("G05"), 1]                          # L2 lock time fell
    assert not b.lli[b.row("E11"), 0]
    c = epochs_from_events([_event(100.0, first), _event(101.0, second, reset=True)])[1]
    assert c.lli[c.row("E11"), 0]                              # clock reset: every phase restarts
