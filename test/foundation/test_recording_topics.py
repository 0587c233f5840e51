"""What a recording holds: /tf in every bundled record list."""
import pytest

from agnav_bringup.graph_config import CONFIG_DIRS, load_config

BUNDLED = sorted(p.stem for p in CONFIG_DIRS[0].glob("*.yaml"))


@pytest.mark.parametrize("name", BUNDLED)
def test_bundled_configs_record_tf(name):
    record = load_config(name).record
    assert not record or "/tf" in record


def test_nsm_replay_recording_holds_one_datum_and_latched_qos(tmp_path, repo_root):
    """`agnav run nsm --record` on (20 s of) the default bag: the player withholds the bag's /map_datum because the
    navigation node publishes its own, so the recording holds one datum, the module's; metadata.yaml offers the
    latched topics latched (through the deterministic in-process bus) and /tf is recorded."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    import yaml
    from rclpy.serialization import deserialize_message
    from rosbags.highlevel import AnyReader
    from sensor_msgs.msg import NavSatFix

    from agnav_common.bagio import filter_bag

    src = repo_root / "bags" / "asphalt_loop"
    with AnyReader([src]) as reader:
        start = reader.start_time
        bag_datums = [deserialize_message(raw, NavSatFix) for c, _, raw in reader.messages()
                      if c.topic == "/map_datum"]
    assert len(bag_datums) == 1
    filter_bag(src, tmp_path / "short", lambda topic, t: t < start + 20_000_000_000)
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    result = subprocess.run([str(Path(sys.executable).with_name("agnav")), "run", "nsm", "--bag", tmp_path / "short",
                             "--record", tmp_path / "out", "--no-eval", "--quiet"],
                            capture_output=True, text=True, timeout=300, env=env)
    assert result.returncode == 0, result.stderr
    with AnyReader([tmp_path / "out"]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        datums = [deserialize_message(raw, NavSatFix) for c, _, raw in reader.messages() if c.topic == "/map_datum"]
    assert counts.get("/tf", 0) > 100 and counts.get("/tf_static", 0) >= 1
    assert len(datums) == 1 and datums[0].header.frame_id == "map"
    assert (datums[0].latitude, datums[0].longitude) != (bag_datums[0].latitude, bag_datums[0].longitude)
    meta = yaml.safe_load((tmp_path / "out" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    qos = {t["topic_metadata"]["name"]: t["topic_metadata"]["offered_qos_profiles"]
           for t in meta["topics_with_message_count"]}
    for topic in ("/map_datum", "/tf_static"):
        assert qos[topic] and all(p["durability"] == "transient_local" and p["reliability"] == "reliable"
                                  and p["history"] == "keep_last" and p["depth"] == 1 for p in qos[topic]), topic
    assert all(p["durability"] == "volatile" for p in qos["/odometry/filtered"])
