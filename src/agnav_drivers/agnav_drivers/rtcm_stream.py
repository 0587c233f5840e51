"""RTCM3 byte stream -> base-station events (no ROS): frames found by the 0xD3 preamble and their 10-bit length,
checked with pyrtcm's CRC-24Q, parsed by pyrtcm and handed to `rtcm_raw.RtcmBase` (MSM4/5/7 epochs -> GnssObservations,
1005/1006 -> BasePosition).

* A candidate whose CRC fails (bit errors, a false preamble inside noise, a corrupt length) is counted and the search
  restarts one byte after its preamble: one bad length never swallows the good frames behind it.
* A frame with a valid CRC that pyrtcm cannot decode is counted (`parse_errors`), never raised.
* RTCM carries the time of week only: the week of each epoch is the one that puts it nearest to the host clock's GPS
  time (`nearest_week`), so a clock within a few days of the truth gives the right week, also at a week rollover.
  Before the clock is set (earlier than the GPS epoch, e.g. use_sim_time before the first /clock) epochs are counted
  (`no_clock`) and dropped.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field, replace

from pyrtcm import RTCMReader
from pyrtcm.rtcmhelpers import calc_crc24q

from .framing import skip_to_sync
from .gnss_types import GPS_EPOCH_UNIX, WEEK
from .rtcm_raw import RtcmBase
from .ubx import GnssObservations

PREAMBLE = b"\xd3"
GPS_UTC_LEAP = 18.0   # s, GPS - UTC since 2017-01-01 (only used to pick the week: any error << half a week)


def nearest_week(tow: float, unix_time: float) -> int:
    """GPS week that puts time of week `tow` nearest to the UTC time `unix_time`."""
    return round((unix_time - GPS_EPOCH_UNIX + GPS_UTC_LEAP - tow) / WEEK)


@dataclass
class RtcmCounters:
    frames: int = 0            # frames with a valid CRC
    crc_failures: int = 0      # candidates whose CRC-24Q failed
    parse_errors: int = 0      # valid frames pyrtcm could not decode
    noise_bytes: int = 0       # bytes outside any frame
    epochs: int = 0            # observation epochs emitted
    no_clock: int = 0          # epochs dropped: no clock to take the week from
    by_type: Counter = field(default_factory=Counter)   # message number -> frames
    last_problem: str = ""


class RtcmStream:
    """Feeds raw bytes, returns the events of the frames completed by them."""

    def __init__(self):
        self.base = RtcmBase()
        self.counters = RtcmCounters()
        self._buf = bytearray()

    def feed(self, data: bytes, host_time: float) -> list:
        """Events (GnssObservations with their week from `host_time`, a UTC unix time; BasePosition)."""
        buf, c, events = self._buf, self.counters, []
        buf += data
        while True:
            found, dropped = skip_to_sync(buf, PREAMBLE)
            c.noise_bytes += dropped
            if not found or len(buf) < 3:
                return events
            if buf[1] & 0xFC:                      # 6 reserved bits after the preamble are zero
                c.noise_bytes += 1
                del buf[:1]
                continue
            size = 6 + ((buf[1] & 0x03) << 8 | buf[2])
            if len(buf) < size:
                return events
            frame = bytes(buf[:size])
            if calc_crc24q(frame):
                c.crc_failures += 1
                c.last_problem = f"CRC-24Q failed ({size} B candidate)"
                c.noise_bytes += 1
                del buf[:1]
                continue
            del buf[:size]
            events += self._decode(frame, host_time)

    def _decode(self, frame: bytes, host_time: float) -> list:
        c = self.counters
        c.frames += 1
        try:
            msg = RTCMReader.parse(frame)
            c.by_type[str(msg.identity)] += 1
            events = self.base.feed(msg, 0, host_time)
        except Exception as exc:  # noqa: BLE001  (pyrtcm raises several types on a payload it cannot decode)
            c.parse_errors += 1
            c.last_problem = f"parse error: {exc}"
            return []
        out = []
        for e in events:
            if isinstance(e, GnssObservations):
                week = nearest_week(e.receiver_tow, host_time)
                if week < 0:
                    c.no_clock += 1
                    continue
                c.epochs += 1
                e = replace(e, week=week)
            out.append(e)
        return out
