"""`agnav run` starts and stops N nodes cleanly, in one process and as separate processes."""
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin

from test.foundation.test_bag_replay import imu_and_inclinometer_bag

AGNAV = str(Path(sys.executable).with_name("agnav"))


def recorders_config(tmp_path, n, output_param=True, topic="/imu/data_raw", **extra):
    nodes = [{"executable": "bag_recorder", "name": f"rec{i}",
              "parameters": ({"output": str(tmp_path / f"rec{i}")} if output_param else {}) | {"topics": [topic]},
              "remappings": {}} for i in range(n)]
    cfg = extra | {"description": "test graph", "bag": "", "record": [], "nodes": nodes,
           "static_transforms": [{"parent": "base_link", "child": "imu_link", "xyz": [0.1, 0, 0.5], "rpy": [0, 0, 0]}]}
    path = tmp_path / "graph.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def run_agnav(*args, timeout=120):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    return subprocess.run([AGNAV, "run", *map(str, args), "--quiet"], capture_output=True, text=True,
                          timeout=timeout, env=env)


@pytest.mark.parametrize("processes", [False, True])
def test_runner_starts_and_stops_nodes(tmp_path, processes):
    bag = imu_and_inclinometer_bag(tmp_path / "in", StoragePlugin.MCAP)
    cfg = recorders_config(tmp_path, 3)
    result = run_agnav(cfg, "--bag", bag, "--record", tmp_path / "all", *(["--processes"] if processes else []))
    assert result.returncode == 0, result.stderr
    for i in range(3):  # each node received the whole replay and closed its bag cleanly on shutdown
        with AnyReader([tmp_path / f"rec{i}"]) as reader:
            assert {c.topic: c.msgcount for c in reader.connections} == {"/imu/data_raw": 300}
    with AnyReader([tmp_path / "all"]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
    assert counts["/imu/data_raw"] == 300 and counts["/inclinometer"] == 30 and counts["/tf_static"] >= 1


@pytest.mark.parametrize("processes", [False, True])
def test_runner_fails_when_a_node_dies(tmp_path, processes):
    cfg = recorders_config(tmp_path, 2, output_param=False)  # bag_recorder without 'output' raises
    result = run_agnav(cfg, "--live", "--duration", "20", *(["--processes"] if processes else []))
    assert result.returncode != 0
    assert "output" in result.stderr


def test_runner_rejects_unknown_config(tmp_path):
    result = run_agnav("no_such_config")
    assert result.returncode != 0 and "not found" in result.stderr


def test_bag_remap_moves_a_replayed_topic(tmp_path):
    bag = imu_and_inclinometer_bag(tmp_path / "in", StoragePlugin.MCAP)
    cfg = recorders_config(tmp_path, 1, topic="/imu/raw_moved", bag_remap={"/imu/data_raw": "/imu/raw_moved"})
    result = run_agnav(cfg, "--bag", bag, "--record", tmp_path / "all")  # the player waits for the recorders
    assert result.returncode == 0, result.stderr
    for rec in ("rec0", "all"):
        with AnyReader([tmp_path / rec]) as reader:
            counts = {c.topic: c.msgcount for c in reader.connections}
        assert counts["/imu/raw_moved"] == 300 and "/imu/data_raw" not in counts


def test_runner_refuses_a_node_publishing_a_replayed_topic(tmp_path):
    """A graph node's output on a replayed topic would mix into the input (the node would read its own output)."""
    bag = imu_and_inclinometer_bag(tmp_path / "in", StoragePlugin.MCAP)
    cfg = {"description": "loop", "nodes": [{"executable": "bag_player", "name": "second_player",
                                             "parameters": {"bag": str(bag), "rate": 0.0}}]}
    path = tmp_path / "loop.yaml"
    path.write_text(yaml.safe_dump(cfg))
    result = run_agnav(path, "--bag", bag, timeout=60)
    assert result.returncode != 0
    assert "another node publishes /imu/data_raw" in result.stderr
    # leaving the node's topics out of the runner's replay resolves it
    result = run_agnav(path, "--bag", bag, "--exclude", "/imu/data_raw", "--exclude", "/inclinometer",
                       "--record", tmp_path / "all", timeout=60)
    assert result.returncode == 0, result.stderr
