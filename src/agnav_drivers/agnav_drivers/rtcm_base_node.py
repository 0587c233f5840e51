"""RTCM3 base-station node: serial / TCP / NTRIP caster / file -> gnss/base/observations (agnav_msgs
GnssObservations, the rover's RXM-RAWX numbering), gnss/base/position (ECEF antenna reference point, latched),
gnss/base/fix (the same point as NavSatFix, latched), /diagnostics."""
from __future__ import annotations

from dataclasses import dataclass

import pymap3d
from geometry_msgs.msg import PointStamped
from sensor_msgs.msg import NavSatFix, NavSatStatus

from agnav_common.node_main import main_for
from agnav_common.qos import LATCHED_QOS, PUBLISHER_QOS
from agnav_common.stamps import to_stamp
from agnav_msgs.msg import GnssObservations as GnssObservationsMsg

from .ntrip import NtripLink, NtripSettings
from .rtcm_raw import BasePosition
from .rtcm_stream import RtcmStream
from .stream_driver import StreamDriverNode, StreamSettings, stream_parameters
from .ubx import GnssObservations
from .ubx_raw_ros import observations_msg

ECEF_FRAME = "ecef"
PARAMS_DOC = """RTCM3 base station (rtcm_base_node): MSM4/5/7 of GPS, Galileo, BeiDou, QZSS -> gnss/base/observations
(GLONASS, SBAS and legacy 1001-1012 are counted, not published); 1005/1006 antenna reference point ->
gnss/base/position (PointStamped, frame ecef) and gnss/base/fix (NavSatFix, WGS84), latched, published when it changes.
Source: port (serial), else host + tcp_port (a raw TCP stream, or an NTRIP caster when mountpoint is set), else file.
Frames need a valid CRC-24Q; failures are counted (crc_failures) and the stream goes on. The GPS week is not in RTCM:
each epoch takes the week nearest to the node clock (use_sim_time aware). Stamps are the host receive time (RTCM
carries no leap seconds, so stamp_source receiver falls back to it); the epoch is in receiver_tow and week."""


@dataclass
class RtcmBaseSettings(StreamSettings, NtripSettings):
    baud: int = 115200         # bit/s of the serial port
    frame_id: str = "gnss_base"  # frame of the observations and of gnss/base/fix: the base antenna


def parameter_entries():
    return stream_parameters(RtcmBaseSettings())


class RtcmBaseNode(StreamDriverNode):
    link_class = NtripLink

    def __init__(self, **kwargs):
        super().__init__("rtcm_base", "rtcm_base", RtcmBaseSettings(), **kwargs)
        self.decoder = RtcmStream()
        self.obs = self.create_publisher(GnssObservationsMsg, "gnss/base/observations", PUBLISHER_QOS)
        self.position = self.create_publisher(PointStamped, "gnss/base/position", LATCHED_QOS)
        self.fix = self.create_publisher(NavSatFix, "gnss/base/fix", LATCHED_QOS)
        self.last_epoch: GnssObservations | None = None
        self._published_position = None
        self.diagnostics.add("rtcm", self._check)
        self.start_reading()

    def handle_bytes(self, data: bytes, host_time: float) -> None:
        frames = self.decoder.counters.frames
        for event in self.decoder.feed(data, host_time):
            if isinstance(event, GnssObservations):
                self.last_epoch = event
                self.obs.publish(observations_msg(self, event, self.settings.frame_id))
                self.published += 1
            elif isinstance(event, BasePosition):
                self._publish_position(event, host_time)
        if self.decoder.counters.frames > frames:
            self.message_seen()

    def _publish_position(self, p: BasePosition, host_time: float):
        key = (p.station, tuple(p.ecef), p.antenna_height)
        if key == self._published_position:
            return
        self._published_position = key
        point = PointStamped()
        point.header.stamp = to_stamp(host_time)
        point.header.frame_id = ECEF_FRAME
        point.point.x, point.point.y, point.point.z = (float(v) for v in p.ecef)
        self.position.publish(point)
        fix = NavSatFix()
        fix.header.stamp = point.header.stamp
        fix.header.frame_id = self.settings.frame_id
        fix.status.status, fix.status.service = NavSatStatus.STATUS_FIX, NavSatStatus.SERVICE_GPS
        fix.latitude, fix.longitude, fix.altitude = (float(v) for v in pymap3d.ecef2geodetic(*p.ecef))
        fix.position_covariance_type = NavSatFix.COVARIANCE_TYPE_UNKNOWN
        self.fix.publish(fix)
        self.published += 2

    def _check(self):
        c = self.decoder.counters
        counters = {k: getattr(c, k) for k in ("frames", "crc_failures", "parse_errors", "noise_bytes", "epochs",
                                               "no_clock")}
        now = self.get_clock().now().nanoseconds * 1e-9
        detail = {"last_problem": c.last_problem,
                  "last_epoch_age": "never" if self.last_epoch is None else f"{now - self.last_epoch.host_time:.2f}"}
        if self.last_epoch is not None:
            detail.update(gps_week=self.last_epoch.week, last_epoch_tow=f"{self.last_epoch.receiver_tow:.3f}",
                          last_epoch_signals=len(self.last_epoch.observations))
        p = self.decoder.base.position
        if p is not None:
            detail.update(station_id=p.station, arp_ecef=" ".join(f"{v:.4f}" for v in p.ecef),
                          antenna_height=f"{p.antenna_height:.4f}")
        return self.stream_check(counters, dict(c.by_type), c.crc_failures + c.parse_errors, detail)


main = main_for(RtcmBaseNode)
