"""NMEA GNSS driver node: serial / TCP / file -> /gnss/fix, /gnss/vel, /gnss/status, /gnss/heading,
/gnss/time_reference, /diagnostics. Parsing lives in nmea.py."""
from __future__ import annotations

from dataclasses import dataclass

from agnav_common.node_main import main_for

from . import gnss_types as g
from .gnss_ros import GnssPublishers, GnssStreamSettings
from .nmea import NmeaParser, NmeaSettings
from .stream_driver import StreamDriverNode, stream_parameters

_NMEA = NmeaSettings()
PARAMS_DOC = """NMEA 0183 GNSS receiver (nmea_gnss_node). Source: `port` (serial), else `host`+`tcp_port`, else `file`.
Covariance without GST: sigma (m per axis) = HDOP x sigma_<fix type>; vertical sigma = VDOP (from GSA) x sigma, else
vertical_factor x horizontal (COVARIANCE_TYPE_APPROXIMATED). With GST: semi-major/minor/orientation -> KNOWN (full ENU
ellipse), lat/lon sigmas -> DIAGONAL_KNOWN.
Altitude is ellipsoidal: MSL + GGA geoid separation; an empty separation field is filled from EGM96 (pyrtklib's 1x1
deg table, vertical variance + 2^2 m^2; diagnostic counter geoid_model); without pyrtklib the MSL altitude is kept
with vertical variance 99999 m^2 (unknown).
Physical limits (gnss_types.Limits, shared with ubx_gnss): |lat| <= 90, |lon| <= 180, altitude -1000..20000 m, speed
<= 100 m/s; a sentence beyond them is dropped (counter implausible); a sigma below 0.01 m (0.01 m/s, 0.01 deg) is
raised to it (counter floored_accuracy). No fix -> /gnss/status only (never a position: NaN lat/lon/alt, covariance
UNKNOWN)."""


@dataclass
class NmeaNodeSettings(GnssStreamSettings):
    baud: int = 9600             # bit/s of the serial port
    heading_std: float = 0.5     # deg, HDT/THS heading sigma on /gnss/heading (NMEA gives no accuracy)
    sigma_single: float = _NMEA.sigma_per_hdop[g.FIX_SINGLE]        # m per axis at HDOP 1: autonomous (GGA 1, 3)
    sigma_dgps: float = _NMEA.sigma_per_hdop[g.FIX_DGPS]            # m per axis at HDOP 1: DGPS / SBAS (GGA 2, 9)
    sigma_rtk_float: float = _NMEA.sigma_per_hdop[g.FIX_RTK_FLOAT]  # m per axis at HDOP 1: RTK float (GGA 5)
    sigma_rtk_fixed: float = _NMEA.sigma_per_hdop[g.FIX_RTK_FIXED]  # m per axis at HDOP 1: RTK fixed (GGA 4)
    vertical_factor: float = _NMEA.vertical_factor  # sigma_up / sigma_horizontal when GSA gives no VDOP
    velocity_std: float = _NMEA.velocity_std        # m/s per horizontal axis for VTG/RMC velocity (NMEA: no accuracy)
    sigma_no_accuracy: float = _NMEA.sigma_no_accuracy  # m per horizontal axis of an RMC/GLL fix (no GGA, no GST)
    gga_timeout: float = _NMEA.gga_timeout  # s of receiver time: a GGA this recent makes GGA the only fix source;
    # without, fixes come from RMC/GLL status A (single), altitude = MSL with vertical variance 99999 m^2
    require_checksum: bool = _NMEA.require_checksum  # a sentence without *hh is treated as truncated
    gst_max_age: float = _NMEA.gst_max_age  # s of receiver time between a GST and the GGA whose covariance it gives
    fix_timeout: float = _NMEA.fix_timeout  # s of host time a valid fix keeps enabling /gnss/vel
    resync_after: int = _NMEA.resync_after  # consecutive backwards epochs accepted as a receiver clock reset


def parameter_entries():
    return stream_parameters(NmeaNodeSettings())


class NmeaGnssNode(StreamDriverNode):
    def __init__(self, **kwargs):
        super().__init__("nmea_gnss", "nmea_gnss", NmeaNodeSettings(), **kwargs)
        s = self.settings
        self.parser = NmeaParser(NmeaSettings(
            sigma_per_hdop={g.FIX_SINGLE: s.sigma_single, g.FIX_DGPS: s.sigma_dgps,
                            g.FIX_RTK_FLOAT: s.sigma_rtk_float, g.FIX_RTK_FIXED: s.sigma_rtk_fixed},
            vertical_factor=s.vertical_factor, velocity_std=s.velocity_std, sigma_no_accuracy=s.sigma_no_accuracy,
            gga_timeout=s.gga_timeout, require_checksum=s.require_checksum, gst_max_age=s.gst_max_age,
            fix_timeout=s.fix_timeout, resync_after=s.resync_after))
        self.gnss = GnssPublishers(self, s)
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
