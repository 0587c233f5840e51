"""`agnav run` at rate 0 in one process is a deterministic replay (agnav_common.local_bus): two runs of a 60-s crop
of bags/asphalt_loop record the same messages, bytes and log times; the navigation output equals the offline
pipeline replay in log order bit for bit; every output is logged at the bag time of the input that caused it."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rclpy")

from agnav_sim_eval.evaluate import read_bag  # noqa: E402
from agnav_common.bagio import filter_bag  # noqa: E402
from rosbags.highlevel import AnyReader  # noqa: E402

SECONDS = 60.0
REPO = Path(__file__).resolve().parents[2]


def run(bag, out, *extra):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    proc = subprocess.run([sys.executable, "-m", "agnav_bringup.cli", "run", "nsm", "--bag", str(bag), "--record",
                           str(out), "--quiet", "--no-eval", *extra], cwd=REPO, env=env, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout


def messages(bag):
    """[(topic, log time, bytes)] of a recording in file order."""
    with AnyReader([bag]) as reader:
        return [(c.topic, t, bytes(raw)) for c, t, raw in reader.messages()]


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("deterministic")
    src, bag = REPO / "bags" / "asphalt_loop", tmp / "asphalt_head"
    with AnyReader([src]) as reader:
        end = reader.start_time + int(SECONDS * 1e9)
    filter_bag(src, bag, lambda topic, t: t <= end)
    assert "deterministic" in run(bag, tmp / "first")
    run(bag, tmp / "second")
    return bag, tmp / "first", tmp / "second"


def test_two_replays_record_identical_messages(recordings):
    _, first, second = recordings
    a, b = messages(first), messages(second)
    topics = {t for t, _, _ in a}
    assert {"/odometry/filtered", "/imu/data", "/gnss/fix_corrected", "/diagnostics", "/tf_static"} <= topics
    assert len(a) > 15_000 and a == b


def test_recording_equals_the_offline_pipeline(recordings):
    from agnav_bringup.graph_config import load_config
    from agnav_fusion.navigation_output import body_velocity
    from agnav_sim_eval.offline import replay as offline_replay
    bag, first, _ = recordings
    states, _ = offline_replay(load_config("nsm"), bag)
    graph = read_bag(first, ["/odometry/filtered"])["/odometry/filtered"]
    offline = np.array([[s.t, *s.position, *s.pose_cov.ravel(), *body_velocity(s)[:2]] for s in states])
    published = np.array([[m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, m.pose.pose.position.x,
                           m.pose.pose.position.y, m.pose.pose.position.z, *m.pose.covariance,
                           m.twist.twist.linear.x, m.twist.twist.linear.y] for _, m in graph])
    assert published.shape == offline.shape and np.array_equal(published[:, 1:], offline[:, 1:])
    assert np.allclose(published[:, 0], offline[:, 0], rtol=0, atol=1e-6)


def test_outputs_are_logged_at_the_time_of_their_input(recordings):
    """Discrete events: each /odometry/filtered is recorded at the log time of the /imu/data_raw that produced it
    (the n-th output at the n-th IMU message from the first one published), the recorder sees the bag's inputs at
    their own log times, and diagnostics come at 1 s of bag time per node."""
    bag, first, _ = recordings
    with AnyReader([bag]) as reader:
        imu = [t for c, t, _ in reader.messages() if c.topic == "/imu/data_raw"]
        truth_in = [t for c, t, _ in reader.messages() if c.topic == "/ground_truth/odometry"]
    rec = messages(first)
    odom = [t for topic, t, _ in rec if topic == "/odometry/filtered"]
    start = imu.index(odom[0])
    assert odom == imu[start:start + len(odom)] and len(odom) > 0.5 * len(imu)
    assert [t for topic, t, _ in rec if topic == "/ground_truth/odometry"] == truth_in
    diagnostics = [t for topic, t, _ in rec if topic == "/diagnostics"]
    span = (imu[-1] - imu[0]) * 1e-9
    assert 3 * (span - 1) <= len(diagnostics) <= 3 * (span + 2)  # player, recorder, module
