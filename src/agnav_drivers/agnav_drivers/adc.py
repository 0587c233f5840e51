"""Microcontroller ADC frames -> physical quantities of the thesis' analog sensors (no ROS).

Frame format (binary mode, preferred), little-endian:

    offset  size  field
    0       2     sync 0xA5 0x5A
    2       1     N = payload length in bytes (5 + 2 x channels)
    3       1     seq: frame counter, wraps at 256 (gaps = dropped frames)
    4       4     t_us: MCU sample time in microseconds, uint32, wraps
    8       2xK   K raw ADC codes, uint16
    3+N     2     CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) over bytes 2 .. 3+N-1

CSV line mode (second option): one line per sample, `seq,t_us,code0,code1,...` + CR/LF.
Volts = code x vref / 2^bits.

Conversions (channel roles in AdcSettings.channels):
* vibratory gyro: omega = K (V_out - V_static)  (SPEC eq 3.8), K in (deg/s)/V, V_static = mean of
  N standstill samples (thesis: 1000) measured on start and on request;
* inclinometer: angle = (V - V0) / sensitivity  (D5R: 0.1 V/deg), then a sign per axis to REP-103;
* fluxgate GDS: B = (V - V_zero) x 250 mG/V (FGM-200A) -> tesla (1 mG = 1e-7 T);
* accelerometer (optional): a = (V - V_zero) x scale (m/s^2)/V.
"""
from __future__ import annotations

import binascii
import math
import struct
from dataclasses import dataclass, field

import numpy as np

from .framing import LineSplitter, skip_to_sync

SYNC = b"\xa5\x5a"
HEADER = struct.Struct("<BI")   # seq, t_us
GYRO = ("gyro_x", "gyro_y", "gyro_z")
ACCEL = ("accel_x", "accel_y", "accel_z")
MAG = ("mag_x", "mag_y", "mag_z")
INCL = ("incl_roll", "incl_pitch")
TESLA_PER_MILLIGAUSS = 1e-7


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE."""
    return binascii.crc_hqx(data, 0xFFFF)


def encode_frame(seq: int, t_us: int, codes) -> bytes:
    """Binary frame as the microcontroller sends it (used by tests, benchmarks and firmware docs)."""
    body = bytes([5 + 2 * len(codes)]) + HEADER.pack(seq & 0xFF, t_us & 0xFFFFFFFF) + struct.pack(
        f"<{len(codes)}H", *codes)
    return SYNC + body + struct.pack("<H", crc16(body))


@dataclass
class AdcFrame:
    seq: int
    t_us: int
    codes: tuple


@dataclass
class AdcCounters:
    frames: int = 0
    crc_failures: int = 0
    parse_errors: int = 0
    rejected: int = 0              # wrong channel count, codes out of range
    dropped_frames: int = 0        # sequence gaps
    noise_bytes: int = 0           # bytes skipped while hunting for sync
    last_problem: str = ""


class AdcDecoder:
    """Byte stream -> AdcFrame list; mode 'binary' or 'csv'."""

    def __init__(self, mode: str = "binary"):
        if mode not in ("binary", "csv"):
            raise ValueError(f"unknown ADC frame mode {mode!r}")
        self.mode = mode
        self.counters = AdcCounters()
        self._buf = bytearray()
        self._lines = LineSplitter(256)
        self._last_seq: int | None = None

    def feed(self, data: bytes) -> list[AdcFrame]:
        frames = self._binary(data) if self.mode == "binary" else self._csv(data)
        for frame in frames:
            if self._last_seq is not None:
                self.counters.dropped_frames += (frame.seq - self._last_seq - 1) % 256
            self._last_seq = frame.seq
        self.counters.frames += len(frames)
        return frames

    def _binary(self, data: bytes) -> list[AdcFrame]:
        buf, c, out = self._buf, self.counters, []
        buf += data
        while True:
            found, dropped = skip_to_sync(buf, SYNC)
            c.noise_bytes += dropped
            if not found:
                return out
            if len(buf) < 3:
                return out
            n = buf[2]
            if n < HEADER.size or (n - HEADER.size) % 2:
                c.parse_errors += 1
                c.last_problem = f"bad length {n}"
                del buf[:2]
                continue
            if len(buf) < 5 + n:
                return out
            body = bytes(buf[2:3 + n])
            if struct.unpack_from("<H", buf, 3 + n)[0] != crc16(body):
                c.crc_failures += 1
                c.last_problem = "crc"
                del buf[:2]  # resynchronise inside the bad frame
                continue
            seq, t_us = HEADER.unpack_from(body, 1)
            out.append(AdcFrame(seq, t_us, struct.unpack_from(f"<{(n - HEADER.size) // 2}H", body, 1 + HEADER.size)))
            del buf[:5 + n]

    def _csv(self, data: bytes) -> list[AdcFrame]:
        out = []
        for line in self._lines.feed(data):
            try:
                fields = [int(x) for x in line.decode("ascii").split(",")]
                if len(fields) < 3 or not 0 <= fields[0] < 256 or not 0 <= fields[1] < 2 ** 32:
                    raise ValueError("needs seq,t_us,code...")
            except (UnicodeDecodeError, ValueError) as exc:
                self.counters.parse_errors += 1
                self.counters.last_problem = f"csv: {exc}"
                continue
            out.append(AdcFrame(fields[0], fields[1], tuple(fields[2:])))
        self.counters.noise_bytes = self._lines.dropped_bytes
        return out


@dataclass
class AdcSettings:
    vref: float = 5.0                      # V at full scale
    bits: int = 16
    channels: list = field(default_factory=lambda: list(GYRO + INCL + MAG))  # role of each code, "" = unused
    gyro_scale: tuple = (40.0, 40.0, 40.0)          # K of eq 3.8, (deg/s)/V (ENV-05F-03: 25 mV/(deg/s))
    static_samples: int = 1000                      # thesis: mean of 1000 samples at rest
    static_max_std: float = 0.02                    # V; a noisier window means "not at standstill"
    incl_zero: tuple = (2.5, 2.5)                   # V0 (D5R: 2.5 V at 0 deg)
    incl_sensitivity: tuple = (0.1, 0.1)            # V/deg (D5R: 100 mV/deg)
    incl_sign: tuple = (1.0, -1.0)                  # thesis (pitch nose up) -> REP-103 (nose down)
    mag_zero: tuple = (2.5, 2.5, 2.5)               # V at zero field (bipolar output level-shifted)
    mag_scale: tuple = (250.0, 250.0, 250.0)        # mG/V (FGM-200A)
    accel_zero: tuple = (2.5, 2.5, 2.5)             # V
    accel_scale: tuple = (9.80665, 9.80665, 9.80665)  # (m/s^2)/V


@dataclass
class AdcReading:
    seq: int
    t_us: int
    gyro: np.ndarray | None = None         # rad/s, sensor axes; None until V_static is known
    accel: np.ndarray | None = None        # m/s^2
    roll: float | None = None              # rad, REP-103
    pitch: float | None = None
    mag: np.ndarray | None = None          # tesla


class StaticCalibrator:
    """V_static (eq 3.8) = mean of N consecutive samples at standstill; a window whose standard
    deviation exceeds max_std (vehicle moving) is discarded and collection starts again."""

    def __init__(self, samples: int, max_std: float):
        self.samples, self.max_std = samples, max_std
        self.collecting = False
        self.rejected_windows = 0
        self.last_std: float | None = None
        self._window: list = []

    def start(self):
        self.collecting, self._window = True, []

    def add(self, volts: np.ndarray) -> np.ndarray | None:
        """Feed one sample; returns V_static when a full still window completes."""
        if not self.collecting:
            return None
        self._window.append(volts)
        if len(self._window) < self.samples:
            return None
        window = np.asarray(self._window)
        self._window = []
        self.last_std = float(window.std(axis=0).max())
        if self.last_std > self.max_std:
            self.rejected_windows += 1
            return None
        self.collecting = False
        return window.mean(axis=0)


class AdcConverter:
    """AdcFrame -> AdcReading with the thesis' conversions; starts a V_static calibration at once."""

    def __init__(self, settings: AdcSettings | None = None):
        self.settings = s = settings or AdcSettings()
        roles = list(s.channels)
        self._idx = {name: roles.index(name) for name in GYRO + ACCEL + MAG + INCL if name in roles}
        self.has_gyro = all(n in self._idx for n in GYRO)
        self.has_accel = all(n in self._idx for n in ACCEL)
        self.has_mag = all(n in self._idx for n in MAG)
        self.has_incl = all(n in self._idx for n in INCL)
        self.rejected = 0
        self.last_problem = ""
        self.v_static: np.ndarray | None = None
        self.calibrator = StaticCalibrator(s.static_samples, s.static_max_std)
        if self.has_gyro:
            self.calibrator.start()

    def request_calibration(self) -> bool:
        """Re-measure V_static over the next N samples (vehicle must stand still)."""
        if not self.has_gyro:
            return False
        self.calibrator.start()
        return True

    def _pick(self, volts: np.ndarray, names) -> np.ndarray:
        return volts[[self._idx[n] for n in names]]

    def convert(self, frame: AdcFrame) -> AdcReading | None:
        s = self.settings
        codes = np.asarray(frame.codes, dtype=float)
        if len(codes) != len(s.channels) or codes.max(initial=0) >= 2 ** s.bits:
            self.rejected += 1
            self.last_problem = f"frame with {len(codes)} codes, max {codes.max(initial=0):.0f}"
            return None
        volts = codes * (s.vref / 2 ** s.bits)
        out = AdcReading(frame.seq, frame.t_us)
        if self.has_gyro:
            v_gyro = self._pick(volts, GYRO)
            v_static = self.calibrator.add(v_gyro)
            if v_static is not None:
                self.v_static = v_static
            if self.v_static is not None:
                out.gyro = np.radians(np.asarray(s.gyro_scale) * (v_gyro - self.v_static))  # eq 3.8
        if self.has_accel:
            out.accel = np.asarray(s.accel_scale) * (self._pick(volts, ACCEL) - np.asarray(s.accel_zero))
        if self.has_incl:
            deg = (self._pick(volts, INCL) - np.asarray(s.incl_zero)) / np.asarray(s.incl_sensitivity)
            out.roll, out.pitch = (math.radians(a) for a in deg * np.asarray(s.incl_sign))
        if self.has_mag:
            out.mag = (self._pick(volts, MAG) - np.asarray(s.mag_zero)) * np.asarray(s.mag_scale) * TESLA_PER_MILLIGAUSS
        return out
