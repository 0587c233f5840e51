"""Shared rclpy plumbing of the byte-stream drivers: link parameters, reader thread, link and
stream diagnostics, stamps. Subclasses implement `handle_bytes(data, host_time)` and give their parameters as a
StreamSettings subclass (agnav_common.parameters: declared once, described, read-only)."""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass

from rclpy.node import Node

from agnav_common.diagnostics import ERROR, OK, WARN, Diagnostics
from agnav_common.parameters import declare, leaves
from agnav_common.stamps import to_stamp

from .serial_link import OPEN, ByteLink, LinkSettings


STAMP_SOURCES = ("host", "receiver")
INTERNAL = ("read_size",)  # LinkSettings fields that are no parameters


@dataclass
class StreamSettings(LinkSettings):
    """Byte source of a driver: `port` (serial), else `host` + `tcp_port`, else `file`."""

    port: str = ""             # serial device, e.g. /dev/serial/by-id/usb-...; a pty /dev/pts/N works too
    baud: int = LinkSettings.baud  # bit/s of the serial port
    host: str = ""             # TCP client (e.g. a receiver's server or gpsd's raw port), used when port is empty
    tcp_port: int = 0          # TCP port of host
    file: str = ""             # replay a capture (used when port and host are empty), paced at file_rate
    file_rate: float = 0.0     # bytes/s of a file replay; 0 = baud / 10 (the serial speed)
    backoff_initial: float = LinkSettings.backoff_initial  # s before reopening an absent device; doubles
    backoff_max: float = LinkSettings.backoff_max          # s, cap of the doubling back-off
    stale_timeout: float = 2.0  # s without a valid message -> WARN on /diagnostics
    stamp_source: str = "host"  # host: receive time of the bytes | receiver: the receiver's time where known


def stream_parameters(settings: StreamSettings):
    """[(name, default, description)] of a driver's parameters (tools/gen_params.py)."""
    return leaves(settings, skip=INTERNAL)


class RateMeter:
    """Per-key rates (Hz) of monotonically growing counters between two calls."""

    def __init__(self):
        self._last: dict = {}
        self._t = time.monotonic()

    def rates(self, counts: dict) -> dict:
        now = time.monotonic()
        dt = max(now - self._t, 1e-6)
        out = {k: (v - self._last.get(k, 0)) / dt for k, v in counts.items()}
        self._last, self._t = dict(counts), now
        return out


class StreamDriverNode(Node):
    """Reads a ByteLink in a thread and hands bytes with their host receive time to the subclass."""

    link_class = ByteLink

    def __init__(self, name: str, hardware: str, settings: StreamSettings, **kwargs):
        super().__init__(name, **kwargs)
        self.settings = declare(self, settings, skip=INTERNAL)
        if self.settings.stamp_source not in STAMP_SOURCES:
            raise ValueError(f"stamp_source must be one of {STAMP_SOURCES}, not {self.settings.stamp_source!r}")
        self.link = self.link_class(self.settings)
        self.stale_timeout = self.settings.stale_timeout
        self.use_receiver_time = self.settings.stamp_source == "receiver"
        self.last_message_time: float | None = None   # time.monotonic() of the last decoded message
        self.published = 0
        self._rates = RateMeter()
        self._problems_seen = 0
        self.diagnostics = Diagnostics(self, f"{hardware} on {self.link.settings.describe}")  # hardware_id: the device
        self.diagnostics.add("link", self._link_check)
        self._running = True
        self._thread = threading.Thread(target=self._reader, name=f"{name}_reader", daemon=True)

    def start_reading(self):
        """Start the reader thread: the last step of a subclass's __init__ (handle_bytes needs its parser)."""
        if not (self.link.settings.port or self.link.settings.host or self.link.settings.file):
            self.get_logger().error("no source: set one of port, host+tcp_port or file")
        else:
            self.get_logger().info(f"reading {self.link.settings.describe}")
            self._thread.start()

    # ---- to implement --------------------------------------------------------------------------
    def handle_bytes(self, data: bytes, host_time: float) -> None:
        raise NotImplementedError

    # ---- helpers for subclasses ----------------------------------------------------------------
    def stamp(self, host_time: float, receiver_time: float | None = None):
        use = receiver_time if self.use_receiver_time and receiver_time is not None else host_time
        return to_stamp(use)

    def message_seen(self):
        self.last_message_time = time.monotonic()

    def stream_check(self, counters: dict, by_type: dict, problems: int, detail: dict):
        """Common stream diagnostic: rates, counters, last message age, stale warning."""
        age = None if self.last_message_time is None else time.monotonic() - self.last_message_time
        values = {f"rate_{k}": f"{v:.2f}" for k, v in self._rates.rates(by_type).items()}
        values.update(counters)
        values.update(detail)
        values["last_message_age"] = "never" if age is None else f"{age:.2f}"
        values["published"] = self.published
        if age is None or age > self.stale_timeout:
            return WARN, "stale: no valid message for %s s" % ("ever" if age is None else f"{age:.1f}"), values
        new_problems, self._problems_seen = problems - self._problems_seen, problems
        if new_problems:
            return WARN, f"{new_problems} new bad inputs (counted, skipped)", values
        return OK, "streaming", values

    # ---- internals -----------------------------------------------------------------------------
    def _link_check(self):
        status = self.link.status()
        if self.link.state != OPEN:
            return ERROR, f"{status['source']} {self.link.state}: {self.link.last_error}", status
        return OK, f"{status['source']} open", status

    def _reader(self):
        while self._running:
            data = self.link.read(0.1)
            if not data or not self._running:
                continue
            try:
                self.handle_bytes(data, self.get_clock().now().nanoseconds * 1e-9)
            except Exception as exc:  # a driver bug must show up on /diagnostics, not kill the thread
                if not (self._running and self.context.ok()):
                    return  # shutting down (context gone under us): stop quietly
                self.get_logger().error(f"driver error: {exc!r}", throttle_duration_sec=5.0)

    def destroy_node(self):
        """Stops the reader (it ends within one read timeout) before the port and the node go away."""
        self._running = False
        self.link.close()  # wakes the reader; closes the port once its read under way has returned
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)
        return super().destroy_node()
