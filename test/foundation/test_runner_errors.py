"""`agnav run` reports bad configs, parameters and inputs in one line (exit 2), ends on empty input, exits 0 on
Ctrl-C/SIGTERM without tracebacks, follows an external /clock with --sim-time, and shows its progress bar only
on a terminal."""
import fcntl
import os
import pty
import shutil
import signal
import struct
import subprocess
import termios
import time
from pathlib import Path

import pytest
import rclpy
import yaml
from rclpy.serialization import deserialize_message
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer
from rosgraph_msgs.msg import Clock
from std_msgs.msg import String

from agnav_common.bagio import typestore
from agnav_common.stamps import to_stamp
from test.foundation.test_bag_replay import imu_and_inclinometer_bag
from test.foundation.test_runner import AGNAV, recorders_config, run_agnav

MODES = [pytest.param([], id="one_process"), pytest.param(["--processes"], id="processes")]
ENV = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")


def graph(tmp_path, nodes, **extra):
    path = tmp_path / "graph.yaml"
    path.write_text(yaml.safe_dump({"nodes": nodes} | extra))
    return path


def recorder(tmp_path, name="rec", **params):
    return {"executable": "bag_recorder", "name": name,
            "parameters": {"output": str(tmp_path / name), "topics": ["/probe"]} | params}


def test_config_errors_are_one_line_with_status_2(tmp_path):
    bad_yaml = tmp_path / "bad.yaml"
    bad_yaml.write_text("nodes:\n  - {executable: bag_recorder\n")
    wrong_type = graph(tmp_path, {"executable": "bag_recorder"})  # nodes must be a list
    for path, expected in [(bad_yaml, f"{bad_yaml}:3:1: YAML syntax error"),
                           (wrong_type, "'nodes' must be a list"), ("no_such_config", "not found")]:
        result = run_agnav(path, "--live", "--duration", "1", timeout=60)
        assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
        assert result.stderr.strip().splitlines() == [f"agnav run: error: {result.stderr.split('error: ', 1)[1]}"
                                                      .strip()] and expected in result.stderr


@pytest.mark.parametrize("mode", MODES)
def test_misspelled_parameter_names_the_closest_declared(tmp_path, mode):
    cfg = graph(tmp_path, [recorder(tmp_path, topcis=["/probe"])])
    result = run_agnav(cfg, "--live", "--duration", "20", *mode, timeout=60)
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
    assert "node 'rec': unknown parameter 'topcis'; closest declared: topics," in result.stderr
    if not mode:
        assert len(result.stderr.strip().splitlines()) == 1, result.stderr


@pytest.mark.parametrize("mode", MODES)
def test_out_of_range_parameter_is_one_line(tmp_path, mode):
    cfg = graph(tmp_path, [recorder(tmp_path, flush_period=-1.0)])  # descriptor range 0.05..60 s
    result = run_agnav(cfg, "--live", "--duration", "20", *mode, timeout=60)
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
    line = next(x for x in result.stderr.splitlines() if "out of range" in x)
    assert "node 'rec':" in line and "flush_period" in line


def empty_bags(tmp_path):
    with Writer(tmp_path / "no_connections", version=9, storage_plugin=StoragePlugin.MCAP):
        pass
    with Writer(tmp_path / "no_messages", version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        writer.add_connection("/imu/data_raw", "sensor_msgs/msg/Imu", typestore=typestore())
    return [tmp_path / "no_connections", tmp_path / "no_messages"]


@pytest.mark.parametrize("mode", MODES)
def test_empty_bag_is_an_error_not_a_hang(tmp_path, mode):
    for bag in empty_bags(tmp_path):
        cfg = graph(tmp_path, [recorder(tmp_path, name=f"rec_{bag.name}")])
        result = run_agnav(cfg, "--bag", bag, "--record", tmp_path / "out", *mode, timeout=60)
        assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
        assert f"agnav run: error: replay: bag {bag} holds no messages" in result.stderr


def test_replay_ends_when_nothing_is_recorded(tmp_path):
    """Every replayed topic excluded and the recorded topics never published: the run still ends."""
    bag = imu_and_inclinometer_bag(tmp_path / "in", StoragePlugin.MCAP)
    cfg = graph(tmp_path, [], record=["/odometry/filtered"])
    result = run_agnav(cfg, "--bag", bag, "--record", tmp_path / "out", "--exclude", "/imu/data_raw",
                       "--exclude", "/inclinometer", timeout=60)
    assert result.returncode == 0, result.stderr
    assert "recorded 0 messages" in result.stdout


# (signal, SIGINT ignored when started, as in a background job of a script: Python then has no KeyboardInterrupt
# and rclpy's own handler used to shut the context down under the executor)
SIGNALS = [(signal.SIGINT, False), (signal.SIGINT, True), (signal.SIGTERM, False)]


def start(cmd, sigint_ignored):
    if sigint_ignored:
        cmd = ["sh", "-c", "trap '' INT; exec \"$0\" \"$@\"", *cmd]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)


@pytest.mark.parametrize("mode", MODES)
def test_signals_stop_cleanly_with_status_0(tmp_path, mode):
    cfg = graph(tmp_path, [recorder(tmp_path)])
    for sig, ignored in SIGNALS:
        shutil.rmtree(tmp_path / "rec", ignore_errors=True)
        proc = start([AGNAV, "run", str(cfg), "--live", "--record", str(tmp_path / "out"), *mode], ignored)
        assert "agnav run:" in proc.stdout.readline()  # the graph is up
        time.sleep(2.0)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=30)
        assert proc.returncode == 0 and "Traceback" not in err and "Exception" not in err, (sig, ignored, err)
        for rec in ("rec", "out"):  # both recorders closed their bags
            assert (tmp_path / rec / "metadata.yaml").exists(), (sig, rec)


def test_node_console_script_stops_cleanly_on_signals(tmp_path):
    """Every node is also a console script (agnav_common.node_main): Ctrl-C/SIGTERM end it with status 0."""
    for sig, ignored in SIGNALS:
        out = tmp_path / f"{sig.name}_{ignored}"
        proc = start([str(Path(AGNAV).with_name("bag_recorder")), "--ros-args", "-p", f"output:={out}"], ignored)
        deadline = time.monotonic() + 30.0
        while not out.exists() and time.monotonic() < deadline:  # the node is constructed
            time.sleep(0.1)
        time.sleep(1.0)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=30)
        assert proc.returncode == 0 and "Traceback" not in err and "Exception" not in err, (sig, ignored, err)
        assert (out / "metadata.yaml").exists()


@pytest.mark.parametrize("how", ["flag", "config"])
def test_live_run_follows_an_external_clock(ros, tmp_path, how):
    """--sim-time (or use_sim_time: true): the recorder stamps with the simulator's /clock, not wall time."""
    sim_t0 = 1000.0
    cfg = graph(tmp_path, [], record=["/probe"], **({"use_sim_time": True} if how == "config" else {}))
    node = rclpy.create_node("external_sim")
    clock, probe = node.create_publisher(Clock, "/clock", 10), node.create_publisher(String, "/probe", 10)
    proc = subprocess.Popen([AGNAV, "run", str(cfg), "--live", "--record", str(tmp_path / "out"), "--duration", "6",
                             *(["--sim-time"] if how == "flag" else [])], stdout=subprocess.PIPE, text=True, env=ENV)
    k, t = 0, sim_t0
    while proc.poll() is None and k < 3000:
        t = sim_t0 + 0.01 * k  # about real time
        clock.publish(Clock(clock=to_stamp(t)))
        probe.publish(String(data=f"{t:.2f}"))
        k += 1
        time.sleep(0.01)
    assert proc.wait(timeout=30) == 0
    node.destroy_node()
    with AnyReader([tmp_path / "out"]) as reader:
        stamps = [(t, raw) for c, t, raw in reader.messages() if c.topic == "/probe"]
    assert len(stamps) > 10
    for t_ns, raw in stamps:  # stamped with the /clock published with the message (or later), not wall time
        assert float(deserialize_message(raw, String).data) - 0.5 <= t_ns * 1e-9 <= t + 1e-6


def test_progress_bar_only_on_a_terminal(tmp_path):
    bag = imu_and_inclinometer_bag(tmp_path / "in", StoragePlugin.MCAP)
    cfg = recorders_config(tmp_path, 0)
    args = [AGNAV, "run", str(cfg), "--bag", str(bag), "--rate", "2"]
    piped = subprocess.run(args, capture_output=True, text=True, timeout=60, env=ENV)
    assert piped.returncode == 0, piped.stderr
    assert "\r" not in piped.stderr and "%|" not in piped.stderr  # nothing for files and CI logs
    leader, follower = pty.openpty()
    fcntl.ioctl(follower, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))  # a 100-column terminal
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=follower, env=ENV)
    os.close(follower)
    out = b""
    while True:
        try:
            chunk = os.read(leader, 4096)
        except OSError:  # the terminal closed with the process
            break
        if not chunk:
            break
        out += chunk
    assert proc.wait(timeout=60) == 0
    os.close(leader)
    text = out.decode(errors="replace")
    assert "replay" in text and "100.0%|" in text and "3.0/3.0 s bag" in text, text
