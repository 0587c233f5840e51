"""Hypothesis fuzzing of every driver parser: random bytes, mutated real input, corrupt UBX lengths and
impossible values never raise, and nothing non-finite or physically implausible comes out."""
import dataclasses
import math

import numpy as np
from hypothesis import HealthCheck, given, settings, strategies as st

from pyubx2 import UBXMessage

from agnav_drivers import gnss_types as g
from agnav_drivers.adc import AdcConverter, AdcDecoder, encode_frame
from agnav_drivers.nmea import NmeaParser
from agnav_drivers.ubx import UbxParser
from drivers_helpers import real_sentences, with_checksum

FUZZ = settings(max_examples=150, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])
REAL = [b for name, kind in [("ublox-zed-f9p-nmea.log", k) for k in ("GGA", "RMC", "VTG", "GSA")]
        + [("skytraq-dgps.log", "GST"), ("hemi.log", "ZDA"), ("rst39.log", "HDT")]
        for b in real_sentences(name, kind)[:3]]
UBX_CAPTURE = open("/work/shared/data/real/ubx/pygpsdata-SF-calibration.log", "rb").read()
UBX_REAL = UBX_CAPTURE[:3000]
LIMITS = g.Limits()
ADC_REAL = b"".join(encode_frame(i, 1000 * i, [30000 + i] * 8) for i in range(10))


def finite_everywhere(events):
    for e in events:
        for v in dataclasses.astuple(e):
            for x in np.ravel(np.asarray(v, dtype=object)):
                if isinstance(x, float):
                    assert math.isfinite(x), e
    within_limits(events)


def within_limits(events):
    """Every published fix and velocity is physically possible and never claims a zero variance."""
    for e in events:
        if isinstance(e, g.GnssFix):
            assert e.fix_type in g.POSITION_FIX_TYPES
            assert abs(e.latitude) <= 90 and abs(e.longitude) <= 180, e
            assert LIMITS.min_altitude <= e.altitude <= LIMITS.max_altitude, e
            if e.covariance_type != g.COV_UNKNOWN:
                assert min(e.covariance[0], e.covariance[4], e.covariance[8]) >= LIMITS.min_position_std ** 2 * 0.999
        elif isinstance(e, g.GnssVelocity):
            assert math.hypot(e.east, e.north, e.up) <= LIMITS.max_speed, e
            assert min(e.covariance[0], e.covariance[4], e.covariance[8]) >= LIMITS.min_velocity_std ** 2 * 0.999


def mutate(data: bytes, ops) -> bytes:
    buf = bytearray(data)
    for pos, byte, kind in ops:
        if not buf:
            break
        i = pos % len(buf)
        if kind == 0:
            buf[i] = byte
        elif kind == 1:
            buf.insert(i, byte)
        else:
            del buf[i]
    return bytes(buf)


OPS = st.lists(st.tuples(st.integers(0, 10 ** 6), st.integers(0, 255), st.integers(0, 2)), max_size=6)


@FUZZ
@given(st.binary(max_size=600), st.integers(1, 64))
def test_nmea_random_bytes(data, chunk):
    p = NmeaParser()
    for i in range(0, len(data), chunk):
        finite_everywhere(p.feed(data[i:i + chunk], 1.0))


@FUZZ
@given(st.integers(0, len(REAL) - 1), OPS, st.booleans(),
       st.sampled_from(["", "nan", "inf", "-1", "999999", "1e308", "00", ",", "*"]))
def test_nmea_mutated_real_sentences(index, ops, fix_checksum, field_value):
    body = REAL[index]
    fields = body.split(",")
    fields[ops[0][0] % len(fields) if ops else 1] = field_value  # a hostile field value ...
    body = ",".join(fields)
    mutated = mutate(body.encode(), ops).decode("latin-1").replace("*", "").replace("$", "")
    # ... with a correct checksum (reaches the field parsers) or with the original bytes' checksum
    line = with_checksum(mutated) if fix_checksum else b"$" + mutated.encode("latin-1") + b"*00\r\n"
    p = NmeaParser()
    finite_everywhere(p.feed(with_checksum(REAL[0]) + line + with_checksum(REAL[1]), 2.0))


@FUZZ
@given(st.binary(max_size=600))
def test_ubx_random_bytes(data):
    finite_everywhere(UbxParser().feed(b"\xb5\x62" + data, 1.0))


@FUZZ
@given(OPS, st.integers(1, 200))
def test_ubx_mutated_real_capture(ops, chunk):
    data = mutate(UBX_REAL, ops)
    p = UbxParser()
    for i in range(0, len(data), chunk):
        finite_everywhere(p.feed(data[i:i + chunk], 1.0))


UBX_PACED = UBX_CAPTURE[:12000]
UBX_RATE = len(UBX_CAPTURE) / 526.0  # bytes/s of the capture's 526 one-second epochs


def paced(data):
    parser, events = UbxParser(), []
    for i in range(0, len(data), 64):
        events += parser.feed(data[i:i + 64], 1000.0 + (i + 64) / UBX_RATE)
    return parser, [e for e in events if isinstance(e, g.GnssFix)]


CLEAN_FIXES = paced(UBX_PACED)[1]
FRAME_STARTS = [i for i in range(len(UBX_PACED) - 6) if UBX_PACED[i:i + 2] == b"\xb5\x62"]


@FUZZ
@given(st.integers(0, len(FRAME_STARTS) - 1), st.integers(0, 0xFFFF))
def test_ubx_corrupt_length_costs_one_frame_and_no_time(index, length):
    """Any length in any header of a real capture: at most the fix of that frame is lost, the others arrive
    with the stamps of a clean stream (no stall, no burst of stale fixes)."""
    start = FRAME_STARTS[index]
    data = UBX_PACED[:start + 4] + length.to_bytes(2, "little") + UBX_PACED[start + 6:]
    parser, fixes = paced(data)
    finite_everywhere(fixes)
    clean = {f.receiver_time: f.host_time for f in CLEAN_FIXES}
    assert len(fixes) >= len(CLEAN_FIXES) - 1
    assert all(abs(f.host_time - clean[f.receiver_time]) < 0.2 for f in fixes)


I4 = st.integers(-2 ** 31, 2 ** 31 - 1)
U4 = st.integers(0, 2 ** 32 - 1)


@FUZZ
@given(st.floats(-214.0, 214.0), st.floats(-214.0, 214.0), I4, U4, U4, I4, I4, I4, U4, st.integers(0, 5),
       st.integers(0, 2))
def test_ubx_impossible_values_never_published(lat, lon, height, h_acc, v_acc, vel_n, vel_e, vel_d, s_acc,
                                               fix_type, carr):
    msg = UBXMessage("NAV", "NAV-PVT", 0, iTOW=1000, year=2024, month=5, day=1, hour=12, second=1, validDate=1,
                     validTime=1, fullyResolved=1, fixType=fix_type, gnssFixOk=1, carrSoln=carr, numSV=12,
                     lat=lat, lon=lon, height=height, hAcc=h_acc, vAcc=v_acc, velN=vel_n, velE=vel_e, velD=vel_d,
                     sAcc=s_acc)
    parser = UbxParser()
    finite_everywhere(parser.feed(msg.serialize(), 1.0))
    assert parser.counters.accepted + parser.counters.rejected == 1


NUMBER = st.one_of(st.floats(-1e6, 1e6).map(lambda v: f"{v:.3f}"), st.floats(-300, 300).map(lambda v: f"{v:.2f}"),
                   st.sampled_from(["0", "0.0", "-0", "", "nan", "inf", "1e308", "99999999", "25000.0", "-1500.0",
                                    "250.0"]))


@FUZZ
@given(NUMBER, NUMBER, NUMBER, NUMBER, NUMBER)
def test_nmea_impossible_values_never_published(altitude, separation, hdop, speed, course):
    gga = real_sentences("ublox-zed-f9p-nmea.log", "GGA")[0].split(",")
    gga[8], gga[9], gga[11] = hdop, altitude, separation
    rmc = real_sentences("ublox-zed-f9p-nmea.log", "RMC")[1].split(",")
    rmc[7], rmc[8] = speed, course
    vtg = f"GPVTG,{course},T,,M,{speed},N,,K,A"
    p = NmeaParser()
    finite_everywhere(p.feed(with_checksum(",".join(gga)) + with_checksum(",".join(rmc)) + with_checksum(vtg), 2.0))


@FUZZ
@given(st.binary(max_size=400), OPS, st.sampled_from(["binary", "csv"]))
def test_adc_random_and_mutated(data, ops, mode):
    dec, conv = AdcDecoder(mode), AdcConverter()
    src = ADC_REAL if mode == "binary" else b"1,2,3,4,5,6,7,8,9,10\r\n" * 5
    for frame in dec.feed(data) + dec.feed(mutate(src, ops)):
        reading = conv.convert(frame)
        if reading is not None:
            finite_everywhere([reading])
