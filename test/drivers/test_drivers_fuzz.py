"""Hypothesis fuzzing of every driver parser: random bytes and mutated real input never raise, and
nothing non-finite comes out."""
import dataclasses
import math

import numpy as np
from hypothesis import HealthCheck, given, settings, strategies as st

from agnav_drivers.adc import AdcConverter, AdcDecoder, encode_frame
from agnav_drivers.nmea import NmeaParser
from agnav_drivers.ubx import UbxParser
from drivers_helpers import real_sentences, with_checksum

FUZZ = settings(max_examples=150, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])
REAL = [b for name, kind in [("ublox-zed-f9p-nmea.log", k) for k in ("GGA", "RMC", "VTG", "GSA")]
        + [("skytraq-dgps.log", "GST"), ("hemi.log", "ZDA"), ("rst39.log", "HDT")]
        for b in real_sentences(name, kind)[:3]]
UBX_REAL = open("/work/shared/data/real/ubx/pygpsdata-SF-calibration.log", "rb").read()[:3000]
ADC_REAL = b"".join(encode_frame(i, 1000 * i, [30000 + i] * 8) for i in range(10))


def finite_everywhere(events):
    for e in events:
        for v in dataclasses.astuple(e):
            for x in np.ravel(np.asarray(v, dtype=object)):
                if isinstance(x, float):
                    assert math.isfinite(x), e


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


@FUZZ
@given(st.binary(max_size=400), OPS, st.sampled_from(["binary", "csv"]))
def test_adc_random_and_mutated(data, ops, mode):
    dec, conv = AdcDecoder(mode), AdcConverter()
    src = ADC_REAL if mode == "binary" else b"1,2,3,4,5,6,7,8,9,10\r\n" * 5
    for frame in dec.feed(data) + dec.feed(mutate(src, ops)):
        reading = conv.convert(frame)
        if reading is not None:
            finite_everywhere([reading])
