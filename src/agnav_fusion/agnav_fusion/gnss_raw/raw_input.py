"""Raw receiver observations into ObsEpoch arrays: u-blox-numbered observations (the UBX driver's RXM-RAWX
events and the agnav_msgs GnssObservations message carry the same field names, so both work duck-typed, without
ROS), and GPS LNAV ephemerides from RXM-SFRBX subframe words into a cssrlib Nav.

Loss of lock: a signal's `lock_time` that falls (or a receiver clock reset) sets the ObsEpoch `lli` flag, as
RTKLIB does for RAWX; phase with an unresolved half cycle is left out (NaN).

RawInput gathers a node's raw-GNSS topics (rover and base GnssObservations, the base position, GnssNavData frames)
into what the tightly coupled filter needs: the latest rover and base ObsEpochs, the base ECEF position, the Nav.
"""
import numpy as np
from cssrlib.gnss import Nav, gpst2time, id2sat, rSigRnx
from cssrlib.rawnav import RawNav

from agnav_fusion.gnss_raw.observations import ObsEpoch

UBX_SYSTEM = {0: "G", 2: "E", 3: "C", 5: "J"}        # u-blox gnssId -> RINEX system letter (GLONASS/SBAS out)
# u-blox sigId -> RINEX signal code, per system (interface description, RXM-RAWX)
UBX_SIGNAL = {"G": {0: "1C", 3: "2L", 4: "2S", 6: "5I", 7: "5Q"},
              "E": {0: "1C", 1: "1B", 3: "5I", 4: "5Q", 5: "7I", 6: "7Q", 8: "6B", 9: "6C"},
              "C": {0: "2I", 1: "2I", 2: "7I", 3: "7I", 5: "1P", 6: "1D", 7: "5P", 8: "5D"},
              "J": {0: "1C", 1: "1Z", 4: "2S", 5: "2L", 8: "5I", 9: "5Q"}}
# frequency slots of a u-blox F9P (L1/L2 type) receiver; observations.SIGNALS is the Septentrio pair's plan
UBX_SIGNALS = {"G": ("1C", "2L"), "E": ("1C", "7Q"), "J": ("1C", "2L"), "C": ("2I", "7I")}


def satellite_id(gnss_id, sv_id):
    """'G05' style id of a u-blox (gnssId, svId); None for systems not used (GLONASS, SBAS, IRNSS)."""
    system = UBX_SYSTEM.get(int(gnss_id))
    if system is None:
        return None
    prn = int(sv_id) - 192 if system == "J" and sv_id > 192 else int(sv_id)
    return f"{system}{prn:02d}"


class LockTracker:
    """Loss-of-lock flags from the lock time of each (satellite, signal) across epochs."""

    def __init__(self):
        self.last = {}

    def slipped(self, key, lock_time, reset=False):
        prev = self.last.get(key)
        self.last[key] = lock_time
        return reset or prev is None or lock_time < prev


def observation_epoch(week, tow, observations, signals=UBX_SIGNALS, locks=None, clock_reset=False):
    """ObsEpoch of one receiver epoch from u-blox-numbered observations (objects with gnss_id, sv_id, sig_id,
    pseudorange, carrier_phase, doppler, cno, lock_time and the *_valid / half_cycle_resolved flags)."""
    nf = max(len(c) for c in signals.values())
    rows = {}
    for o in observations:
        sid = satellite_id(o.gnss_id, o.sv_id)
        if sid is None or sid[0] not in signals:
            continue
        code = UBX_SIGNAL[sid[0]].get(int(o.sig_id))
        if code not in signals[sid[0]]:
            continue
        rows.setdefault(sid, {})[signals[sid[0]].index(code)] = o
    sats = sorted(rows)
    shape = (len(sats), nf)
    pr, cp, dop, snr, wl = (np.full(shape, np.nan) for _ in range(5))
    lli = np.zeros(shape, bool)
    for i, sid in enumerate(sats):
        for f, o in rows[sid].items():
            wl[i, f] = rSigRnx(sid[0] + "L" + signals[sid[0]][f]).wavelength()
            if o.pseudorange_valid:
                pr[i, f] = o.pseudorange
            if o.carrier_phase_valid and o.half_cycle_resolved:
                cp[i, f] = o.carrier_phase
            dop[i, f], snr[i, f] = o.doppler, o.cno
            if locks is not None:
                lli[i, f] = locks.slipped((sid, f), o.lock_time, clock_reset)
    return ObsEpoch(week=int(week), tow=float(tow), sats=sats, code=pr, phase=cp, doppler=dop, snr=snr, lli=lli,
                    wavelength=wl)


def epochs_from_events(events, signals=UBX_SIGNALS):
    """ObsEpochs of a sequence of UBX driver GnssObservations events (or agnav_msgs GnssObservations)."""
    locks = LockTracker()
    return [observation_epoch(e.week, e.receiver_tow, e.observations, signals, locks, e.clock_reset)
            for e in events]


def _gal_pages(words):
    """u-blox Galileo I/NAV frame (8 words: even page, odd page, 120 bits each in a 128-bit block) -> the
    240 contiguous bits RawNav expects; None unless it is an even page followed by an odd one."""
    value = 0
    for w in words[:8]:
        value = (value << 32) | (int(w) & 0xFFFFFFFF)
    even, odd = value >> (128 + 8), (value >> 8) & ((1 << 120) - 1)
    if even >> 119 != 0 or odd >> 119 != 1:
        return None
    return ((even << 120) | odd).to_bytes(30, "big")


class SubframeNav:
    """GPS LNAV and Galileo I/NAV ephemerides from RXM-SFRBX frames (GPS: 10 words with 30 data bits
    right-aligned in each 32-bit word), decoded by cssrlib's RawNav into a cssrlib Nav for satellite_states."""

    def __init__(self):
        self.nav = Nav()
        self._decoder = RawNav()

    def add(self, gnss_id, sv_id, sig_id, words, week, tow):
        """Feed one frame received at GPS (week, tow); True when it completed a new ephemeris. GPS and QZSS from
        L1 C/A only (L2C/L5 CNAV frames share the LNAV preamble 0x8B), Galileo from E1B / E5bI I/NAV."""
        t, sat = gpst2time(int(week), float(tow)), id2sat(satellite_id(gnss_id, sv_id) or "R01")
        if int(gnss_id) in (0, 5) and int(sig_id) == 0 and len(words) >= 10:
            data = b"".join((int(w) & 0xFFFFFFFF).to_bytes(4, "big") for w in words[:10])
            eph = self._decoder.decode_gps_lnav(int(week), t, sat, data)
        elif int(gnss_id) == 2 and int(sig_id) in (1, 5) and len(words) >= 8 and _gal_pages(words) is not None:
            eph = self._decoder.decode_gal_inav(int(week), t, sat, 0 if int(sig_id) == 1 else 2, _gal_pages(words))
        else:
            return False
        if eph is None:
            return False
        known = [e for e in self.nav.eph if e.sat == eph.sat and e.iode == eph.iode and e.toe.time == eph.toe.time]
        if known:
            return False
        self.nav.eph.append(eph)
        return True



class RawInput:
    """Raw-GNSS messages (duck-typed agnav_msgs) -> ObsEpochs, base position and broadcast ephemerides. Navigation
    frames wait for the first rover epoch (its GPS week and time decode them)."""

    def __init__(self, signals=UBX_SIGNALS):
        self.signals = signals
        self.locks = {"rover": LockTracker(), "base": LockTracker()}
        self.subframes = SubframeNav()
        self.base = None          # latest base ObsEpoch
        self.base_pos = None      # base antenna ECEF [m]
        self._time = None         # (week, tow) of the latest rover epoch
        self._frames = []         # navigation frames before it

    @property
    def nav(self):
        return self.subframes.nav

    def observations(self, msg, receiver="rover"):
        """ObsEpoch of a GnssObservations message of `receiver` (rover | base); the base one is kept."""
        epoch = observation_epoch(msg.week, msg.receiver_tow, msg.observations, self.signals, self.locks[receiver],
                                  msg.clock_reset)
        if receiver == "base":
            self.base = epoch
        else:
            self._time = (epoch.week, epoch.tow)
            for frame in self._frames:
                self.subframes.add(*frame, *self._time)
            self._frames = []
        return epoch

    def base_position(self, x, y, z):
        self.base_pos = np.array([x, y, z], dtype=float)

    def nav_data(self, msg):
        """One GnssNavData frame; True when it completed a new ephemeris."""
        frame = (msg.gnss_id, msg.sv_id, msg.sig_id, list(msg.words))
        if self._time is None:
            self._frames.append(frame)
            return False
        return self.subframes.add(*frame, *self._time)
