"""u-blox UBX core (pyubx2): byte stream -> plain fix / velocity / status / attitude / raw
observation events (no ROS).

* NAV-PVT and NAV-PVAT -> GnssFixStatus, GnssFix (hAcc/vAcc covariance, carrSoln float/fixed),
  GnssVelocity (velN/E/D, sAcc); NAV-PVAT also vehicle attitude, NAV-PVT the vehicle heading.
* NAV-ATT -> GnssAttitude (one per iTOW together with NAV-PVAT); NAV-DOP -> HDOP for the status.
* ESF-STATUS -> EsfStatus; ESF-MEAS -> EsfMeasurement (scaled sensor data by u-blox data type).
* RXM-RAWX -> GnssObservations (per-signal pseudorange, carrier phase, Doppler, C/N0, lock time);
  RXM-SFRBX -> NavDataFrame (broadcast navigation data words).
Frames are found by sync chars and length; pyubx2 checks the checksum and decodes. Bad frames and
values are counted, never raised.
* A header is checked before its payload is awaited: the class must be a UBX class pyubx2 knows, a handled
  message must have its documented length (fixed, or base + items x count as soon as the count byte is in),
  any other message at most MAX_PAYLOAD bytes. A corrupt header is counted (`corrupt_frames`) and the
  search for the next sync starts right after it: one bad length never stalls the stream.
* Each frame carries the host time at which its last byte arrived, not that of the read that completed it.
* Every event passes gnss_types.Screen (physical limits, accuracy floors): implausible messages are dropped
  and counted (`implausible`), floored accuracies counted (`floored_accuracy`).
"""
from __future__ import annotations

import datetime as dt
from collections import deque
from dataclasses import dataclass, field

import pyubx2

from .framing import skip_to_sync
from .gnss_types import (COV_DIAGONAL_KNOWN, FIX_DEAD_RECKONING, FIX_DGPS, FIX_NONE, FIX_RTK_FIXED,
                         FIX_RTK_FLOAT, FIX_SINGLE, POSITION_FIX_TYPES, GnssAttitude, GnssFix, GnssFixStatus,
                         GnssVelocity, Limits, ReceiverTime, Screen, diag3, finite)

SYNC = b"\xb5\x62"
MAX_PAYLOAD = 4096  # bytes of a message without a length rule (real ones: NAV-SAT, RXM-MEASX <= ~1.5 kB)
UBX_CLASSES = {c[0] for c in pyubx2.UBX_CLASSES if c[0] < 0xF0}  # 0xF0.. are NMEA/RTCM ids in CFG-MSG only
# Payload length of the handled messages (u-blox interface descriptions): the set of fixed lengths, or
# (base, bytes per item, offset of the count byte in the payload, right shift of that byte, optional extra bytes).
PAYLOAD_RULES = {
    b"\x01\x07": frozenset({84, 92}),      # NAV-PVT (84 before protocol 15, u-blox 7)
    b"\x01\x17": frozenset({116}),         # NAV-PVAT
    b"\x01\x05": frozenset({32}),          # NAV-ATT
    b"\x01\x04": frozenset({18}),          # NAV-DOP
    b"\x10\x10": (16, 4, 15, 0, (0,)),      # ESF-STATUS: numSens
    b"\x10\x02": (8, 4, 5, 3, (0, 4)),      # ESF-MEAS: numMeas = flags bits 11-15, optional calibTtag
    b"\x02\x15": (16, 32, 11, 0, (0,)),     # RXM-RAWX: numMeas
    b"\x02\x13": (8, 4, 4, 0, (0,)),        # RXM-SFRBX: numWords
}
# NAV-PVT lastCorrectionAge code -> upper bound of the age range (s); 0 = not available.
CORRECTION_AGE = {1: 1, 2: 2, 3: 5, 4: 10, 5: 15, 6: 20, 7: 30, 8: 45, 9: 60, 10: 90, 11: 120, 12: 120}
# ESF-MEAS data types (u-blox interface description): name, scale of the signed 24-bit field.
ESF_TYPES = {5: ("gyro_z", 2 ** -12), 12: ("gyro_temp", 1e-2), 13: ("gyro_y", 2 ** -12),
             14: ("gyro_x", 2 ** -12), 16: ("accel_x", 2 ** -10), 17: ("accel_y", 2 ** -10),
             18: ("accel_z", 2 ** -10), 11: ("speed", 1e-3)}


@dataclass
class GnssObservation:
    gnss_id: int            # u-blox gnssId: 0 GPS, 1 SBAS, 2 Galileo, 3 BeiDou, 5 QZSS, 6 GLONASS
    sv_id: int
    sig_id: int             # u-blox sigId within the constellation (e.g. 0 = GPS L1C/A)
    freq_id: int            # GLONASS frequency slot + 7
    pseudorange: float      # m
    carrier_phase: float    # cycles (0 when not valid)
    doppler: float          # Hz
    cno: int                # dB-Hz
    lock_time: float        # s of continuous carrier tracking
    pseudorange_std: float  # m
    carrier_phase_std: float  # cycles
    doppler_std: float      # Hz
    pseudorange_valid: bool
    carrier_phase_valid: bool
    half_cycle_resolved: bool
    half_cycle_subtracted: bool


@dataclass
class GnssObservations:
    host_time: float
    receiver_tow: float     # s of GPS week
    week: int
    leap_seconds: int
    leap_seconds_known: bool
    clock_reset: bool
    observations: list


@dataclass
class NavDataFrame:
    host_time: float
    gnss_id: int
    sv_id: int
    sig_id: int
    freq_id: int
    words: list


@dataclass
class EsfStatus:
    host_time: float
    fusion_mode: int        # 0 init, 1 fusion, 2 suspended, 3 disabled
    sensors_used: int
    sensors: int


@dataclass
class EsfMeasurement:
    host_time: float
    time_tag: int           # ms, sensor time tag
    values: dict            # name -> SI-ish value (deg/s, m/s^2, deg C, m/s)


@dataclass
class UbxCounters:
    frames: int = 0
    accepted: int = 0
    ignored: int = 0
    checksum_failures: int = 0
    parse_errors: int = 0
    rejected: int = 0
    corrupt_frames: int = 0          # headers with an unknown class or an impossible length
    implausible: int = 0             # messages with values outside gnss_types.Limits (part of `rejected`)
    floored_accuracy: int = 0        # messages with an accuracy raised to the floor (published)
    noise_bytes: int = 0
    last_problem: str = ""
    by_type: dict = field(default_factory=dict)


def _signed24(value: int) -> int:
    return value - (1 << 24) if value & 0x800000 else value


def header_problem(head: bytes) -> str | None:
    """Why the start of a frame (sync, class, id, length, payload so far) cannot be a real frame, or None."""
    if len(head) < 6:
        return None
    cls_id, length = bytes(head[2:4]), int.from_bytes(head[4:6], "little")
    if head[2] not in UBX_CLASSES:
        return f"unknown class 0x{head[2]:02x}"
    rule = PAYLOAD_RULES.get(cls_id)
    if rule is None:
        return f"length {length}" if length > MAX_PAYLOAD else None
    if isinstance(rule, frozenset):
        return None if length in rule else f"length {length} of {pyubx2.UBX_MSGIDS[cls_id]}"
    base, per_item, offset, shift, extras = rule
    if len(head) <= 6 + offset:
        return None if length >= base else f"length {length} of {pyubx2.UBX_MSGIDS[cls_id]}"
    items = head[6 + offset] >> shift
    if any(length == base + per_item * items + extra for extra in extras):
        return None
    return f"length {length} of {pyubx2.UBX_MSGIDS[cls_id]} with {items} items"


class UbxParser:
    """Incremental UBX decoder: feed(bytes, host_time) -> list of events."""

    def __init__(self, limits: Limits | None = None):
        self.counters = UbxCounters()
        self._buf = bytearray()
        self._start = 0                  # stream offset of _buf[0]
        self._arrivals = deque()         # (stream offset after a read's last byte, host time of that read)
        self._scan = 0                   # where _frame_inside resumes in _buf
        self._screen = Screen(limits)
        self._hdop: float | None = None
        self._attitude_tow: float | None = None
        self._handlers = {"NAV-PVT": self._pvt, "NAV-PVAT": self._pvt, "NAV-ATT": self._att,
                          "NAV-DOP": self._dop, "ESF-STATUS": self._esf_status, "ESF-MEAS": self._esf_meas,
                          "RXM-RAWX": self._rawx, "RXM-SFRBX": self._sfrbx}

    def feed(self, data: bytes, host_time: float) -> list:
        buf, c, events = self._buf, self.counters, []
        buf += data
        self._arrivals.append((self._start + len(buf), host_time))
        while True:
            found, dropped = skip_to_sync(buf, SYNC)
            c.noise_bytes += dropped
            self._consumed(dropped)
            if not found or len(buf) < 6:
                return events
            problem = header_problem(buf[:6 + 16])
            if problem is not None:
                c.corrupt_frames += 1
                c.last_problem = problem
                self._drop(2)  # hunt for the next sync right after this one
                continue
            length = int.from_bytes(buf[4:6], "little")
            if len(buf) < 8 + length:
                if not self._frame_inside(length):
                    return events
                c.corrupt_frames += 1  # a whole valid frame lies inside the awaited payload
                c.last_problem = f"length {length}: next frame inside"
                self._drop(2)
                continue
            frame = bytes(buf[:8 + length])
            if not pyubx2.isvalid_checksum(frame):
                c.checksum_failures += 1
                c.last_problem = "checksum"
                self._drop(2)  # the sync may have been inside noise: hunt again just after it
                continue
            arrival = self._arrival(8 + length)
            self._drop(8 + length)
            c.frames += 1
            events += self._frame(frame, arrival)

    def _frame_inside(self, length: int) -> bool:
        """True when a complete frame with a valid checksum starts inside the awaited frame: its header
        (length) was corrupt. Scans each buffered byte once."""
        buf, i, pending = self._buf, max(self._scan, 2), None
        while (i := buf.find(SYNC, i)) >= 0 and len(buf) - i >= 6:
            if header_problem(buf[i:i + 22]) is None:
                end = i + 8 + int.from_bytes(buf[i + 4:i + 6], "little")
                if end > len(buf):
                    pending = i if pending is None else pending  # look at it again once it is complete
                elif end <= 8 + length and pyubx2.isvalid_checksum(bytes(buf[i:end])):
                    return True
            i += 1
        self._scan = pending if pending is not None else len(buf) - 1 if i < 0 else i
        return False

    def _arrival(self, size: int) -> float:
        """Host time of the read that brought the byte `size` - 1 of the buffer."""
        last = self._start + size
        return next(t for end, t in self._arrivals if end >= last)

    def _drop(self, n: int):
        del self._buf[:n]
        self._consumed(n)

    def _consumed(self, n: int):
        if n:
            self._start += n
            self._scan = 0
        while self._arrivals and self._arrivals[0][0] <= self._start and len(self._arrivals) > 1:
            self._arrivals.popleft()

    def _frame(self, frame: bytes, host_time: float) -> list:
        c = self.counters
        try:
            msg = pyubx2.UBXReader.parse(frame, validate=pyubx2.VALCKSUM)
        except (pyubx2.UBXParseError, pyubx2.UBXMessageError, pyubx2.UBXTypeError, ValueError, KeyError,
                IndexError, TypeError) as exc:
            c.parse_errors += 1
            c.last_problem = f"decode: {exc}"
            return []
        handler = self._handlers.get(msg.identity)
        if handler is None:
            c.ignored += 1
            return []
        try:
            events = handler(msg, host_time)
        except ValueError as exc:
            c.rejected += 1
            c.last_problem = f"{msg.identity}: {exc}"
            return []
        except (AttributeError, TypeError, OverflowError) as exc:
            c.parse_errors += 1
            c.last_problem = f"{msg.identity}: {exc}"
            return []
        events, problem = self._screen(events)
        if problem is not None and not events:
            c.rejected += 1
            c.implausible += 1
            c.last_problem = f"{msg.identity}: {problem}"
            return []
        if problem is not None:
            c.floored_accuracy += 1
            c.last_problem = f"{msg.identity}: {problem}"
        c.accepted += 1
        c.by_type[msg.identity] = c.by_type.get(msg.identity, 0) + 1
        return events

    # ---- navigation solution -------------------------------------------------------------------
    @staticmethod
    def _utc(msg) -> float | None:
        if not (msg.validDate and msg.validTime and msg.fullyResolved):
            return None
        second = getattr(msg, "second", None)
        second = msg.sec if second is None else second
        t = dt.datetime(msg.year, msg.month, msg.day, msg.hour, msg.min, second, tzinfo=dt.timezone.utc)
        return t.timestamp() + msg.nano * 1e-9

    @staticmethod
    def _fix_type(msg) -> int:
        fix_ok = getattr(msg, "gnssFixOk", getattr(msg, "gnssFixOK", 0))
        if msg.fixType == 1:
            return FIX_DEAD_RECKONING
        if not fix_ok or msg.fixType not in (2, 3, 4):
            return FIX_NONE
        if msg.carrSoln == 2:
            return FIX_RTK_FIXED
        if msg.carrSoln == 1:
            return FIX_RTK_FLOAT
        return FIX_DGPS if msg.diffSoln else FIX_SINGLE

    def _pvt(self, msg, host_time: float) -> list:
        rt = self._utc(msg)
        fix_type = self._fix_type(msg)
        age = CORRECTION_AGE.get(getattr(msg, "lastCorrectionAge", 0), -1.0)
        events = [GnssFixStatus(host_time, rt, fix_type, msg.numSV,
                                -1.0 if self._hdop is None else self._hdop, float(age))]
        if rt is not None:
            events.append(ReceiverTime(host_time, rt, msg.identity))
        if fix_type in POSITION_FIX_TYPES and not getattr(msg, "invalidLlh", 0):
            lat, lon, h = msg.lat, msg.lon, msg.height * 1e-3
            h_acc, v_acc = msg.hAcc * 1e-3, msg.vAcc * 1e-3
            events.append(GnssFix(host_time, rt, lat, lon, h, fix_type,
                                  diag3(h_acc ** 2, h_acc ** 2, v_acc ** 2), COV_DIAGONAL_KNOWN))
            s_acc = msg.sAcc * 1e-3
            events.append(GnssVelocity(host_time, rt, msg.velE * 1e-3, msg.velN * 1e-3, -msg.velD * 1e-3,
                                       diag3(s_acc ** 2, s_acc ** 2, s_acc ** 2)))
        if msg.identity == "NAV-PVAT" and msg.vehHeadingValid:
            events += self._attitude(host_time, rt, msg.iTOW, msg.vehHeading, msg.accHeading,
                                     msg.vehRoll if msg.vehRollValid else None,
                                     msg.vehPitch if msg.vehPitchValid else None, msg.accRoll, msg.accPitch)
        elif msg.identity == "NAV-PVT" and msg.headVehValid:
            events += self._attitude(host_time, rt, msg.iTOW, msg.headVeh, msg.headAcc)
        return events

    def _attitude(self, host_time, rt, tow, heading, heading_acc, roll=None, pitch=None, roll_acc=None,
                  pitch_acc=None) -> list:
        if tow == self._attitude_tow:
            return []  # NAV-ATT and NAV-PVAT of one epoch
        if not finite(heading) or not (roll is None or finite(roll)) or not (pitch is None or finite(pitch)):
            raise ValueError("non-finite attitude")
        self._attitude_tow = tow
        return [GnssAttitude(host_time, rt, heading % 360.0, heading_acc, roll, pitch,
                             roll_acc if roll is not None else None, pitch_acc if pitch is not None else None)]

    def _att(self, msg, host_time: float) -> list:
        return self._attitude(host_time, None, msg.iTOW, msg.heading, msg.accHeading, msg.roll, msg.pitch,
                              msg.accRoll, msg.accPitch)

    def _dop(self, msg, host_time: float) -> list:
        self._hdop = msg.hDOP if finite(msg.hDOP) and 0 < msg.hDOP < 100 else None
        return []

    # ---- sensor fusion -------------------------------------------------------------------------
    def _esf_status(self, msg, host_time: float) -> list:
        used = sum(getattr(msg, f"used_{i:02d}", 0) for i in range(1, msg.numSens + 1))
        return [EsfStatus(host_time, msg.fusionMode, used, msg.numSens)]

    def _esf_meas(self, msg, host_time: float) -> list:
        values = {}
        for i in range(1, msg.numMeas + 1):
            kind = ESF_TYPES.get(getattr(msg, f"dataType_{i:02d}"))
            if kind is not None:
                values[kind[0]] = _signed24(getattr(msg, f"dataField_{i:02d}")) * kind[1]
        return [EsfMeasurement(host_time, msg.timeTag, values)] if values else []

    # ---- raw measurements ----------------------------------------------------------------------
    def _rawx(self, msg, host_time: float) -> list:
        obs = []
        for i in range(1, msg.numMeas + 1):
            g = lambda name: getattr(msg, f"{name}_{i:02d}")  # noqa: E731
            pr, cp, do = g("prMes"), g("cpMes"), g("doMes")
            if not finite(pr, cp, do):
                raise ValueError(f"non-finite measurement of sv {g('svId')}")
            obs.append(GnssObservation(
                g("gnssId"), g("svId"), g("sigId"), g("freqId"), pr, cp if g("cpValid") else 0.0, do, g("cno"),
                g("locktime") * 1e-3, 0.01 * 2 ** g("prStd"), 0.004 * g("cpStd"), 0.002 * 2 ** g("doStd"),
                bool(g("prValid")), bool(g("cpValid")), bool(g("halfCyc")), bool(g("subHalfCyc"))))
        if not (finite(msg.rcvTow) and 0 <= msg.rcvTow < 604800.5):
            raise ValueError(f"receiver tow {msg.rcvTow}")
        return [GnssObservations(host_time, msg.rcvTow, msg.week, msg.leapS, bool(msg.leapSec),
                                 bool(msg.clkReset), obs)]

    def _sfrbx(self, msg, host_time: float) -> list:
        words = [getattr(msg, f"dwrd_{i:02d}") for i in range(1, msg.numWords + 1)]
        return [NavDataFrame(host_time, msg.gnssId, msg.svId, getattr(msg, "sigId", 0), msg.freqId, words)]

