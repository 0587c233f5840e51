"""`agnav bench campaign` end to end on two short runs through the shipped graphs (nsm / ins)."""
import json
import os
import subprocess
import sys

from agnav_bringup.graph_config import REPO_ROOT


def test_campaign_two_short_runs_json_keys():
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    proc = subprocess.run([sys.executable, "-m", "agnav_bringup.cli", "bench", "campaign", "--runs", "2", "--seed",
                           "5", "--duration", "20", "--json"], env=env, cwd=REPO_ROOT, capture_output=True, text=True,
                          timeout=240)
    assert proc.returncode == 0, proc.stderr
    assert "tuning results" in proc.stderr  # seeds < 1000
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    assert res["runs"] == 2 and [r["seed"] for r in res["rows"]] == [5, 6] and res["failed"] == 0
    for key in ("horizontal_rms_cm", "horizontal_rms_over_floor", "max_over_floor_max", "roll_rms_deg",
                "pitch_rms_deg", "heading_rms_deg_DGPS", "heading_rms_deg_RTK", "within_3sigma", "nan_samples"):
        assert set(res["summary"][key]) >= {"n", "p50", "p95", "max"}
    assert {a["metric"] for a in res["acceptance"]} >= {"horizontal_rms_over_floor", "within_3sigma", "nan_samples"}
    assert res["warning"] and len(res["worst"]) == 2 and all("params" in r for r in res["worst"])
    scored = [r for r in res["rows"] if r.get("samples")]
    assert scored and all(r["floor_rms_cm"] > 0 and r["horizontal_rms_cm"] > 0 for r in scored)
    assert {r["config"] for r in res["rows"]} <= {"nsm", "ins"}
    assert "| horizontal RMS / receiver floor |" in proc.stdout
