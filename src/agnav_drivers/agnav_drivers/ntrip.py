"""NTRIP client connection for ByteLink (no ROS): a TCP connection that first requests a caster's mountpoint.

`GET /mountpoint` with `Ntrip-Version: Ntrip/2.0` (version 2, HTTP/1.1) or none (version 1, HTTP/1.0), basic
authentication when a user is set. Accepted answers: `ICY 200 OK` (version 1: data follows the status line) and
`HTTP/1.x 200` (version 2: data after the headers, de-chunked when `Transfer-Encoding: chunked`). Anything else
(401, 404, a SOURCETABLE because the mountpoint is unknown) fails the open with the caster's status line, so that
ByteLink retries with its back-off and shows it on /diagnostics. Without a mountpoint it is a plain TCP client.
"""
from __future__ import annotations

import base64
from dataclasses import dataclass, field

from agnav_common.parameters import bounded

from .serial_link import ByteLink, LinkSettings, TcpConnection

MAX_HEADER = 8192   # bytes of a caster's answer before the data


@dataclass
class NtripSettings(LinkSettings):
    mountpoint: str = ""       # NTRIP mountpoint at host:tcp_port (empty: plain TCP stream, no request)
    ntrip_user: str = ""       # NTRIP basic-auth user (empty: no Authorization header)
    ntrip_password: str = ""   # NTRIP basic-auth password
    ntrip_version: int = field(default=2, metadata=bounded(1, 2))  # NTRIP protocol version of the request: 1 or 2

    @property
    def describe(self) -> str:
        if self.host and self.mountpoint:
            return f"ntrip {self.host}:{self.tcp_port}/{self.mountpoint}"
        return super().describe


def ntrip_request(s: NtripSettings) -> bytes:
    lines = [f"GET /{s.mountpoint} HTTP/{'1.1' if s.ntrip_version == 2 else '1.0'}", f"Host: {s.host}:{s.tcp_port}",
             "User-Agent: NTRIP agnav/0.1"]
    if s.ntrip_version == 2:
        lines.append("Ntrip-Version: Ntrip/2.0")
    if s.ntrip_user:
        token = base64.b64encode(f"{s.ntrip_user}:{s.ntrip_password}".encode()).decode()
        lines.append(f"Authorization: Basic {token}")
    lines.append("Connection: close")
    return ("\r\n".join(lines) + "\r\n\r\n").encode()


class Dechunker:
    """HTTP/1.1 chunked transfer decoding of a byte stream fed in pieces."""

    def __init__(self):
        self._buf = bytearray()
        self._left = 0      # data bytes still due in the current chunk

    def feed(self, data: bytes) -> bytes:
        buf, out = self._buf, bytearray()
        buf += data
        while buf:
            if self._left:
                take = bytes(buf[:self._left])
                out += take
                del buf[:len(take)]
                self._left -= len(take)
                continue
            end = buf.find(b"\r\n")
            if end < 0:
                if len(buf) > 64:
                    raise ConnectionError("NTRIP: bad chunk header")
                break
            line = bytes(buf[:end]).split(b";")[0].strip()
            del buf[:end + 2]
            if not line:
                continue    # the CRLF that closes a chunk's data
            try:
                self._left = int(line, 16)
            except ValueError:
                raise ConnectionError(f"NTRIP: bad chunk size {line[:16]!r}") from None
            if self._left == 0:
                raise ConnectionError("NTRIP: caster ended the stream")
        return bytes(out)


class NtripConnection(TcpConnection):
    def __init__(self, s: NtripSettings):
        super().__init__(s)
        self._pending, self._chunks = b"", None
        if s.mountpoint:
            try:
                self._handshake(s)
            except OSError:
                self.close()
                raise

    def _handshake(self, s: NtripSettings):
        self._sock.sendall(ntrip_request(s))
        head = b""
        while not (head.startswith(b"ICY") and b"\r\n" in head) and b"\r\n\r\n" not in head:
            data = self._sock.recv(1024)
            if not data or len(head) > MAX_HEADER:
                raise ConnectionError(f"NTRIP: no answer from the caster: {head[:80]!r}")
            head += data
        status = head.split(b"\r\n", 1)[0].decode("latin-1")
        if status.startswith("ICY 200"):
            self._pending = head.split(b"\r\n", 1)[1]
            return
        if not (status.startswith("HTTP/1.") and status.split(" ")[1:2] == ["200"]):
            raise ConnectionError(f"NTRIP caster refused /{s.mountpoint}: {status}")
        headers, self._pending = head.split(b"\r\n\r\n", 1)
        if b"transfer-encoding: chunked" in headers.lower():
            self._chunks = Dechunker()

    def read(self, timeout: float, size: int) -> bytes:
        data, self._pending = self._pending or super().read(timeout, size), b""
        return self._chunks.feed(data) if self._chunks else data


class NtripLink(ByteLink):
    """ByteLink whose TCP source may be an NTRIP caster (NtripSettings.mountpoint)."""

    tcp_class = NtripConnection
