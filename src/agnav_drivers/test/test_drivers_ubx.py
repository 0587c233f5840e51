"""UBX core on real u-blox captures: NAV-PVAT/ATT at 1 Hz, RXM-RAWX, RTK mapping, bad frames and values."""
import glob

import numpy as np
import pytest
from pyubx2 import UBXMessage, calc_checksum

from agnav_drivers import gnss_types as g
from agnav_drivers.ubx import GnssObservations, NavDataFrame, UbxParser

UBX = "/work/shared/data/real/ubx/"
GPSD = "/work/shared/data/real/gpsd_nmea/"


def run(path, chunk=97):
    data = open(path, "rb").read()
    parser = UbxParser()
    events = []
    for i in range(0, len(data), chunk):
        events += parser.feed(data[i:i + chunk], float(i))
    return parser, events


def of(events, kind):
    return [e for e in events if isinstance(e, kind)]


def test_sf_calibration_fix_velocity_attitude_at_1hz():
    parser, events = run(UBX + "pygpsdata-SF-calibration.log")
    fixes, vels, atts = of(events, g.GnssFix), of(events, g.GnssVelocity), of(events, g.GnssAttitude)
    assert parser.counters.checksum_failures == 0 and parser.counters.parse_errors == 0
    assert len(fixes) > 500 and len(vels) == len(fixes) and len(atts) == len(fixes)
    dt = np.diff([f.receiver_time for f in fixes])
    assert np.median(dt) == pytest.approx(1.0, abs=1e-3) and dt.min() > 0
    lat = np.array([f.latitude for f in fixes])
    lon = np.array([f.longitude for f in fixes])
    assert np.ptp(lat) < 0.1 and np.ptp(lon) < 0.1           # one car drive, Guildford area
    speed = np.hypot([v.east for v in vels], [v.north for v in vels])
    assert speed.max() < 20 and speed.max() > 5               # README: 0-15 m/s
    roll = np.array([a.roll for a in atts])
    pitch = np.array([a.pitch for a in atts])
    assert np.abs(roll).max() < 5 and np.abs(pitch).max() < 5  # README: roll -3..3.7, pitch -2.2..4 deg
    assert all(0 <= a.heading < 360 and a.heading_std > 0 for a in atts)
    assert all(f.covariance_type == g.COV_DIAGONAL_KNOWN and f.covariance[0] > 0 for f in fixes)
    # heading of motion agrees with the velocity direction while moving
    moving = speed > 3
    course = np.degrees(np.arctan2([v.east for v in vels], [v.north for v in vels])) % 360
    diff = (course - np.array([a.heading for a in atts]) + 180) % 360 - 180
    assert np.median(np.abs(diff[moving])) < 5


def test_rawx_observations_are_physical():
    parser, events = run(GPSD + "ublox-neo-m8t.log")
    epochs = of(events, GnssObservations)
    assert len(epochs) > 30
    for epoch in epochs:
        assert 0 <= epoch.receiver_tow < 604800 and epoch.week > 2000 and epoch.observations
        for o in epoch.observations:
            if o.pseudorange_valid and o.gnss_id == 0:
                assert 1.5e7 < o.pseudorange < 3.0e7  # ~20,200 km range + receiver clock bias
            assert abs(o.doppler) < 10000 and 0 <= o.cno < 70 and o.lock_time >= 0


def pvt(**kw):
    fields = dict(iTOW=1000, year=2024, month=5, day=1, hour=12, min=0, second=1, validDate=1, validTime=1,
                  fullyResolved=1, fixType=3, gnssFixOk=1, diffSoln=1, numSV=20, lat=52.0, lon=13.0,
                  height=100000, hMSL=60000, hAcc=20, vAcc=30, velN=1000, velE=2000, velD=-500, sAcc=50)
    fields.update(kw)
    return UBXMessage("NAV", "NAV-PVT", 0, **fields).serialize()


@pytest.mark.parametrize("carr,fix_type", [(0, g.FIX_DGPS), (1, g.FIX_RTK_FLOAT), (2, g.FIX_RTK_FIXED)])
def test_carrier_solution_maps_to_rtk_float_and_fixed(carr, fix_type):
    events = UbxParser().feed(pvt(carrSoln=carr), 1.0)
    (status,), (fix,), (vel,) = of(events, g.GnssFixStatus), of(events, g.GnssFix), of(events, g.GnssVelocity)
    assert status.fix_type == fix.fix_type == fix_type
    assert fix.altitude == pytest.approx(100.0) and fix.covariance[0] == pytest.approx(0.02 ** 2)
    assert (vel.east, vel.north, vel.up) == pytest.approx((2.0, 1.0, 0.5))


def test_no_fix_gives_status_only_and_bad_frames_are_counted():
    parser = UbxParser()
    events = parser.feed(pvt(fixType=0, gnssFixOk=0), 1.0)
    assert [type(e) for e in events if not isinstance(e, g.ReceiverTime)] == [g.GnssFixStatus]
    bad = bytearray(pvt())
    bad[20] ^= 0x55
    assert parser.feed(b"\x00\xb5junk" + bytes(bad) + pvt(iTOW=2000, second=2), 2.0)
    assert parser.counters.checksum_failures == 1 and parser.counters.noise_bytes > 0
    assert not of(parser.feed(pvt(lat=100.0, iTOW=3000, second=3), 3.0), g.GnssFix)
    assert parser.counters.rejected == 1


def test_sfrbx_decoded():
    msg = UBXMessage("RXM", "RXM-SFRBX", 0, gnssId=0, svId=5, numWords=3, dwrd_01=1, dwrd_02=2, dwrd_03=3)
    (frame,) = UbxParser().feed(msg.serialize(), 1.0)
    assert isinstance(frame, NavDataFrame) and frame.sv_id == 5 and frame.words == [1, 2, 3]


# ---- corrupt headers: resynchronise at once, every frame keeps its own arrival time ---------------------------
SF = open(UBX + "pygpsdata-SF-calibration.log", "rb").read()
SF_RATE = len(SF) / 526.0  # bytes/s: the capture's 526 one-second epochs, as over the wire


def feed_paced(data, chunk=64):
    """Feeds `data` in chunks with the host time at which each chunk would arrive at SF_RATE."""
    parser, events = UbxParser(), []
    for i in range(0, len(data), chunk):
        events += parser.feed(data[i:i + chunk], 1000.0 + (i + chunk) / SF_RATE)
    return parser, events


@pytest.mark.parametrize("header", [
    b"\xb5\x62\x01\x07\x40\x1f",   # NAV-PVT claiming 8000 bytes (NAV-PVT is 92)
    b"\xb5\x62\x01\x35\xb8\x0b",   # NAV-SAT (no length rule) claiming 3000 bytes: a valid frame inside gives it away
    b"\xb5\x62\x77\x01\x10\x00",   # unknown class
    b"\xb5\x62\x02\x15\x10\x04\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x05",  # RXM-RAWX 1040 B, 5 meas
    b"\xb5\x62\x01\x35\xb8\x0b\xb5\x62\x01\x43\xd0\x07",  # NAV-SAT 3000 B holding a NAV-SIG 2000 B header
], ids=["nav_pvt_8000", "nav_sat_3000", "unknown_class", "rawx_count_mismatch", "nested"])
def test_corrupt_header_does_not_stall_or_restamp_the_stream(header):
    cut = SF.index(b"\xb5\x62", 20000)  # a frame boundary ~40 s into the drive
    data = SF[:cut] + header + SF[cut:]
    clean_parser, clean = feed_paced(SF[:cut + 20000])
    parser, events = feed_paced(data[:cut + len(header) + 20000])
    fixes, clean_fixes = of(events, g.GnssFix), of(clean, g.GnssFix)
    assert len(fixes) == len(clean_fixes) > 60
    late = max(f.host_time - c.host_time for f, c in zip(fixes, clean_fixes))
    assert late < 0.5  # s: each fix is stamped when its own bytes arrived (was: 16 s late, all one stamp)
    assert len({f.host_time for f in fixes}) == len(fixes)
    assert parser.counters.corrupt_frames >= 1 and clean_parser.counters.corrupt_frames == 0


def test_real_ubx_captures_pass_the_header_and_value_checks_untouched():
    paths = sorted(glob.glob(UBX + "*.log") + glob.glob(GPSD + "ublox*.log"))
    frames = 0
    for path in paths:
        parser, _ = run(path)
        c = parser.counters
        frames += c.frames
        assert c.corrupt_frames == c.checksum_failures == c.implausible == c.floored_accuracy == 0, (path, c)
    assert len(paths) > 15 and frames > 5000


# ---- physical plausibility --------------------------------------------------------------------------------------
@pytest.mark.parametrize("field,value", [("velN", 2_000_000_000), ("height", 30_000_000), ("lat", 91.0),
                                         ("velD", -150_000)])
def test_implausible_pvt_is_rejected_and_counted(field, value):
    parser = UbxParser()
    events = parser.feed(pvt(**{field: value}), 1.0)
    assert not of(events, g.GnssFix) and not of(events, g.GnssVelocity)
    assert parser.counters.implausible == 1 and parser.counters.rejected == 1
    assert of(parser.feed(pvt(iTOW=2000, second=2), 2.0), g.GnssFix)  # the stream goes on


def test_zero_accuracy_is_floored_never_a_known_zero():
    parser = UbxParser()
    events = parser.feed(pvt(hAcc=0, vAcc=0, sAcc=0), 1.0)
    (fix,), (vel,) = of(events, g.GnssFix), of(events, g.GnssVelocity)
    floor = g.Limits()
    assert fix.covariance_type == g.COV_DIAGONAL_KNOWN
    assert [fix.covariance[i] for i in (0, 4, 8)] == pytest.approx([floor.min_position_std ** 2] * 3)
    assert [vel.covariance[i] for i in (0, 4, 8)] == pytest.approx([floor.min_velocity_std ** 2] * 3)
    assert parser.counters.floored_accuracy == 1


def test_protocol_14_nav_pvt_of_84_bytes_is_not_a_corrupt_header():
    """u-blox 7 (protocol 14) sends NAV-PVT with an 84-byte payload: a legitimate length."""
    payload = pvt()[6:6 + 84]
    head = b"\x01\x07" + (84).to_bytes(2, "little")
    short = b"\xb5\x62" + head + payload + calc_checksum(head + payload)
    parser = UbxParser()
    (fix,) = of(parser.feed(short, 1.0), g.GnssFix)
    assert fix.latitude == pytest.approx(52.0) and parser.counters.corrupt_frames == 0
