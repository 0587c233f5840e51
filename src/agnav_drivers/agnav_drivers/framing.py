"""Byte-stream framing: lines for text protocols (NMEA, ADC CSV), sync hunting for binary ones; no ROS."""
from __future__ import annotations

import re

_EOL = re.compile(rb"[\r\n]+")


class LineSplitter:
    """Splits a byte stream on CR/LF; a run longer than max_len without a line end is dropped.

    `dropped_bytes` counts what was thrown away (binary noise, overlong runs).
    """

    def __init__(self, max_len: int = 256):
        self.max_len = max_len
        self.dropped_bytes = 0
        self._buf = bytearray()

    def feed(self, data: bytes) -> list[bytes]:
        buf = self._buf
        buf += data
        lines = []
        end = max(buf.rfind(b"\n"), buf.rfind(b"\r"))
        if end >= 0:
            for line in _EOL.split(bytes(buf[:end])):
                if len(line) <= self.max_len:
                    if line:
                        lines.append(line)
                else:
                    self.dropped_bytes += len(line)
            del buf[:end + 1]
        if len(buf) > self.max_len:
            self.dropped_bytes += len(buf)
            buf.clear()
        return lines


def skip_to_sync(buf: bytearray, sync: bytes) -> tuple[bool, int]:
    """Drop the bytes before the next `sync` in `buf`, keeping a partial sync at its end: (found, dropped)."""
    start = buf.find(sync)
    if start >= 0:
        del buf[:start]
        return True, start
    keep = next((k for k in range(len(sync) - 1, 0, -1) if buf.endswith(sync[:k])), 0)
    dropped = len(buf) - keep
    del buf[:dropped]
    return False, dropped
