"""ROS publishing of raw GNSS observations (RXM-RAWX, RXM-SFRBX) on /gnss/raw_observations and
/gnss/nav_data (agnav_msgs GnssObservations / GnssNavData), for tightly coupled GNSS/INS."""
from __future__ import annotations

from agnav_common.qos import PUBLISHER_QOS

from .gnss_types import GPS_EPOCH_UNIX, WEEK
from .ubx import GnssObservations, NavDataFrame

from agnav_msgs.msg import GnssNavData, GnssObservation, GnssObservations as GnssObservationsMsg


def observations_msg(node, e: GnssObservations, frame_id: str) -> GnssObservationsMsg:
    """agnav_msgs GnssObservations of an event, stamped by `node.stamp` (receiver time: GPS time - leap seconds,
    when they are known)."""
    msg = GnssObservationsMsg()
    utc = GPS_EPOCH_UNIX + e.week * WEEK + e.receiver_tow - e.leap_seconds if e.leap_seconds_known else None
    msg.header.stamp = node.stamp(e.host_time, utc)
    msg.header.frame_id = frame_id
    msg.receiver_tow, msg.week, msg.leap_seconds = e.receiver_tow, e.week, e.leap_seconds
    msg.leap_seconds_known, msg.clock_reset = e.leap_seconds_known, e.clock_reset
    msg.observations = [GnssObservation(
        gnss_id=o.gnss_id, sv_id=o.sv_id, sig_id=o.sig_id, freq_id=o.freq_id, pseudorange=o.pseudorange,
        carrier_phase=o.carrier_phase, doppler=o.doppler, cno=float(o.cno), lock_time=o.lock_time,
        pseudorange_std=o.pseudorange_std, carrier_phase_std=o.carrier_phase_std, doppler_std=o.doppler_std,
        pseudorange_valid=o.pseudorange_valid, carrier_phase_valid=o.carrier_phase_valid,
        half_cycle_resolved=o.half_cycle_resolved, half_cycle_subtracted=o.half_cycle_subtracted)
        for o in e.observations]
    return msg


class RawPublishers:
    def __init__(self, node):
        self.node = node
        self.obs = node.create_publisher(GnssObservationsMsg, "gnss/raw_observations", PUBLISHER_QOS)
        self.nav = node.create_publisher(GnssNavData, "gnss/nav_data", PUBLISHER_QOS)

    def publish(self, event) -> int:
        if isinstance(event, GnssObservations):
            self.obs.publish(observations_msg(self.node, event, self.node.gnss.frame_id))
        elif isinstance(event, NavDataFrame):
            self._nav(event)
        return 1

    def _nav(self, e: NavDataFrame):
        msg = GnssNavData()
        msg.header.stamp = self.node.stamp(e.host_time)
        msg.header.frame_id = self.node.gnss.frame_id
        msg.gnss_id, msg.sv_id, msg.sig_id, msg.freq_id = e.gnss_id, e.sv_id, e.sig_id, e.freq_id
        msg.words = [int(w) & 0xFFFFFFFF for w in e.words]
        self.nav.publish(msg)
