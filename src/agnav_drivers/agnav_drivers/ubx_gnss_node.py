"""u-blox UBX GNSS driver node: serial / TCP / file -> /gnss/fix, /gnss/vel, /gnss/status,
/gnss/heading (NAV-PVAT / NAV-ATT attitude), /gnss/time_reference, /gnss/raw_observations and
/gnss/nav_data (when agnav_msgs provides GnssObservations / GnssNavData), /diagnostics."""
from __future__ import annotations

from dataclasses import dataclass

from agnav_common.node_main import main_for

from . import gnss_types as g
from .gnss_ros import GnssPublishers, GnssStreamSettings
from .stream_driver import StreamDriverNode, stream_parameters
from .ubx import EsfMeasurement, EsfStatus, GnssObservations, NavDataFrame, UbxParser
from .ubx_raw_ros import RawPublishers

ESF_FUSION = {0: "initialising", 1: "fusion", 2: "suspended", 3: "disabled"}
PARAMS_DOC = """u-blox UBX receiver (ubx_gnss_node). Enable NAV-PVT (or NAV-PVAT on dead-reckoning modules), NAV-DOP,
NAV-ATT, ESF-STATUS and, for tight coupling, RXM-RAWX + RXM-SFRBX on the receiver.
Covariance comes from the receiver: diag(hAcc^2, hAcc^2, vAcc^2) (DIAGONAL_KNOWN), velocity sAcc^2.
Fix type: carrSoln 2 -> RTK fixed, 1 -> RTK float, diffSoln -> DGPS, fixType 1 -> dead reckoning.
Corrupt headers (class unknown, or a length that the message cannot have: NAV-PVT 84/92, NAV-PVAT 116, NAV-ATT 32,
NAV-DOP 18, ESF/RXM lengths from their item counts, others <= 4096 B, or a valid frame inside the awaited payload) are
skipped at once (counter corrupt_frames); frames keep the host time of their own arrival. Physical limits
(gnss_types.Limits): |lat| <= 90, |lon| <= 180, altitude -1000..20000 m, speed <= 100 m/s, else the message is dropped
(counter implausible); hAcc/vAcc/sAcc below 0.01 m(/s) and attitude accuracies below 0.01 deg, e.g. 0, are raised to
it (counter floored_accuracy), never published as a known zero. No fix -> /gnss/status only (never a position: NaN,
covariance UNKNOWN). stamp_source receiver: NAV-PVT UTC (valid + fully resolved) / RAWX GPS time - leap seconds."""


@dataclass
class UbxNodeSettings(GnssStreamSettings):
    baud: int = 38400  # bit/s of the serial port


def parameter_entries():
    return stream_parameters(UbxNodeSettings())


class UbxGnssNode(StreamDriverNode):
    def __init__(self, **kwargs):
        super().__init__("ubx_gnss", "ubx_gnss", UbxNodeSettings(), **kwargs)
        self.parser = UbxParser()
        self.gnss = GnssPublishers(self, self.settings)
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
