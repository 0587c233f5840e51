"""RTCM3 base observations (agnav_drivers.rtcm_raw): a GPS MSM4 frame and a 1005 frame packed here bit by bit
from known values decode to those values; the real u-blox ZED-F9T RTCM3 log (gpsd test data, MSM7 + 1005)
gives whole epochs with code, phase and Doppler that agree with each other."""
import io
from pathlib import Path

import numpy as np
import pytest
from pyrtcm import RTCMReader
from pyrtcm.rtcmhelpers import calc_crc24q

from agnav_drivers.rtcm_raw import CLIGHT, RANGE_MS, RtcmBase, lock_time_s

REAL = Path("/work/shared/data/real/gpsd_nmea/ublox-zed-f9t-rtcm3.log")
L1 = CLIGHT / 1575.42e6


def _frame(fields):
    """RTCM3 frame of (value, bits) fields (two's complement for negatives)."""
    bits = "".join(format(v & ((1 << n) - 1), f"0{n}b") for v, n in fields)
    bits += "0" * (-len(bits) % 8)
    payload = int(bits, 2).to_bytes(len(bits) // 8, "big")
    head = bytes([0xD3, len(payload) >> 8, len(payload) & 0xFF]) + payload
    return head + calc_crc24q(head).to_bytes(3, "big")


def _read(data):
    return [p for _, p in RTCMReader(io.BytesIO(data), quitonerror=0) if p is not None]


def test_generated_msm4_and_1005():
    tow_ms, prns = 345600123, (5, 13)
    ranges_ms = (70.123456, 78.654321)                       # pseudorange, ms of light travel
    phase_off_ms = (0.0001, -0.0002)                          # phase range − pseudorange
    sat_mask = sum(1 << (64 - p) for p in prns)
    fields = [(1074, 12), (42, 12), (tow_ms, 30), (0, 1), (0, 3), (0, 7), (0, 2), (0, 2), (0, 1), (0, 3),
              (sat_mask, 64), (1 << (32 - 2), 32), (0b11, 2)]            # signal 2 = L1 C/A ('1C')
    fields += [(int(r), 8) for r in ranges_ms]
    fields += [(round((r % 1) * 1024), 10) for r in ranges_ms]
    rough = [int(r) + round((r % 1) * 1024) / 1024 for r in ranges_ms]
    fields += [(round((r - rr) * 2 ** 24), 15) for r, rr in zip(ranges_ms, rough)]
    fields += [(round((r + o - rr) * 2 ** 29), 22) for r, o, rr in zip(ranges_ms, phase_off_ms, rough)]
    fields += [(7, 4), (7, 4), (0, 1), (0, 1), (45, 6), (38, 6)]     # lock 2 s, full cycles, C/N0
    ecef = (-3957199.8, 3310199.9, 3737711.7)
    frame_1005 = _frame([(1005, 12), (42, 12), (0, 6), (1, 1), (0, 1), (0, 1), (0, 1),
                         (round(ecef[0] * 1e4), 38), (0, 1), (0, 1), (round(ecef[1] * 1e4), 38), (0, 2),
                         (round(ecef[2] * 1e4), 38)])
    base, events = RtcmBase(), []
    for msg in _read(frame_1005 + _frame(fields)):
        events += base.feed(msg, week=2380)
    assert np.allclose(base.position.ecef, ecef, atol=1e-4) and base.position.station == 42
    obs = events[-1]
    assert obs.receiver_tow == pytest.approx(tow_ms * 1e-3) and obs.week == 2380
    assert [(o.gnss_id, o.sv_id, o.sig_id) for o in obs.observations] == [(0, 5, 0), (0, 13, 0)]
    for o, r, off in zip(obs.observations, ranges_ms, phase_off_ms):
        assert o.pseudorange == pytest.approx(r * RANGE_MS, abs=0.02)            # 2^-24 ms = 1.8 cm steps
        assert o.carrier_phase * L1 == pytest.approx((r + off) * RANGE_MS, abs=0.001)
        assert o.lock_time == pytest.approx(2.048) and o.half_cycle_resolved and o.doppler == 0.0
    assert [o.cno for o in obs.observations] == [45, 38]


def test_lock_time_indicators():
    assert lock_time_s({"DF402": 0}) == 0.0 and lock_time_s({"DF402": 1}) == 0.032
    assert lock_time_s({"DF407": 63}) == 0.063 and lock_time_s({"DF407": 64}) == 0.064
    assert lock_time_s({"DF407": 96}) == 0.128 and lock_time_s({"DF407": 704}) == pytest.approx(67108.864)


def test_real_zed_f9t_log():
    data = REAL.read_bytes()
    base, epochs = RtcmBase(), []
    for msg in _read(data[data.find(b"\xd3"):]):
        epochs += [e for e in base.feed(msg, week=2075) if hasattr(e, "observations")]
    assert base.position is not None and 6.3e6 < np.linalg.norm(base.position.ecef) < 6.4e6
    assert len(epochs) >= 20
    tows = [e.receiver_tow for e in epochs]
    assert np.allclose(np.diff(tows), 1.0)
    systems = {o.gnss_id for e in epochs for o in e.observations}
    assert {0, 2, 3} <= systems                               # GPS, Galileo, BeiDou (GLONASS skipped)
    first = {(o.gnss_id, o.sv_id, o.sig_id): o for o in epochs[0].observations}
    assert len(first) >= 15
    # the pseudorange change over 1 s agrees with the Doppler range rate (receiver clock steered)
    rate_err = []
    for o in epochs[1].observations:
        p = first.get((o.gnss_id, o.sv_id, o.sig_id))
        if p is not None and o.pseudorange_valid and p.pseudorange_valid and o.gnss_id == 0 and o.sig_id == 0:
            lam = L1
            rate_err.append((o.pseudorange - p.pseudorange) + lam * (o.doppler + p.doppler) / 2)
            assert 2.0e7 < o.pseudorange < 2.6e7
            assert abs(o.carrier_phase * lam - o.pseudorange) < 1500.0
    assert len(rate_err) >= 5 and np.median(np.abs(np.array(rate_err) - np.median(rate_err))) < 1.0
