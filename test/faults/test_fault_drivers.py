"""Driver cases of the fault bench (agnav_sim_eval.bench.faults_drivers): the scoring catches what the issue saw
(NO_FIX at lat/lon 0, zero covariance marked known, 2000 m/s, stale stamps), the docs merge keeps other graphs'
results, and two real cases (node processes on a pty) pass: corrupt UBX length, NMEA unplug/replug."""
import math
import os

from geometry_msgs.msg import TwistWithCovarianceStamped
from sensor_msgs.msg import NavSatFix, NavSatStatus

from agnav_sim_eval.bench import faults, faults_drivers as fd, faults_report
from agnav_common.stamps import to_stamp


def _fix(lat, lon, status=NavSatStatus.STATUS_FIX, cov=(0.04, 0.04, 0.09), kind=2):
    m = NavSatFix()
    m.status.status = status
    m.latitude, m.longitude, m.altitude = lat, lon, 50.0
    m.position_covariance[0], m.position_covariance[4], m.position_covariance[8] = cov
    m.position_covariance_type = kind
    return m


def test_scoring_flags_confident_garbage():
    assert fd.fix_problem(_fix(fd.LAT0, fd.LON0)) is None
    assert fd.fix_problem(_fix(math.nan, math.nan, NavSatStatus.STATUS_NO_FIX, (0, 0, 0), 0)) is None
    assert "NO_FIX" in fd.fix_problem(_fix(0.0, 0.0, NavSatStatus.STATUS_NO_FIX, (0, 0, 0), 0))
    assert "off the stream" in fd.fix_problem(_fix(0.0, 0.0))            # quality 1 at 0, 0
    assert "covariance" in fd.fix_problem(_fix(fd.LAT0, fd.LON0, cov=(0.0, 0.0, 0.0)))  # hAcc 0 marked known
    assert fd.fix_problem(_fix(fd.LAT0, fd.LON0, cov=(0.0, 0.0, 0.0), kind=0)) is None
    v = TwistWithCovarianceStamped()
    v.twist.twist.linear.y = 2000.0
    v.twist.covariance[0] = v.twist.covariance[7] = v.twist.covariance[14] = 0.0025
    assert "velocity" in fd.vel_problem(v)
    v.twist.twist.linear.y = 2.0
    assert fd.vel_problem(v) is None


def test_stale_burst_and_silence_fail_their_criteria():
    case = next(c for c in fd.cases() if c.name == "ubx_corrupt_length_8000")
    fixes = []
    for k in range(10):  # 81 stale fixes released at once, as the old UBX driver did: here 10 stamped 3 s late
        m = _fix(fd.LAT0, fd.LON0)
        m.header.stamp = to_stamp(100.0 + 0.1 * k)
        fixes.append((103.0, m))
    r = fd.score(case, {"fix": fixes, "vel": [], "diag": []}, 100.0, 101.0, 106.0,
                 (True, 0, "[ERROR] [99.5] [ubx_gnss]: driver error: AttributeError()"), [], 99.8)
    assert not r["fresh_ok"] and r["stale_outputs"] == 10
    assert not r["stream_ok"] and r["max_gap_after_s"] == 3.0  # silent from 103 s to the end at 106 s
    assert not r["detected_ok"] and not r["pass"]
    assert r["alive_ok"] and r["startup_errors"]  # an error before the first fix is reported apart


def test_docs_merge_keeps_other_graphs(repo_root):
    checked_in = repo_root / "docs" / "benchmarks" / "faults.md"
    old = checked_in.read_text() if checked_in.exists() else ""
    bag_rows = [ln for ln in old.splitlines() if ln.startswith("| ") and ln.split("|")[2].strip() in faults.GRAPHS]
    r = dict(graph="drivers", case="x", driver="nmea", fault="f", rc=0, alive=True, driver_errors=[], startup_errors=[],
             first_fix_after_s=0.1, allowed_s=2.0,
             max_gap_after_s=0.2, first_bad_output=None, bad_outputs=0, detected_after_s=0.5, detect_keys=["k"],
             stale_outputs=0, crash=False, **{k: True for k in fd.CRITERIA}, **{"pass": True})
    new = faults_report.merged_docs(old, [], [], [r])
    assert all(ln in new for ln in bag_rows) and "| x | drivers | yes |" in new
    again = faults_report.merged_docs(new, [], [], [dict(r, case="y")])
    assert "| x | drivers" not in again and "| y | drivers" in again and all(ln in again for ln in bag_rows)


def test_driver_cases_through_a_pty():
    names = {"ubx_corrupt_length_8000", "nmea_unplug_replug"}
    results = {r["case"]: r for r in fd.run(names, int(os.environ.get("ROS_DOMAIN_ID", "101")))}
    assert set(results) == names
    for r in results.values():
        assert r["fixes"] > 10 and r["velocities"] > 10, r
        assert r["pass"], {k: v for k, v in r.items() if k not in ("fault",)}
    assert results["nmea_unplug_replug"]["first_fix_after_s"] <= fd.BACKOFF_MAX + 1.0 / fd.RATE_HZ
