"""ByteLink over real pseudo-terminals, TCP and files: data, unplug/replug recovery, no busy loop."""
import socket
import threading
import time

import pytest

from agnav_drivers.pty_device import PtyDevice
from agnav_drivers.serial_link import BACKOFF, EOF, OPEN, ByteLink, LinkSettings


def read_until(link, n, deadline=5.0):
    out, end = b"", time.monotonic() + deadline
    while len(out) < n and time.monotonic() < end:
        out += link.read(0.05)
    return out


def receive_stream(link, device, message, deadline=5.0):
    """Like a receiver that talks continuously: write `message` every read until one arrives whole
    (opening a port flushes what was sent before)."""
    out, end = b"", time.monotonic() + deadline
    while message not in out and time.monotonic() < end:
        device.write(message)
        out += link.read(0.05)
    return message in out


@pytest.fixture
def device(tmp_path):
    dev = PtyDevice(str(tmp_path / "gnss0"))
    yield dev
    dev.close()


def test_pty_bytes_arrive_unchanged(device):
    link = ByteLink(LinkSettings(port=device.path, baud=115200))
    payload = bytes(range(256)) + b"$GPGGA,\r\n"
    assert link.read(0.05) == b"" and link.state == OPEN
    device.write(payload)
    assert read_until(link, len(payload)) == payload
    link.close()


def test_unplug_backs_off_without_spinning_and_replug_recovers(device):
    link = ByteLink(LinkSettings(port=device.path, backoff_initial=0.05, backoff_max=0.4))
    assert receive_stream(link, device, b"first")
    device.unplug()
    cpu0, t0 = time.process_time(), time.monotonic()
    while time.monotonic() - t0 < 1.0:
        link.read(0.1)
    assert link.state == BACKOFF and link.disconnects == 1 and link.open_failures >= 2
    assert time.process_time() - cpu0 < 0.2, "absent device must not busy-loop"
    device.plug()
    assert receive_stream(link, device, b"second")
    assert link.state == OPEN and link.opens == 2
    link.close()


def test_missing_port_at_start_then_appears(tmp_path):
    path = str(tmp_path / "late")
    link = ByteLink(LinkSettings(port=path, backoff_initial=0.05, backoff_max=0.2))
    assert link.read(0.05) == b"" and link.state == BACKOFF and "open failed" in link.last_error
    dev = PtyDevice(path)
    try:
        assert receive_stream(link, dev, b"hello")
    finally:
        link.close()
        dev.close()


def test_tcp_client_reconnects_after_server_drops():
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(2)
    port = server.getsockname()[1]

    def serve():
        for msg in (b"one", b"two"):
            conn, _ = server.accept()
            conn.sendall(msg)
            time.sleep(0.1)
            conn.close()

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    link = ByteLink(LinkSettings(host="127.0.0.1", tcp_port=port, backoff_initial=0.05))
    assert read_until(link, 3) == b"one"
    assert read_until(link, 3) == b"two"
    assert link.disconnects >= 1 and link.opens == 2
    link.close()
    server.close()


def test_file_replay_paced_then_eof(tmp_path):
    path = tmp_path / "cap.log"
    path.write_bytes(b"x" * 300)
    link = ByteLink(LinkSettings(file=str(path), file_rate=3000))
    t0 = time.monotonic()
    assert read_until(link, 300) == b"x" * 300
    assert time.monotonic() - t0 >= 0.05  # paced, not dumped at once
    link.read(0.05)
    assert link.state == EOF
    link.close()


def test_close_from_another_thread_stops_a_blocked_reader_quietly(device):
    """Node shutdown: the reader thread sits in a blocking read when the link is closed; nothing may escape."""
    errors = []
    for _ in range(4):
        link = ByteLink(LinkSettings(port=device.path))
        link.read(0.01)
        assert link.state == OPEN

        def reader():
            try:
                while link.state != "closed":
                    link.read(0.3)
            except Exception as exc:  # noqa: BLE001  (what the old close let escape: TypeError on fd None)
                errors.append(exc)
        thread = threading.Thread(target=reader)
        thread.start()
        time.sleep(0.1)  # the reader is inside the port's select now
        link.close()
        thread.join(2.0)
        assert not thread.is_alive() and link.state == "closed"
    assert errors == []
