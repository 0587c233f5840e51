"""Byte source for drivers: serial port (pyserial), TCP client or file replay, with reconnect (no ROS).

`ByteLink.read(timeout)` never raises and never spins: while the device is absent it sleeps
until the next open attempt (exponential back-off from backoff_initial to backoff_max), and
`state` / `status()` say what is going on for diagnostics. `close()` may come from another thread while
a read is under way: it wakes the read and closes the source only after that read has returned.
"""
from __future__ import annotations

import socket
import threading
import time
from dataclasses import dataclass

import serial

CLOSED, OPEN, BACKOFF, EOF = "closed", "open", "backoff", "eof"


@dataclass
class LinkSettings:
    port: str = ""                   # serial device, e.g. /dev/ttyUSB0 or a pty /dev/pts/N
    baud: int = 9600
    host: str = ""                   # TCP client (used when port is empty)
    tcp_port: int = 0
    file: str = ""                   # replay (used when port and host are empty)
    file_rate: float = 0.0           # bytes/s for file replay; 0 = baud / 10 (serial speed)
    backoff_initial: float = 0.1     # s before the first reopen attempt
    backoff_max: float = 2.0         # s, cap of the doubling back-off
    read_size: int = 4096

    @property
    def describe(self) -> str:
        if self.port:
            return f"serial {self.port} @ {self.baud}"
        if self.host:
            return f"tcp {self.host}:{self.tcp_port}"
        return f"file {self.file}"


class _Serial:
    def __init__(self, s: LinkSettings):
        self._dev = serial.Serial(s.port, s.baud, timeout=0.1, exclusive=True)

    def read(self, timeout: float, size: int) -> bytes:
        self._dev.timeout = timeout
        first = self._dev.read(1)  # blocks until data or timeout; raises SerialException on unplug
        return first + self._dev.read(min(self._dev.in_waiting, size)) if first else b""

    def close(self):
        self._dev.close()


class TcpConnection:
    def __init__(self, s: LinkSettings):
        self._sock = socket.create_connection((s.host, s.tcp_port), timeout=2.0)

    def read(self, timeout: float, size: int) -> bytes:
        self._sock.settimeout(timeout)
        try:
            data = self._sock.recv(size)
        except socket.timeout:
            return b""
        if not data:
            raise ConnectionError("peer closed the connection")
        return data

    def close(self):
        self._sock.close()


class _File:
    """Replays a file at a byte rate so that a capture arrives as it would over the wire."""

    def __init__(self, s: LinkSettings, wait):
        self._f = open(s.file, "rb")
        self._rate = s.file_rate or s.baud / 10.0
        self._wait = wait
        self._last = time.monotonic()
        self.at_end = False

    def read(self, timeout: float, size: int) -> bytes:
        self._wait(timeout if self.at_end else min(timeout, 0.02))
        now = time.monotonic()
        n = max(1, min(size, int(self._rate * (now - self._last))))
        self._last = now
        data = self._f.read(n)
        self.at_end = not data
        return data

    def close(self):
        self._f.close()


class ByteLink:
    tcp_class = TcpConnection            # connection for host + tcp_port (a subclass may handshake, e.g. NTRIP)

    def __init__(self, settings: LinkSettings):
        self.settings = settings
        self.state = CLOSED
        self.last_error = ""
        self.opens = 0                   # successful opens (1 + reconnects)
        self.open_failures = 0
        self.disconnects = 0
        self.bytes_read = 0
        self.last_data_time: float | None = None   # time.monotonic() of the latest byte
        self._conn = None
        self._backoff = settings.backoff_initial
        self._next_attempt = 0.0
        self._stop = threading.Event()
        self._io = threading.RLock()     # held by a read (at most its timeout) and by close()

    def status(self) -> dict:
        return {"source": self.settings.describe, "state": self.state, "opens": self.opens,
                "open_failures": self.open_failures, "disconnects": self.disconnects,
                "bytes_read": self.bytes_read, "last_error": self.last_error}

    def read(self, timeout: float = 0.1) -> bytes:
        """Bytes that arrived within `timeout` s (possibly none); reopens the source when due."""
        with self._io:
            if self._stop.is_set():
                return b""
            if self._conn is None and not self._open():
                return b""
            try:
                data = self._conn.read(timeout, self.settings.read_size)
            except (OSError, serial.SerialException, ConnectionError) as exc:
                self._drop(f"read failed: {exc}")
                return b""
            if data:
                self.bytes_read += len(data)
                self.last_data_time = time.monotonic()
            elif isinstance(self._conn, _File) and self._conn.at_end:
                self.state = EOF
            return data

    def _open(self) -> bool:
        wait = self._next_attempt - time.monotonic()
        if wait > 0:
            self._stop.wait(min(wait, 0.5))
            if time.monotonic() < self._next_attempt:
                return False
        s = self.settings
        try:
            if s.port:
                self._conn = _Serial(s)
            elif s.host:
                self._conn = self.tcp_class(s)
            else:
                self._conn = _File(s, self._stop.wait)
        except (OSError, ValueError, serial.SerialException) as exc:
            self.open_failures += 1
            self.last_error = f"open failed: {exc}"
            self._schedule_retry()
            return False
        self.state = OPEN
        self.opens += 1
        self._backoff = s.backoff_initial
        return True

    def _schedule_retry(self):
        self.state = BACKOFF
        self._next_attempt = time.monotonic() + self._backoff
        self._backoff = min(2.0 * self._backoff, self.settings.backoff_max)

    def _drop(self, reason: str):
        self.last_error = reason
        self.disconnects += 1
        self._close_conn()
        self._backoff = self.settings.backoff_initial
        self._schedule_retry()

    def _close_conn(self):
        if self._conn is not None:
            try:
                self._conn.close()
            except (OSError, serial.SerialException):
                pass
            self._conn = None

    def close(self):
        """Stops the link for good: wakes a sleeping read, waits for a read under way, closes the source."""
        self._stop.set()
        with self._io:
            self._close_conn()
            self.state = CLOSED
