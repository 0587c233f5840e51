"""RTCM3 base-station node end to end: the real u-blox ZED-F9T RTCM3 capture (gpsd test data, MSM7 + 1005 among UBX
frames) through a pseudo-terminal and through TCP servers on 127.0.0.1 that the tests start (bounded, they stop by
themselves); the published observations equal what RtcmBase decodes from the same bytes, a flipped CRC is counted and
the stream goes on, a dropped connection is reconnected. NTRIP v1 / v2 (chunked) against a loopback caster."""
import base64
import io
import socket
import threading
import time
from dataclasses import replace

import numpy as np
import pymap3d
import pytest
from pyrtcm import RTCMReader
from rclpy.parameter import Parameter

from agnav_drivers.gnss_types import GPS_EPOCH_UNIX, WEEK
from agnav_drivers.ntrip import Dechunker, NtripLink, NtripSettings
from agnav_drivers.pty_device import PtyDevice
from agnav_drivers.rtcm_stream import RtcmStream, nearest_week
from agnav_drivers.serial_link import BACKOFF, OPEN
from agnav_drivers.ubx import GnssObservations

CORPUS = "/work/shared/data/real/gpsd_nmea/"
F9T = open(CORPUS + "ublox-zed-f9t-rtcm3.log", "rb").read()
OBS = "/gnss/base/observations"


def flip_crc(data, identity="1077", nth=4):
    """`data` with the last CRC byte of its `nth` `identity` frame inverted."""
    raws = [raw for raw, msg in RTCMReader(io.BytesIO(data), quitonerror=0) if msg and msg.identity == identity]
    raw = raws[nth]
    return data.replace(raw, raw[:-1] + bytes([raw[-1] ^ 0xFF]), 1)


def decoded(data):
    """(epochs, counters) of RtcmStream on `data`: what the node must publish."""
    stream = RtcmStream()
    events = stream.feed(data, time.time())
    return [e for e in events if isinstance(e, GnssObservations)], stream.counters


def obs_fields(o):
    return (o.gnss_id, o.sv_id, o.sig_id, o.freq_id, o.pseudorange, o.carrier_phase, np.float32(o.doppler),
            np.float32(o.cno), np.float32(o.lock_time), o.pseudorange_valid, o.carrier_phase_valid,
            o.half_cycle_resolved, o.half_cycle_subtracted)


def assert_published_equal(msgs, epochs):
    assert len(msgs) == len(epochs)
    for msg, e in zip(msgs, epochs):
        assert (msg.receiver_tow, msg.week, msg.header.frame_id) == (e.receiver_tow, e.week, "gnss_base")
        assert [obs_fields(o) for o in msg.observations] == [obs_fields(o) for o in e.observations]


class Server:
    """TCP server on 127.0.0.1 serving `handler(conn, index)` to at most `connections` clients, then stopping."""

    def __init__(self, handler, connections):
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.sock.settimeout(10.0)
        self.port = self.sock.getsockname()[1]
        self.requests = []
        self.thread = threading.Thread(target=self._serve, args=(handler, connections), daemon=True)
        self.thread.start()

    def _serve(self, handler, connections):
        with self.sock:
            for index in range(connections):
                try:
                    conn, _ = self.sock.accept()
                except OSError:
                    return
                with conn:
                    conn.settimeout(10.0)
                    try:
                        handler(conn, index)
                    except OSError:
                        pass

    def read_request(self, conn):
        head = b""
        while b"\r\n\r\n" not in head:
            head += conn.recv(1024)
        self.requests.append(head.decode())
        return head.decode()


class Graph:
    """The node under test and a listener on one executor."""

    def __init__(self, rclpy, **params):
        from rclpy.executors import SingleThreadedExecutor

        from agnav_drivers.rtcm_base_node import RtcmBaseNode
        self.node = RtcmBaseNode(parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
        self.listener = rclpy.create_node("rtcm_test_listener")
        self.got = {}
        self.executor = SingleThreadedExecutor()
        for n in (self.node, self.listener):
            self.executor.add_node(n)

    def listen(self, msg_type, topic, qos=None):
        from agnav_common.qos import SENSOR_QOS
        self.got[topic] = []
        self.listener.create_subscription(msg_type, topic, self.got[topic].append, qos or SENSOR_QOS)

    def wait(self, done, timeout=20.0):
        end = time.monotonic() + timeout
        while not done() and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.05)
        return done()

    def close(self):
        self.node.destroy_node()
        self.listener.destroy_node()


def test_stream_is_split_independent_and_weeks_follow_the_clock():
    data = flip_crc(F9T)
    whole, counters = decoded(data)
    stream, pieces = RtcmStream(), []
    for i in range(0, len(data), 7):
        pieces += [e for e in stream.feed(data[i:i + 7], time.time()) if isinstance(e, GnssObservations)]
    assert [replace(e, host_time=0.0) for e in whole] == [replace(e, host_time=0.0) for e in pieces]
    assert stream.counters == counters
    unset = RtcmStream()                                       # sim time before the first /clock: no week
    assert not any(isinstance(e, GnssObservations) for e in unset.feed(data, 0.0))
    assert unset.counters.no_clock == 26 and unset.counters.epochs == 0
    assert counters.crc_failures > decoded(F9T)[1].crc_failures and counters.epochs == len(whole) == 26
    start = GPS_EPOCH_UNIX + 2288 * WEEK - 18.0                # UTC unix time at which GPS week 2288 begins
    assert nearest_week(252800.0, start + 252801.0) == 2288
    assert nearest_week(604790.0, start + 10.0) == 2287 and nearest_week(5.0, start + 10.0) == 2288
    assert nearest_week(3.0, start - 5.0) == 2288              # clock a few seconds behind at the rollover


def test_pty_stream_publishes_base_observations_and_position(ros, tmp_path):
    from geometry_msgs.msg import PointStamped
    from sensor_msgs.msg import NavSatFix

    from agnav_common.qos import LATCHED_QOS
    from agnav_msgs.msg import GnssObservations as GnssObservationsMsg
    data = flip_crc(F9T)
    epochs, counters = decoded(data)
    device = PtyDevice(str(tmp_path / "ttyBASE"))
    g = Graph(ros, port=device.path, baud=460800)
    try:
        g.listen(GnssObservationsMsg, OBS)
        assert g.wait(lambda: g.node.link.state == OPEN)
        threading.Thread(target=device.stream, args=(data, 460800, 256), daemon=True).start()
        assert g.wait(lambda: len(g.got[OBS]) >= len(epochs) and g.node.decoder.counters.frames >= counters.frames)
        assert_published_equal(g.got[OBS], epochs)
        values = g.node._check()[2]
        for key in ("frames", "crc_failures", "parse_errors", "noise_bytes", "epochs", "no_clock"):
            assert values[key] == getattr(counters, key), key
        assert values["gps_week"] == epochs[-1].week
        # latched: a subscriber that joins after the 1005 still gets the base position, once
        g.listen(PointStamped, "/gnss/base/position", LATCHED_QOS)
        g.listen(NavSatFix, "/gnss/base/fix", LATCHED_QOS)
        assert g.wait(lambda: g.got["/gnss/base/position"] and g.got["/gnss/base/fix"])
        p, fix = g.got["/gnss/base/position"][0], g.got["/gnss/base/fix"][0]
        arp = g.node.decoder.base.position.ecef
        assert p.header.frame_id == "ecef" and [p.point.x, p.point.y, p.point.z] == list(arp)
        assert 6.3e6 < np.linalg.norm(arp) < 6.4e6
        assert np.allclose(pymap3d.geodetic2ecef(fix.latitude, fix.longitude, fix.altitude), arp, atol=1e-3)
        assert 43.5 < fix.latitude < 44.5 and -121.7 < fix.longitude < -120.9      # Bend, Oregon
        g.wait(lambda: False, timeout=0.3)
        assert len(g.got["/gnss/base/position"]) == 1 and g.node.published == len(epochs) + 2
    finally:
        g.close()
        device.close()


def test_week_and_stamps_follow_the_simulated_clock(ros, tmp_path):
    """use_sim_time: a /clock on the capture's day (2019-10-17, GPS week 2075) gives that week and those stamps."""
    from rosgraph_msgs.msg import Clock

    from agnav_common.stamps import to_sec, to_stamp
    from agnav_msgs.msg import GnssObservations as GnssObservationsMsg
    epochs, _ = decoded(F9T)
    sim = GPS_EPOCH_UNIX + 2075 * WEEK + epochs[0].receiver_tow - 18.0
    device = PtyDevice(str(tmp_path / "ttyBASE"))
    g = Graph(ros, port=device.path, baud=460800, use_sim_time=True)
    try:
        g.listen(GnssObservationsMsg, OBS)
        clock = g.listener.create_publisher(Clock, "/clock", 10)

        def clock_set():
            clock.publish(Clock(clock=to_stamp(sim)))
            return g.node.get_clock().now().nanoseconds > 0
        assert g.wait(clock_set)
        assert g.wait(lambda: g.node.link.state == OPEN)
        threading.Thread(target=device.stream, args=(F9T, 460800, 256), daemon=True).start()
        assert g.wait(lambda: len(g.got[OBS]) >= 3)
        assert {m.week for m in g.got[OBS]} == {2075}
        assert all(to_sec(m.header.stamp) == pytest.approx(sim) for m in g.got[OBS])
    finally:
        g.close()
        device.close()


def test_tcp_stream_survives_garbage_and_a_dropped_connection(ros):
    from agnav_msgs.msg import GnssObservations as GnssObservationsMsg
    half = len(F9T) // 2
    sent = [bytes(range(256)) * 4 + F9T[:half], flip_crc(F9T)]      # noise, half a capture, drop; the capture
    epochs, counters = decoded(b"".join(sent))
    server = Server(lambda conn, i: (conn.sendall(sent[i]), time.sleep(0.2 if i == 0 else 5.0)), connections=2)
    g = Graph(ros, host="127.0.0.1", tcp_port=server.port, backoff_initial=0.05)
    try:
        g.listen(GnssObservationsMsg, OBS)
        assert g.wait(lambda: len(g.got[OBS]) >= len(epochs))
        assert_published_equal(g.got[OBS], epochs)
        status = g.node.link.status()
        assert status["opens"] == 2 and status["disconnects"] == 1 and g.node.link.state == OPEN
        assert g.node.decoder.counters.crc_failures == counters.crc_failures > 0
        assert g.node.diagnostics._hardware_id == f"rtcm_base on tcp 127.0.0.1:{server.port}"
    finally:
        g.close()


def _chunked(data, size=1000):
    return b"".join(b"%x\r\n%s\r\n" % (len(data[i:i + size]), data[i:i + size]) for i in range(0, len(data), size))


@pytest.mark.parametrize("version", [1, 2])
def test_ntrip_client_gets_the_mountpoint_stream(version):
    auth = "Basic " + base64.b64encode(b"farmer:secret").decode()

    def caster(conn, index):
        head = server.read_request(conn)
        if f"Authorization: {auth}" not in head:
            conn.sendall(b"HTTP/1.1 401 Unauthorized\r\n\r\n")
        elif not head.startswith("GET /BASE1 "):
            conn.sendall(b"SOURCETABLE 200 OK\r\n\r\nSTR;BASE1;...\r\nENDSOURCETABLE\r\n")
        elif version == 1:
            conn.sendall(b"ICY 200 OK\r\n" + F9T)
        else:
            conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Type: gnss/data\r\nTransfer-Encoding: chunked\r\n\r\n"
                         + _chunked(F9T))
        if index == 2:
            time.sleep(1.0)    # keep the stream open while the client reads

    server = Server(caster, connections=3)
    base = dict(host="127.0.0.1", tcp_port=server.port, ntrip_version=version, backoff_initial=0.05)
    wrong = [NtripLink(NtripSettings(**base, mountpoint="BASE1", ntrip_user="farmer", ntrip_password="guess")),
             NtripLink(NtripSettings(**base, mountpoint="NOPE", ntrip_user="farmer", ntrip_password="secret"))]
    for link, status in zip(wrong, ("401 Unauthorized", "SOURCETABLE 200 OK")):
        assert link.read(0.5) == b"" and link.state == BACKOFF and status in link.last_error
        link.close()
    link = NtripLink(NtripSettings(**base, mountpoint="BASE1", ntrip_user="farmer", ntrip_password="secret"))
    got, end = b"", time.monotonic() + 10.0
    while len(got) < len(F9T) and time.monotonic() < end:
        got += link.read(0.1)
    link.close()
    assert got == F9T and link.settings.describe == f"ntrip 127.0.0.1:{server.port}/BASE1"
    request = server.requests[-1]
    assert request.startswith(f"GET /BASE1 HTTP/1.{version - 1}\r\n")
    assert ("Ntrip-Version: Ntrip/2.0" in request) == (version == 2)


def test_dechunker_any_split_and_end_of_stream():
    data = _chunked(F9T[:3000], 700)
    for step in (1, 5, 333):
        d = Dechunker()
        assert b"".join(d.feed(data[i:i + step]) for i in range(0, len(data), step)) == F9T[:3000]
    with pytest.raises(ConnectionError, match="ended"):
        Dechunker().feed(b"0\r\n\r\n")
    with pytest.raises(ConnectionError, match="chunk size"):
        Dechunker().feed(b"zz\r\n")


def test_1006_antenna_height_on_diagnostics(ros):
    """rtcm3.bndm.log (ORGN network, Bend): legacy 1004/1012 observations (counted, not published) and 1006."""
    data = open(CORPUS + "rtcm3.bndm.log", "rb").read()
    msg = next(m for _, m in RTCMReader(io.BytesIO(data), quitonerror=0) if m and m.identity == "1006")
    g = Graph(ros)
    try:
        g.node.handle_bytes(data, time.time())
        values = g.node._check()[2]
        assert values["station_id"] == msg.DF003 and float(values["antenna_height"]) == pytest.approx(msg.DF028)
        assert values["arp_ecef"] == f"{msg.DF025:.4f} {msg.DF026:.4f} {msg.DF027:.4f}"
        assert values["epochs"] == 0 and values["frames"] > 80 and g.node.published == 2
    finally:
        g.close()
