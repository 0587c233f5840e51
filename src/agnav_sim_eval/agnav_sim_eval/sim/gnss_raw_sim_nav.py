"""Broadcast ephemerides as the navigation data frames a u-blox receiver delivers (RXM-SFRBX, agnav_msgs GnssNavData):
the simulated receiver's /gnss/nav_data, so that the navigation node gets its orbits from the topic as on a tractor.

GPS and QZSS LNAV: subframes 1–3, ten 32-bit words each with the 30 data bits right-aligned (u-blox layout);
Galileo I/NAV (E1-B): word types 1–5, each as an even + odd page pair in eight 32-bit words. Fields are quantised
with the interface specifications' scale factors (IS-GPS-200 Table 20-III, Galileo OS SIS ICD Table 60), so a
RINEX navigation record (printed from the same integers) comes back bit for bit through cssrlib's RawNav
(agnav_fusion.gnss_raw.raw_input.SubframeNav). Parity and CRC bits are zero (the decoder does not check them);
unhealthy records and Galileo F/NAV records are left out.
"""
import math

from cssrlib.gnss import sat2id

SC = math.pi            # semicircles -> rad
UBX_GNSS = {"G": 0, "E": 2, "J": 5}
GAL_E1B = 1             # u-blox sigId of Galileo E1-B; GPS / QZSS L1 C/A is 0


def _bits(fields):
    """Integer of [(value, width)] packed MSB first (negative values in two's complement)."""
    out = 0
    for value, width in fields:
        out = (out << width) | (int(value) & ((1 << width) - 1))
    return out


def _q(value, scale):
    return round(value / scale)


def lnav_subframes(eph, tow):
    """Three LNAV subframes (ten u-blox words each) of a GPS / QZSS record; `tow` [s]: GPS time of week sent."""
    m0, e, sqrt_a = _q(eph.M0, 2 ** -31 * SC), _q(eph.e, 2 ** -33), _q(math.sqrt(eph.A), 2 ** -19)
    omg0, i0, omg = _q(eph.OMG0, 2 ** -31 * SC), _q(eph.i0, 2 ** -31 * SC), _q(eph.omg, 2 ** -31 * SC)
    iodc = int(eph.iodc)
    data = {
        1: [[(eph.week % 1024, 10), (eph.code, 2), (0, 4), (eph.svh, 6), (iodc >> 8, 2)], [(eph.l2p, 1), (0, 23)],
            [(0, 24)], [(0, 24)], [(0, 16), (_q(eph.tgd, 2 ** -31), 8)],
            [(iodc & 0xFF, 8), (_q(_tow_of(eph.toc), 16), 16)],
            [(_q(eph.af2, 2 ** -55), 8), (_q(eph.af1, 2 ** -43), 16)], [(_q(eph.af0, 2 ** -31), 22), (0, 2)]],
        2: [[(eph.iode, 8), (_q(eph.crs, 2 ** -5), 16)], [(_q(eph.deln, 2 ** -43 * SC), 16), (m0 >> 24, 8)],
            [(m0, 24)], [(_q(eph.cuc, 2 ** -29), 16), (e >> 24, 8)], [(e, 24)],
            [(_q(eph.cus, 2 ** -29), 16), (sqrt_a >> 24, 8)], [(sqrt_a, 24)],
            [(_q(eph.toes, 16), 16), (0, 1), (0, 5), (0, 2)]],
        3: [[(_q(eph.cic, 2 ** -29), 16), (omg0 >> 24, 8)], [(omg0, 24)], [(_q(eph.cis, 2 ** -29), 16), (i0 >> 24, 8)],
            [(i0, 24)], [(_q(eph.crc, 2 ** -5), 16), (omg >> 24, 8)], [(omg, 24)],
            [(_q(eph.OMGd, 2 ** -43 * SC), 24)], [(eph.iode, 8), (_q(eph.idot, 2 ** -43 * SC), 14), (0, 2)]]}
    frames = []
    for sid, words in data.items():
        head = [[(0x8B, 8), (0, 16)], [(int(tow // 6) % 100800, 17), (0, 2), (sid, 3), (0, 2)]]
        frames.append([_bits(w) << 6 for w in head + words])      # 24 data bits + 6 (zero) parity bits
    return frames


def _tow_of(t):
    """GPS time of week [s] of a cssrlib gtime."""
    return (t.time + t.sec - 315964800) % 604800


def inav_words(eph):
    """Galileo I/NAV word types 1–5 of a record, each as eight u-blox words (even page, odd page)."""
    iod, week_gst = int(eph.iode), int(eph.week) - 1024
    words = [
        [(1, 6), (iod, 10), (_q(eph.toes, 60), 14), (_q(eph.M0, 2 ** -31 * SC), 32), (_q(eph.e, 2 ** -33), 32),
         (_q(math.sqrt(eph.A), 2 ** -19), 32), (0, 2)],
        [(2, 6), (iod, 10), (_q(eph.OMG0, 2 ** -31 * SC), 32), (_q(eph.i0, 2 ** -31 * SC), 32),
         (_q(eph.omg, 2 ** -31 * SC), 32), (_q(eph.idot, 2 ** -43 * SC), 14), (0, 2)],
        [(3, 6), (iod, 10), (_q(eph.OMGd, 2 ** -43 * SC), 24), (_q(eph.deln, 2 ** -43 * SC), 16),
         (_q(eph.cuc, 2 ** -29), 16), (_q(eph.cus, 2 ** -29), 16), (_q(eph.crc, 2 ** -5), 16),
         (_q(eph.crs, 2 ** -5), 16), (0, 8)],
        [(4, 6), (iod, 10), (int(sat2id(eph.sat)[1:]), 6), (_q(eph.cic, 2 ** -29), 16), (_q(eph.cis, 2 ** -29), 16),
         (_q(_tow_of(eph.toc), 60), 14), (_q(eph.af0, 2 ** -34), 31), (_q(eph.af1, 2 ** -46), 21),
         (_q(eph.af2, 2 ** -59), 6), (0, 2)],
        [(5, 6), (0, 11), (0, 11), (0, 14), (0, 5), (_q(eph.tgd, 2 ** -32), 10), (0, 10), (0, 6),
         (week_gst % 4096, 12), (int(_tow_of(eph.toe)), 20), (0, 23)]]
    out = []
    for w in words:
        data = _bits(w)                                          # 128 bits
        even = _bits([(0, 1), (0, 1), (data >> 16, 112), (0, 6)])
        odd = _bits([(1, 1), (0, 1), (data & 0xFFFF, 16), (0, 102)])
        value = _bits([(even, 120), (0, 8), (odd, 120), (0, 8)])
        out.append([(value >> (32 * (7 - k))) & 0xFFFFFFFF for k in range(8)])
    return out


def nav_frames(nav, systems="GEJ", tow=0.0):
    """[(gnss_id, sv_id, sig_id, words)] of every healthy LNAV / I/NAV record of a cssrlib Nav."""
    out = []
    for eph in nav.eph:
        sid = sat2id(eph.sat)
        if sid[0] not in systems or eph.svh != 0:
            continue
        if sid[0] == "E":
            if eph.code & 1:                                     # I/NAV E1-B
                out += [(UBX_GNSS["E"], int(sid[1:]), GAL_E1B, w) for w in inav_words(eph)]
        else:
            out += [(UBX_GNSS[sid[0]], int(sid[1:]), 0, w) for w in lnav_subframes(eph, tow)]
    return out
