"""NMEA GNSS driver node: serial / TCP / file -> /gnss/fix, /gnss/vel, /gnss/status, /gnss/heading,
/gnss/time_reference, /diagnostics. Parsing lives in nmea.py."""
from __future__ import annotations

from agnav_common.node_main import main_for

from . import gnss_types as g
from .gnss_ros import GnssPublishers
from .nmea import NmeaParser, NmeaSettings
from .stream_driver import StreamDriverNode


class NmeaGnssNode(StreamDriverNode):
    def __init__(self, **kwargs):
        super().__init__("nmea_gnss", "nmea_gnss", default_baud=9600, stale_timeout=2.0, **kwargs)
        p = self.declare_parameter
        defaults = NmeaSettings()
        table = defaults.sigma_per_hdop
        self.parser = NmeaParser(NmeaSettings(
            sigma_per_hdop={g.FIX_SINGLE: p("sigma_single", table[g.FIX_SINGLE]).value,
                            g.FIX_DGPS: p("sigma_dgps", table[g.FIX_DGPS]).value,
                            g.FIX_RTK_FLOAT: p("sigma_rtk_float", table[g.FIX_RTK_FLOAT]).value,
                            g.FIX_RTK_FIXED: p("sigma_rtk_fixed", table[g.FIX_RTK_FIXED]).value},
            vertical_factor=p("vertical_factor", defaults.vertical_factor).value,
            velocity_std=p("velocity_std", defaults.velocity_std).value,
            sigma_no_accuracy=p("sigma_no_accuracy", defaults.sigma_no_accuracy).value,
            gga_timeout=p("gga_timeout", defaults.gga_timeout).value,
            require_checksum=p("require_checksum", defaults.require_checksum).value,
            gst_max_age=p("gst_max_age", defaults.gst_max_age).value,
            fix_timeout=p("fix_timeout", defaults.fix_timeout).value,
            resync_after=p("resync_after", defaults.resync_after).value))
        self.gnss = GnssPublishers(self, default_heading_std_deg=0.5)
        self.diagnostics.add("nmea", self._check)
        self.start_reading()

    def handle_bytes(self, data: bytes, host_time: float) -> None:
        for event in self.parser.feed(data, host_time):
            self.message_seen()
            if self.gnss.publish(event):
                self.published += 1

    def _check(self):
        c = self.parser.counters
        counters = {k: getattr(c, k) for k in ("lines", "accepted", "ignored", "checksum_failures", "parse_errors",
                                               "rejected", "time_backwards", "implausible", "floored_accuracy",
                                               "geoid_model", "noise_lines", "noise_bytes")}
        problems = c.checksum_failures + c.parse_errors + c.rejected
        return self.stream_check(counters, dict(c.by_type), problems, {
            "fix_type": g.FIX_NAMES[self.gnss.last_fix_type], "last_problem": c.last_problem})


main = main_for(NmeaGnssNode)
