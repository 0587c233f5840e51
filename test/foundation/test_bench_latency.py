"""`agnav bench latency --json` smoke test: a reduced run (1.5 s at 100 Hz + 1.5 s at 400 Hz per layout, no
scaling phases) gives every key with sane values. Only sanity, not the goals: the machine is shared."""
import json
import os
import subprocess
import sys
from pathlib import Path

AGNAV = str(Path(sys.executable).with_name("agnav"))
KEYS = ("imu_to_odom_p50_ms", "imu_to_odom_p99_ms", "imu_to_odom_max_ms", "bare_hop_p50_ms", "bare_hop_p99_ms")


def test_bench_latency_reduced():
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    result = subprocess.run([AGNAV, "bench", "latency", "--json", "--no-scaling", "--seconds", "1.5"],
                            capture_output=True, text=True, timeout=240, env=env)
    assert result.returncode == 0, result.stderr[-3000:]
    out = json.loads(result.stdout.strip().splitlines()[-1])
    for key in KEYS + ("graph_cpu_percent_100hz", "cpu_percent_per_node_100hz", "goals", "scaling",
                       "load_average_start", "load_average_end"):
        assert key in out, key
    assert 0 < out["imu_to_odom_p50_ms"] <= out["imu_to_odom_p99_ms"] <= out["imu_to_odom_max_ms"] < 1000
    assert 0 < out["bare_hop_p50_ms"] <= out["bare_hop_p99_ms"] < 1000
    assert 0 < out["graph_cpu_percent_100hz"] < 200
    assert "nav_sensor_module" in out["cpu_percent_per_node_100hz"]  # it publishes /gnss/fix_corrected too
    for layout in ("one_process", "processes"):
        for hz in ("100hz", "400hz"):
            r = out[layout][hz]
            assert all(r[k] is not None and r[k] > 0 for k in KEYS), (layout, hz, r)
            rate = int(hz[:-2])
            assert r["dropped"] <= 0.05 * rate * 1.5 and abs(r["imu_sent_hz"] - rate) < 0.2 * rate, (layout, hz, r)
    assert {(r["layout"], r["imu_hz"]) for r in out["scaling"]} == {
        (lay, hz) for lay in ("one_process", "processes") for hz in (100, 400)}
