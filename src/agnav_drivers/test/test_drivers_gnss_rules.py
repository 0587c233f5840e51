"""GNSS output rules shared by the drivers: ellipsoidal altitude (geoid model), RMC/GLL fixes without GGA,
no position without a fix, physical limits. Real gpsd captures where they exist."""
import datetime as dt
import math
import os
import re

import pytest

from agnav_drivers import gnss_types as g
from agnav_drivers.nmea import NmeaParser
from drivers_helpers import CORPUS, CORPUS_FILES, real_sentences, with_checksum

ANY_CASE = re.compile(rb"\$[A-Z]{2}(RMC|GLL),[^\r\n$*]*\*[0-9A-Fa-f]{2}")


def feed(data: bytes, parser=None, chunk=64):
    parser = parser or NmeaParser()
    events = []
    for i in range(0, len(data), chunk):
        events += parser.feed(data[i:i + chunk], 100.0 + i * 1e-3)
    return parser, events


def fixes(events):
    return [e for e in events if isinstance(e, g.GnssFix)]


def fields(body: str) -> list[str]:
    return body.split(",")


# ---- geoid ------------------------------------------------------------------------------------------------------
def test_geoid_model_agrees_with_the_separation_receivers_report():
    """66 receivers worldwide that send the GGA geoid separation: the model is within their own tables' spread."""
    diffs = {}
    for path in CORPUS_FILES:
        for body in real_sentences(os.path.basename(path), "GGA"):
            f = fields(body)
            if len(f) > 11 and f[6] in ("1", "2", "4", "5") and f[11] and f[2] and f[4]:
                try:
                    lat = (float(f[2][:2]) + float(f[2][2:]) / 60) * (1 if f[3] == "N" else -1)
                    lon = (float(f[4][:3]) + float(f[4][3:]) / 60) * (1 if f[5] == "E" else -1)
                    sep = float(f[11])
                except ValueError:
                    continue
                diffs.setdefault(path, []).append(g.geoid_height(lat, lon) - sep)
    worst = max(abs(d) for v in diffs.values() for d in v)
    assert len(diffs) > 50 and worst < 8.0


TELIT = [b for b in real_sentences("telit-he910.log", "GGA") if fields(b)[6] == "1"]


def test_gga_without_geoid_separation_is_made_ellipsoidal_by_the_model():
    body = TELIT[0]
    f = fields(body)
    assert f[11] == ""  # MSL altitude, empty separation (a Telit HE910 in Brussels)
    parser = NmeaParser()
    _, fix = parser.feed(with_checksum(body), 1.0)
    separation = fix.altitude - float(f[9])
    assert 40.0 < separation < 50.0  # EGM96 geoid in Belgium: about +45 m (was 0: altitude 45 m too low)
    assert separation == pytest.approx(g.geoid_height(fix.latitude, fix.longitude))
    sigma_h = float(f[8]) * parser.settings.sigma_per_hdop[g.FIX_SINGLE]
    assert fix.covariance[8] == pytest.approx((2 * sigma_h) ** 2 + g.GEOID_MODEL_STD ** 2)
    assert parser.counters.geoid_model == 1


def test_whole_telit_capture_is_ellipsoidal():
    data = open(os.path.join(CORPUS, "telit-he910.log"), "rb").read()
    parser, events = feed(data)
    out = fixes(events)
    assert len(out) > 150 and parser.counters.geoid_model == len(out)
    msl = {float(fields(b)[9]) for b in TELIT}
    for fx in out:
        separation = g.geoid_height(fx.latitude, fx.longitude)
        assert 40.0 < separation < 50.0 and round(fx.altitude - separation, 3) in msl


def test_without_a_geoid_model_the_altitude_is_unknown(monkeypatch):
    monkeypatch.setattr(g, "_GEOID", [None])  # pyrtklib missing
    f = fields(TELIT[0])
    _, fix = NmeaParser().feed(with_checksum(TELIT[0]), 1.0)
    assert fix.altitude == pytest.approx(float(f[9]))
    assert fix.covariance[8] >= g.UNKNOWN_VARIANCE and fix.covariance[0] < 100.0
    assert fix.covariance_type == g.COV_APPROXIMATED


# ---- fixes from RMC / GLL when a stream has no GGA --------------------------------------------------------------
def a_epochs(path):
    """Times of RMC/GLL sentences with status A and a position (independent of the parser)."""
    times = []
    for m in ANY_CASE.finditer(open(path, "rb").read()):
        f = m.group().decode().split("*")[0].split(",")
        time_, status, lat = (f[1], f[2], f[3]) if f[0].endswith("RMC") else (f[5], f[6], f[1])
        if status == "A" and lat and time_ not in times:
            times.append(time_)
    return times


@pytest.mark.parametrize("name", ["ait250.log", "firefly-II.log", "magellan-ec10.log", "sounder.log"])
def test_rmc_or_gll_only_captures_give_honest_fixes(name):
    path = os.path.join(CORPUS, name)
    parser, events = feed(open(path, "rb").read())
    out = fixes(events)
    expected = len(a_epochs(path)) - 1  # the first epoch waits: a GGA might have followed it
    assert expected > 5 and len(out) == expected
    sigma = parser.settings.sigma_no_accuracy
    for fx in out:
        assert fx.fix_type == g.FIX_SINGLE and fx.covariance_type == g.COV_APPROXIMATED
        assert fx.covariance[0] == fx.covariance[4] == pytest.approx(sigma ** 2)
        assert fx.covariance[8] == g.UNKNOWN_VARIANCE and math.isfinite(fx.altitude)
        assert abs(fx.altitude) < 110  # mean sea level: the geoid, within its global range
    assert len({fx.receiver_time for fx in out if fx.receiver_time is not None}) == len(out) or "sounder" in name


def test_gga_stays_the_only_fix_source_and_rmc_takes_over_when_gga_stops():
    rmc = real_sentences("ublox-zed-f9p-nmea.log", "RMC")
    gga = {fields(b)[1]: b for b in real_sentences("ublox-zed-f9p-nmea.log", "GGA")}
    gll = {fields(b)[5]: b for b in real_sentences("ublox-zed-f9p-nmea.log", "GLL")}
    epochs = [(fields(r)[1], r) for r in rmc if fields(r)[1] in gga and fields(r)[1] in gll][:10]
    stream = b""
    for k, (t, r) in enumerate(epochs):  # receiver order: RMC, GGA, GLL; GGA output stops after epoch 4
        stream += with_checksum(r) + (with_checksum(gga[t]) if k < 5 else b"") + with_checksum(gll[t])
    _, events = feed(stream)
    out = fixes(events)
    from_gga = [fx for fx in out if fx.covariance[8] < g.UNKNOWN_VARIANCE]
    from_rmc = [fx for fx in out if fx.covariance[8] == g.UNKNOWN_VARIANCE]
    assert len(from_gga) == 5  # one per epoch: RMC and GLL of those epochs add none
    assert len(from_rmc) == 3  # epochs 7, 8, 9: more than gga_timeout (2 s) after the last GGA
    assert len({fx.receiver_time for fx in out}) == len(out)


def test_no_fix_sentences_never_give_a_position():
    rmc = fields(real_sentences("ublox-zed-f9p-nmea.log", "RMC")[0])
    gga = fields(real_sentences("ublox-zed-f9p-nmea.log", "GGA")[0])
    t0 = dt.datetime.strptime(rmc[1], "%H%M%S.%f")
    stream = b""
    for k in range(6):  # an RMC/GLL-only stream (fixes allowed from the second epoch) ...
        t = (t0 + dt.timedelta(seconds=k)).strftime("%H%M%S.00")
        r, gl = list(rmc), ["GNGLL", rmc[3], rmc[4], rmc[5], rmc[6], t, "A", "A"]
        r[1] = t
        if k >= 2:  # ... whose sentences say there is no position: status V, modes N / E / S
            r[2], r[12] = ("V", "N") if k % 2 else ("A", "E")
            gl[6], gl[7] = ("V", "N") if k % 2 else ("A", "S")
        stream += with_checksum(",".join(r)) + with_checksum(",".join(gl))
    q0 = list(gga)
    q0[1], q0[6] = (t0 + dt.timedelta(seconds=7)).strftime("%H%M%S.00"), "0"  # quality 0 with a position
    parser, events = feed(stream + with_checksum(",".join(q0)))
    out = fixes(events)
    assert len(out) == 1 and out[0].receiver_time is not None  # epoch 1 only
    status = [e for e in events if isinstance(e, g.GnssFixStatus)]
    assert [s.fix_type for s in status] == [g.FIX_NONE]


# ---- physical limits --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("index,value", [(9, "25000.0"), (9, "-1500.0")])
def test_nmea_implausible_altitude_is_rejected_and_counted(index, value):
    f = fields(real_sentences("ublox-zed-f9p-nmea.log", "GGA")[0])
    f[index] = value
    parser = NmeaParser()
    assert not fixes(parser.feed(with_checksum(",".join(f)), 1.0))
    assert parser.counters.implausible == 1 and parser.counters.rejected == 1


def test_nmea_implausible_speed_is_rejected_and_counted():
    gga = real_sentences("ublox-zed-f9p-nmea.log", "GGA")[0]
    vtg = "GPVTG,90.0,T,,M,250.0,N,463.0,K,A"  # 129 m/s: not a tractor
    parser = NmeaParser()
    parser.feed(with_checksum(gga), 1.0)
    assert not [e for e in parser.feed(with_checksum(vtg), 1.1) if isinstance(e, g.GnssVelocity)]
    assert parser.counters.implausible == 1


def test_screen_turns_a_no_fix_into_nan_with_unknown_covariance():
    no_fix = g.GnssFix(1.0, None, 0.0, 0.0, 0.0, g.FIX_NONE, g.diag3(1.0, 1.0, 1.0), g.COV_DIAGONAL_KNOWN)
    (out,), problem = g.Screen()([no_fix])
    assert problem is None and out.covariance_type == g.COV_UNKNOWN
    assert all(math.isnan(v) for v in (out.latitude, out.longitude, out.altitude))


def test_publisher_never_gives_a_no_fix_a_position():
    from sensor_msgs.msg import NavSatFix, NavSatStatus

    from agnav_common.stamps import to_stamp
    from agnav_drivers.gnss_ros import GnssPublishers, GnssStreamSettings

    class Node:  # the part of rclpy.Node that GnssPublishers uses
        def __init__(self):
            self.sent = []

        def create_publisher(self, msg_type, topic, qos):
            return type("Pub", (), {"publish": lambda _, msg: self.sent.append((topic, msg))})()

        def stamp(self, host_time, receiver_time=None):
            return to_stamp(host_time)

    node = Node()
    pubs = GnssPublishers(node, GnssStreamSettings())
    pubs.publish(g.GnssFix(5.0, None, 0.0, 0.0, 0.0, g.FIX_NONE, g.diag3(1e-4, 1e-4, 1e-4), g.COV_DIAGONAL_KNOWN))
    pubs.publish(g.GnssFix(6.0, None, 52.0, 13.0, 90.0, g.FIX_SINGLE, g.diag3(4.0, 4.0, 9.0), g.COV_APPROXIMATED))
    (_, none), (_, good) = node.sent
    assert none.status.status == NavSatStatus.STATUS_NO_FIX
    assert all(math.isnan(v) for v in (none.latitude, none.longitude, none.altitude))
    assert none.position_covariance_type == NavSatFix.COVARIANCE_TYPE_UNKNOWN
    assert good.status.status == NavSatStatus.STATUS_FIX and good.latitude == 52.0
    assert list(good.position_covariance) == [4.0, 0, 0, 0, 4.0, 0, 0, 0, 9.0]
