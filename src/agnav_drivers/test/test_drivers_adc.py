"""ADC core: frames through a real pty into ByteLink, exact conversions, V_static, unplug/replug."""
import math
import time

import numpy as np
import pytest

from agnav_drivers.adc import (AdcConverter, AdcDecoder, AdcFrame, AdcSettings, encode_frame)
from agnav_drivers.pty_device import PtyDevice
from agnav_drivers.serial_link import ByteLink, LinkSettings

S = AdcSettings()
LSB = S.vref / 2 ** S.bits


def code(volts):
    return int(round(volts / LSB))


def collect(link, decoder, n, device=None, frames_to_send=(), deadline=10.0):
    """Read frames until n decoded; optionally keep a device streaming (a live MCU)."""
    out, end, pending = [], time.monotonic() + deadline, list(frames_to_send)
    while len(out) < n and time.monotonic() < end:
        if device is not None and pending:
            device.write(b"".join(pending[:50]))
            del pending[:50]
        out += decoder.feed(link.read(0.05))
    return out


@pytest.fixture
def device(tmp_path):
    dev = PtyDevice(str(tmp_path / "adc0"))
    yield dev
    dev.close()


def test_conversions_exact_through_pty(device):
    link = ByteLink(LinkSettings(port=device.path, baud=115200))
    link.read(0.01)
    conv = AdcConverter(AdcSettings(static_samples=3))
    v_static = [2.50, 2.40, 2.60]
    still = [code(v) for v in v_static] + [code(2.5)] * 2 + [code(2.5)] * 3
    moving = [code(2.9), code(2.40), code(2.2), code(2.7), code(2.3), code(3.5), code(2.5), code(1.5)]
    frames = [encode_frame(i, 1000 * i, still) for i in range(3)] + [encode_frame(3, 3000, moving)]
    device.write(b"".join(frames))
    decoded = collect(link, AdcDecoder(), 4)
    readings = [conv.convert(f) for f in decoded]
    assert [r.gyro is None for r in readings] == [True, True, False, False]
    volts = np.array(moving) * LSB
    vs = np.array([code(v) for v in v_static]) * LSB
    r = readings[3]
    np.testing.assert_allclose(r.gyro, np.radians(40.0 * (volts[:3] - vs)), rtol=0, atol=1e-12)   # eq 3.8
    assert r.roll == pytest.approx(math.radians((volts[3] - 2.5) / 0.1), abs=1e-12)
    assert r.pitch == pytest.approx(-math.radians((volts[4] - 2.5) / 0.1), abs=1e-12)      # nose up -> REP-103
    np.testing.assert_allclose(r.mag, (volts[5:] - 2.5) * 250.0 * 1e-7, rtol=0, atol=1e-15)
    assert readings[2].gyro == pytest.approx([0, 0, 0], abs=1e-12)
    link.close()


def test_v_static_converges_and_rejects_motion():
    rng = np.random.default_rng(7)
    conv = AdcConverter(AdcSettings(channels=["gyro_x", "gyro_y", "gyro_z"]))
    true_static = np.array([2.604, 2.512, 2.398])
    noise = 0.010  # V rms (ENV-05F-03 data sheet: < 10 mV)

    def frame(i, v):
        return AdcFrame(i % 256, i, tuple(int(round(x / LSB)) for x in v))

    # vehicle turning at first: the window is rejected
    for i in range(1000):
        conv.convert(frame(i, true_static + [0.5 * math.sin(i / 50), 0, 0] + rng.normal(0, noise, 3)))
    assert conv.v_static is None and conv.calibrator.rejected_windows == 1
    for i in range(1000):
        conv.convert(frame(i, true_static + rng.normal(0, noise, 3)))
    assert conv.v_static is not None
    np.testing.assert_allclose(conv.v_static, true_static, atol=4 * noise / math.sqrt(1000))
    # recalibration on request follows a temperature drift of V_static
    drifted = true_static + 0.008
    assert conv.request_calibration()
    for i in range(1000):
        conv.convert(frame(i, drifted + rng.normal(0, noise, 3)))
    np.testing.assert_allclose(conv.v_static, drifted, atol=4 * noise / math.sqrt(1000))


def test_unplug_and_replug_recovers(device):
    link = ByteLink(LinkSettings(port=device.path, backoff_initial=0.05, backoff_max=0.2))
    decoder = AdcDecoder()
    link.read(0.01)
    codes = [code(2.5)] * 8
    before = collect(link, decoder, 20, device, [encode_frame(i, i, codes) for i in range(20)])
    assert len(before) == 20
    device.write(encode_frame(20, 20, codes)[:9])  # cut mid-frame by the unplug
    device.unplug()
    for _ in range(5):
        link.read(0.05)
    device.plug()
    after = collect(link, decoder, 10, device, [encode_frame(100 + i, i, codes) for i in range(400)])
    assert len(after) >= 10 and after[0].codes == tuple(codes)
    assert link.opens == 2 and decoder.counters.crc_failures <= 1
    link.close()


def test_noise_crc_and_length_errors_are_counted():
    codes = [code(2.5)] * 8
    good = encode_frame(1, 10, codes)
    bad_crc = bytearray(encode_frame(2, 20, codes))
    bad_crc[10] ^= 0xFF
    stream = b"\x00\xff\xa5noise" + good + bytes(bad_crc) + b"\xa5\x5a\x02" + encode_frame(4, 40, codes)
    dec = AdcDecoder()
    frames = dec.feed(stream[:7]) + dec.feed(stream[7:])
    assert [f.seq for f in frames] == [1, 4]
    c = dec.counters
    assert c.crc_failures == 1 and c.parse_errors == 1 and c.dropped_frames == 2 and c.noise_bytes > 0


def test_csv_mode_matches_binary():
    codes = [code(2.5 + 0.01 * i) for i in range(8)]
    dec = AdcDecoder("csv")
    frames = dec.feed(f"7,1234,{','.join(map(str, codes))}\r\nnot,a,frame\r\n".encode())
    assert frames == [AdcFrame(7, 1234, tuple(codes))] and dec.counters.parse_errors == 1
    assert AdcDecoder().feed(encode_frame(7, 1234, codes)) == frames


def test_wrong_channel_count_or_out_of_range_code_is_rejected():
    conv = AdcConverter()
    assert conv.convert(AdcFrame(0, 0, (1, 2, 3))) is None
    assert conv.convert(AdcFrame(0, 0, (2 ** 16,) * 8)) is None
    assert conv.rejected == 2
