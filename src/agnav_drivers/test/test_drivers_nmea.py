"""NMEA core: the whole gpsd corpus, fix/covariance/velocity/status rules, bad input."""
import math
import os
import re

import pytest

from agnav_drivers import gnss_types as g
from agnav_drivers.nmea import KNOT, NmeaParser, NmeaSettings
from drivers_helpers import CORPUS_FILES, real_sentences, with_checksum


def run(parser, data: bytes, chunk=37, t0=100.0):
    events = []
    for i in range(0, len(data), chunk):
        events += parser.feed(data[i:i + chunk], t0 + i * 1e-4)
    return events


def of(events, kind):
    return [e for e in events if isinstance(e, kind)]


def has_usable_gga(path) -> bool:
    """Independent check: a checksummed GGA with quality 1-5 and numeric time, lat/lon, altitude."""
    number = re.compile(r"^-?\d+(\.\d+)?$")
    for body in real_sentences(os.path.basename(path), "GGA"):
        f = body.split(",")
        if len(f) > 9 and f[6] and f[6] in "12345" and all(number.match(f[i]) for i in (1, 2, 4, 9)):
            return True
    return False


@pytest.mark.parametrize("path", CORPUS_FILES, ids=lambda p: p.rsplit("/", 1)[-1])
def test_corpus_file_never_raises_and_fixes_are_sane(path):
    data = open(path, "rb").read()
    parser = NmeaParser()
    events = run(parser, data)
    c = parser.counters
    assert c.lines > 0
    assert c.accepted + c.ignored + c.checksum_failures + c.parse_errors + c.rejected + c.noise_lines >= c.lines
    fixes = of(events, g.GnssFix)
    if has_usable_gga(path):
        assert fixes, "a capture with valid GGA must give fixes"
    for fix in fixes:
        assert abs(fix.latitude) <= 90 and abs(fix.longitude) <= 180 and math.isfinite(fix.altitude)
        assert fix.fix_type in g.POSITION_FIX_TYPES
        assert all(math.isfinite(v) for v in fix.covariance)
        assert min(fix.covariance[0], fix.covariance[4], fix.covariance[8]) >= 0
    for vel in of(events, g.GnssVelocity):
        assert all(math.isfinite(v) for v in (vel.east, vel.north, vel.up))


def test_gga_altitude_is_ellipsoidal_and_covariance_from_hdop_table():
    body = real_sentences("ublox-zed-f9p-nmea.log", "GGA")[0]
    f = body.split(",")
    parser = NmeaParser()
    status, fix = parser.feed(with_checksum(body), 1.0)
    assert fix.altitude == pytest.approx(float(f[9]) + float(f[11]))
    assert fix.latitude == pytest.approx(-(float(f[2][:2]) + float(f[2][2:]) / 60))
    assert fix.longitude == pytest.approx(float(f[4][:3]) + float(f[4][3:]) / 60)
    sigma = float(f[8]) * parser.settings.sigma_per_hdop[g.FIX_SINGLE]
    assert fix.covariance_type == g.COV_APPROXIMATED
    assert fix.covariance[0] == pytest.approx(sigma ** 2) and fix.covariance[4] == pytest.approx(sigma ** 2)
    assert status.satellites_used == int(f[7]) and status.hdop == pytest.approx(float(f[8]))
    assert status.correction_age == -1.0


@pytest.mark.parametrize("quality,fix_type", [("4", g.FIX_RTK_FIXED), ("5", g.FIX_RTK_FLOAT),
                                              ("2", g.FIX_DGPS), ("1", g.FIX_SINGLE), ("6", g.FIX_DEAD_RECKONING)])
def test_rtk_float_and_fixed_stay_distinct(quality, fix_type):
    f = real_sentences("ublox-zed-f9p-nmea.log", "GGA")[0].split(",")
    f[6], f[13] = quality, "1.5"
    events = NmeaParser().feed(with_checksum(",".join(f)), 1.0)
    status = of(events, g.GnssFixStatus)[0]
    assert status.fix_type == fix_type and status.correction_age == 1.5
    fixes = of(events, g.GnssFix)
    assert (len(fixes) == 1) == (fix_type in g.POSITION_FIX_TYPES)
    if fixes:
        assert fixes[0].fix_type == fix_type


def test_rtk_fixed_variance_smaller_than_float():
    f = real_sentences("ublox-zed-f9p-nmea.log", "GGA")[0].split(",")
    var = {}
    for q in "45":
        f[6] = q
        var[q] = of(NmeaParser().feed(with_checksum(",".join(f)), 1.0), g.GnssFix)[0].covariance[0]
    assert var["4"] < var["5"]


def test_gst_gives_full_covariance_ellipse():
    gst = real_sentences("skytraq-dgps.log", "GST")
    gga = real_sentences("skytraq-dgps.log", "GGA")
    body = next(b for b in gst if all(b.split(",")[2:5]))
    f = body.split(",")
    gga_f = next(x for x in gga if x.split(",")[1] == f[1]).split(",")
    parser = NmeaParser()
    fix = of(parser.feed(with_checksum(body) + with_checksum(",".join(gga_f)), 1.0), g.GnssFix)[0]
    assert fix.covariance_type == g.COV_KNOWN
    c = fix.covariance
    tr, det = c[0] + c[4], c[0] * c[4] - c[1] * c[3]
    major, minor = float(f[3]), float(f[4])
    assert tr == pytest.approx(major ** 2 + minor ** 2) and det == pytest.approx(major ** 2 * minor ** 2)
    assert c[1] == c[3] and c[8] == pytest.approx(float(f[8]) ** 2)


def test_velocity_enu_only_with_valid_fix():
    gga = real_sentences("ublox-zed-f9p-nmea.log", "GGA")[0]
    vtg = "GPVTG,90.0,T,,M,10.0,N,18.52,K,A"
    parser = NmeaParser()
    assert not of(parser.feed(with_checksum(vtg), 1.0), g.GnssVelocity)
    parser.feed(with_checksum(gga), 1.0)
    vel = of(parser.feed(with_checksum(vtg), 1.1), g.GnssVelocity)[0]
    assert vel.east == pytest.approx(10 * KNOT) and vel.north == pytest.approx(0, abs=1e-9)
    assert vel.covariance[8] == 99999.0
    # the fix goes stale on the host clock: no more velocity
    stale = 1.0 + parser.settings.fix_timeout + 1
    parser2 = NmeaParser()
    parser2.feed(with_checksum(gga), 1.0)
    assert not of(parser2.feed(with_checksum(vtg), stale), g.GnssVelocity)


def test_rmc_gives_time_reference_and_velocity_once_per_epoch():
    rmc = real_sentences("ublox-zed-f9p-nmea.log", "RMC")[0]
    vtg = real_sentences("ublox-zed-f9p-nmea.log", "VTG")[0]
    events = NmeaParser().feed(with_checksum(rmc) + with_checksum(vtg), 5.0)
    assert len(of(events, g.GnssVelocity)) == 1
    (t,) = of(events, g.ReceiverTime)
    import datetime as dt
    f = rmc.split(",")
    expected = dt.datetime.strptime(f[9] + f[1][:6], "%d%m%y%H%M%S").replace(tzinfo=dt.timezone.utc)
    assert t.receiver_time == pytest.approx(expected.timestamp() + float("0" + f[1][6:]))


def test_heading_from_hdt_and_ths():
    parser = NmeaParser()
    (att,) = parser.feed(with_checksum("GPHDT,274.07,T"), 1.0)
    assert att.heading == pytest.approx(274.07)
    assert of(parser.feed(with_checksum("GNTHS,77.52,A"), 1.0), g.GnssAttitude)[0].heading == pytest.approx(77.52)
    assert not parser.feed(with_checksum("GNTHS,77.52,V"), 1.0)


def test_bad_input_is_counted_not_raised():
    good = real_sentences("ublox-zed-f9p-nmea.log", "GGA")
    parser = NmeaParser()
    stream = (with_checksum(good[0])
              + b"\x00\xb5\x62\x01\x07garbage\xff\xfe\r\n"            # binary noise
              + with_checksum(good[1])[:-9] + b"\r\n"                  # truncated (no checksum)
              + with_checksum(good[2]).replace(b",1,", b",1,", 1)[:-5] + b"00\r\n"  # checksum failure
              + with_checksum(good[3].replace(good[3].split(",")[9], "nan", 1))  # NaN altitude
              + with_checksum(good[0]))                                # time backwards
    events = parser.feed(stream, 1.0)
    c = parser.counters
    assert c.checksum_failures == 2 and c.noise_lines == 1
    assert c.rejected == 2 and c.time_backwards == 1
    assert len(of(events, g.GnssFix)) == 1
    assert not any(isinstance(e, g.GnssFix) and not math.isfinite(e.altitude) for e in events)


def test_clock_reset_is_adopted_after_resync_epochs():
    good = real_sentences("ublox-zed-f9p-nmea.log", "GGA")
    parser = NmeaParser(NmeaSettings(resync_after=3))
    parser.feed(with_checksum(good[10]), 1.0)
    fixes = [of(parser.feed(with_checksum(b), 1.0), g.GnssFix) for b in good[:4]]
    assert [len(f) for f in fixes] == [0, 0, 1, 1]
    assert parser.counters.time_backwards == 2
