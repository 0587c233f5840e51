"""u-blox UBX GNSS driver node: serial / TCP / file -> /gnss/fix, /gnss/vel, /gnss/status,
/gnss/heading (NAV-PVAT / NAV-ATT attitude), /gnss/time_reference, /gnss/raw_observations and
/gnss/nav_data (when agnav_msgs provides GnssObservations / GnssNavData), /diagnostics."""
from __future__ import annotations

from agnav_common.node_main import main_for

from . import gnss_types as g
from .gnss_ros import GnssPublishers
from .stream_driver import StreamDriverNode
from .ubx import EsfMeasurement, EsfStatus, GnssObservations, NavDataFrame, UbxParser
from .ubx_raw_ros import RawPublishers

ESF_FUSION = {0: "initialising", 1: "fusion", 2: "suspended", 3: "disabled"}


class UbxGnssNode(StreamDriverNode):
    def __init__(self, **kwargs):
        super().__init__("ubx_gnss", "ubx_gnss", default_baud=38400, stale_timeout=2.0, **kwargs)
        self.parser = UbxParser()
        self.gnss = GnssPublishers(self, default_heading_std_deg=1.0)
        self.raw = RawPublishers(self)
        self.esf_status: EsfStatus | None = None
        self.esf_measurements = 0
        self.diagnostics.add("ubx", self._check)
        self.start_reading()

    def handle_bytes(self, data: bytes, host_time: float) -> None:
        for event in self.parser.feed(data, host_time):
            self.message_seen()
            if isinstance(event, EsfStatus):
                self.esf_status = event
            elif isinstance(event, EsfMeasurement):
                self.esf_measurements += 1
            elif isinstance(event, (GnssObservations, NavDataFrame)):
                self.published += self.raw.publish(event)
            elif self.gnss.publish(event):
                self.published += 1

    def _check(self):
        c = self.parser.counters
        counters = {k: getattr(c, k) for k in ("frames", "accepted", "ignored", "checksum_failures", "corrupt_frames",
                                               "parse_errors", "rejected", "implausible", "floored_accuracy",
                                               "noise_bytes")}
        detail = {"fix_type": g.FIX_NAMES[self.gnss.last_fix_type], "last_problem": c.last_problem,
                  "esf_measurements": self.esf_measurements}
        if self.esf_status is not None:
            detail["esf_fusion_mode"] = ESF_FUSION.get(self.esf_status.fusion_mode, self.esf_status.fusion_mode)
            detail["esf_sensors_used"] = f"{self.esf_status.sensors_used}/{self.esf_status.sensors}"
        problems = c.checksum_failures + c.corrupt_frames + c.parse_errors + c.rejected
        return self.stream_check(counters, dict(c.by_type), problems, detail)


main = main_for(UbxGnssNode)
