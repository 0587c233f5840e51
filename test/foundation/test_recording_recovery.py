"""A recording whose run is killed (SIGKILL, power loss) keeps what was flushed: `agnav recover DIR` finishes it."""
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest
import yaml
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer
from sensor_msgs.msg import Imu

from agnav_common.bagio import typestore
from agnav_common.mcap_recording import flush_recording, recover_bag, unfinished
from agnav_drivers.bag_source import BagSource
from test.foundation.test_bag_replay import imu_and_inclinometer_bag
from test.foundation.test_runner import AGNAV, run_agnav

ENV = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")


def imu_values(path):
    with AnyReader([Path(path)]) as reader:
        return [deserialize_message(raw, Imu).angular_velocity.z
                for c, _, raw in reader.messages() if c.topic == "/imu/data_raw"]


def unfinished_recording(path, n, flush_every, cut=0):
    """A rosbags mcap recording of n IMU messages flushed every `flush_every`, never closed, `cut` bytes lost."""
    writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    conn = writer.add_connection("/imu/data_raw", "sensor_msgs/msg/Imu", typestore=typestore())
    for i in range(n):
        msg = Imu()
        msg.angular_velocity.z = float(i)
        writer.write(conn, 1_000_000_000 + i * 10_000_000, serialize_message(msg))
        if (i + 1) % flush_every == 0:
            flush_recording(writer)
    writer.storage.bio.flush()  # what the OS has of a killed process: flushed chunks, no summary, no metadata
    mcap = path / f"{path.name}.mcap"
    os.truncate(mcap, mcap.stat().st_size - cut)
    return path


@pytest.mark.parametrize("cut", [0, 300])
def test_recover_keeps_every_complete_chunk(tmp_path, cut):
    rec = unfinished_recording(tmp_path / "rec", n=95, flush_every=10, cut=cut)
    assert unfinished(rec)
    with pytest.raises(ValueError, match="unfinished recording .* `agnav recover "):
        BagSource(rec)
    kept = recover_bag(rec)
    # the last complete chunk ends at message 90; a cut past its message index (175 bytes) loses that chunk only
    assert kept == (90 if cut == 0 else 80)
    assert imu_values(rec) == [float(i) for i in range(kept)] and not unfinished(rec)
    assert BagSource(rec).message_count == kept
    with pytest.raises(ValueError, match="finished recording"):
        recover_bag(rec)


def test_killed_run_is_recoverable(tmp_path):
    """SIGKILL of `agnav run --record` at real-time replay: the messages up to about a second before the kill
    are readable after `agnav recover`, and a new run does not replace the unfinished recording."""
    bag = imu_and_inclinometer_bag(tmp_path / "in", StoragePlugin.MCAP, n=3000)  # 30 s at 100 Hz
    cfg = tmp_path / "graph.yaml"
    cfg.write_text(yaml.safe_dump({"nodes": []}))
    out = tmp_path / "out"
    proc = subprocess.Popen([AGNAV, "run", str(cfg), "--bag", str(bag), "--rate", "1", "--record", str(out),
                             "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=ENV)
    assert "agnav run:" in proc.stdout.readline()
    started = time.monotonic()
    time.sleep(6.0)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=10)
    ran = time.monotonic() - started
    assert unfinished(out)
    refused = run_agnav(cfg, "--bag", bag, "--record", out, timeout=60)
    assert refused.returncode == 2 and f"agnav recover {out}" in refused.stderr and unfinished(out)
    result = subprocess.run([AGNAV, "recover", str(out)], capture_output=True, text=True, timeout=60, env=ENV)
    assert result.returncode == 0, result.stderr
    values = imu_values(out)
    # a prefix of the replay: start delay 0.5 s, flushes every 1 s; allow 1.5 s more for a loaded machine
    assert sorted(values) == [float(i) for i in range(len(values))]
    assert (ran - 3.0) * 100 <= len(values) <= ran * 100 + 10
    assert "messages kept" in result.stdout


def test_killed_runner_stops_its_child_processes(tmp_path):
    """--processes children notice a SIGKILLed runner and stop cleanly (their own recordings are finished)."""
    name = f"orphan_check_{os.getpid()}"
    cfg = tmp_path / "graph.yaml"
    cfg.write_text(yaml.safe_dump({"nodes": [{"executable": "bag_recorder", "name": name, "parameters": {
        "output": str(tmp_path / "child"), "topics": ["/probe"]}}]}))
    proc = subprocess.Popen([AGNAV, "run", str(cfg), "--live", "--processes", "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=ENV)
    assert "agnav run:" in proc.stdout.readline()

    def children():
        found = []
        for pid in filter(str.isdigit, os.listdir("/proc")):
            try:
                if f"__node:={name}".encode() in Path(f"/proc/{pid}/cmdline").read_bytes():
                    found.append(int(pid))
            except OSError:
                pass
        return found

    assert children()
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=10)
    deadline = time.monotonic() + 15.0
    while children() and time.monotonic() < deadline:
        time.sleep(0.2)
    left = children()
    for pid in left:  # do not leave a process behind when the check fails
        os.kill(pid, signal.SIGKILL)
    assert not left
    assert (tmp_path / "child" / "metadata.yaml").exists()
