"""`agnav bench ins_fast`: the thesis' fast run through the shipped ins graph, scored against truth and the receiver
floor (one seed here; the report runs 1,2,3)."""
import json
import os
import subprocess
import sys

from agnav_bringup.graph_config import REPO_ROOT


def test_ins_fast_one_seed():
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    proc = subprocess.run([sys.executable, "-m", "agnav_bringup.cli", "bench", "ins_fast", "--seeds", "2", "--json"],
                          env=env, cwd=REPO_ROOT, capture_output=True, text=True, timeout=240)
    assert proc.returncode == 0, proc.stderr
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    (row,) = res["rows"]
    assert row["seed"] == 2 and 0.5 < row["floor_rms_cm"] < row["horizontal_rms_cm"] < 10.0
    assert 0.0 < row["heading_rms_deg"] < 1.0 and row["within_3sigma"] >= 0.99
    assert set(res["meets"]) == {"horizontal_rms_cm", "heading_rms_deg"}
    assert "| mean |" in proc.stdout
