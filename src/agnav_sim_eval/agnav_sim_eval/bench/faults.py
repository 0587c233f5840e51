"""`agnav bench faults [--json] [--graph G] [--cases A,B] [--write-docs PATH]`: fault injection through the shipped graphs.

Each case is a copy of a simulated bag with one fault (agnav_sim_eval.fault_injection) at T0 s after its start,
replayed as users do (`agnav run CONFIG --bag B --record OUT --quiet --no-eval`, a subprocess with its own
ROS_DOMAIN_ID) and compared with the clean replay of the same bag: nsm on asphalt_loop and ins on mems_field
(fault at 100 s, bags cropped to the fault end + 25 s, at most 170 s), gds on gds_straight_slow (magnetometer
cases at 40 s; the bag lasts 96 s). Criteria per case:
(a) gap: no output gap over 2 s from the first output to the input's end, beyond the longest gap of the input's
IMU itself (allowed = max(2 s, input IMU gap + 0.1 s): a 2 s IMU gap may silence the output for 2.1 s);
(b) stamps: no output (odometry, /imu/data, /gnss/fix_corrected, /heading/imu) stamped outside the input's log
span ± 0.5 s; (c) 3σ: every output sample within 3σ of the truth (east, north per axis from pose.covariance;
yaw where its variance < 1e4), over-3σ samples are counted, also for the clean run; (d) recovery: back within
10 cm of the clean run's position (gds: 1° of its heading) at most 10 s after the fault ends and for the rest of
the run (recovery s = last sample off by more, after the fault end); (e) diagnostics: within 1 s of the fault's
first message, a status of a graph node on /diagnostics is WARN/ERROR where the clean run's is not, or a value
that never changes in the clean run (a rejection counter) changes. Plus crashes (runner rc != 0) and NaN outputs.
Graph `drivers`: the GNSS driver nodes fed faulty byte streams through a pseudo-terminal, with their own criteria
(agnav_sim_eval.bench.faults_drivers). `--write-docs PATH` replaces only the rows, totals and sections of the graphs
run and keeps the others' results.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from agnav_bringup.graph_config import REPO_ROOT
from agnav_sim_eval.bench import docs_option, faults_drivers, write_docs
from agnav_sim_eval.evaluate import error_series, move_datum, odometry_arrays, read_bag
from agnav_sim_eval.fault_injection import FaultCase, bag_span, mutate_bag
from agnav_common.frames import euler_from_quaternion, wrap_angle

REPO = REPO_ROOT
GRAPHS = {  # name: (config, bag, fault start s, crop s, output topic)
    "nsm": ("nsm", REPO / "bags" / "asphalt_loop", 100.0, 170.0, "/odometry/filtered"),
    "ins": ("ins", REPO / "bags" / "mems_field", 100.0, 170.0, "/odometry/filtered"),
    "gds": ("gds", REPO / "bags" / "gds_straight_slow", 40.0, None, "/heading/imu"),
}
IMU, FIX, VEL, MAG = "/imu/data_raw", "/gnss/fix", "/gnss/vel", "/imu/mag"
DATA_TOPICS = ("/odometry/filtered", "/imu/data", "/gnss/fix_corrected", "/heading/imu")
MAX_GAP, GAP_SLACK, SPAN_SLACK = 2.0, 0.1, 0.5      # s
RECOVER_S, RECOVER_M, RECOVER_YAW_DEG = 10.0, 0.10, 1.0
DETECT_S, AFTER_FAULT_S = 1.0, 25.0
SIGMA_UNKNOWN = 1e4   # rad^2: yaw variance marking an unknown yaw
TIMEOUT_S = 600.0


def cases_for(graph, t0):
    """The fault cases of one graph (gds: the magnetometer cases)."""
    if graph == "gds":
        return [FaultCase("mag_disturbance_20uT", "mag_offset", MAG, t0, 10.0, 20e-6),
                FaultCase("mag_rotation_10deg", "mag_rotate", MAG, t0, 10.0, 10.0),
                FaultCase("mag_nan", "nan", MAG, t0, 1.0)]
    c = lambda *a: FaultCase(a[0], a[1], a[2], t0, *a[3:])  # noqa: E731
    return [c("imu_gyro_nan", "nan", IMU, 1.0), c("imu_gyro_inf", "inf", IMU, 1.0),
            c("fix_nan", "nan", FIX, 5.0), c("fix_inf", "inf", FIX, 5.0),
            c("vel_nan", "nan", VEL, 5.0), c("vel_inf", "inf", VEL, 5.0),
            c("fix_cov_zero", "zero_cov", FIX, 5.0), c("fix_cov_negative", "negative_cov", FIX, 5.0),
            c("vel_cov_zero", "zero_cov", VEL, 5.0), c("vel_cov_negative", "negative_cov", VEL, 5.0),
            c("imu_zero_stamp", "zero_stamp", IMU, 1.0), c("fix_zero_stamp", "zero_stamp", FIX),
            c("imu_backwards_stamp", "backwards_stamp", IMU, 1.0, 1.0),
            c("fix_backwards_stamp", "backwards_stamp", FIX, 0.0, 1.5),
            c("imu_future_stamp_1000s", "future_stamp", IMU, 0.0, 1000.0),
            c("fix_future_stamp_1000s", "future_stamp", FIX, 0.0, 1000.0),
            c("fix_future_stamp_10s", "future_stamp", FIX, 0.0, 10.0),
            c("imu_duplicates", "duplicate", IMU, 1.0), c("fix_duplicates", "duplicate", FIX, 5.0),
            c("imu_gap_0.2s", "drop", IMU, 0.2), c("imu_gap_0.6s", "drop", IMU, 0.6), c("imu_gap_2s", "drop", IMU, 2.0),
            c("imu_stuck_2s", "stuck", IMU, 2.0), c("fix_step_5m_20s", "step", FIX, 20.0, 5.0),
            FaultCase("gnss_outage_30s", "drop", FIX, t0, 30.0, also=(VEL, "/gnss/status")),
            c("fix_no_fix_10s", "no_fix", FIX, 10.0)]


def replay(config, bag, out, domain):
    """(runner rc, wall s, stderr tail) of `agnav run CONFIG --bag BAG --record OUT --quiet --no-eval`."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_DOMAIN_ID=str(domain))
    start = time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, "-m", "agnav_bringup.cli", "run", config, "--bag", str(bag),
                               "--record", str(out), "--quiet", "--no-eval"], env=env, cwd=REPO,
                              capture_output=True, text=True, timeout=TIMEOUT_S)
        rc, err = proc.returncode, proc.stderr
    except subprocess.TimeoutExpired as exc:
        rc, err = "timeout", str(exc)
    return rc, time.perf_counter() - start, err.strip().splitlines()[-3:] if err else []


def _sorted(samples):
    return sorted(samples, key=lambda s: s[0])


def output_arrays(samples, topic):
    """Arrays t, (x, y,) yaw and σ_x, σ_y, yaw variance of the finite samples, and the NaN sample count."""
    rows, bad = [], 0
    for t, m in _sorted(samples):
        if topic == "/heading/imu":
            q = m.orientation
            row = (t, math.nan, math.nan, euler_from_quaternion(q.x, q.y, q.z, q.w)[2], math.nan, math.nan,
                   m.orientation_covariance[8])
            finite = np.isfinite([q.x, q.y, q.z, q.w, row[6]]).all()
        else:
            p, q, c = m.pose.pose.position, m.pose.pose.orientation, m.pose.covariance
            row = (t, p.x, p.y, euler_from_quaternion(q.x, q.y, q.z, q.w)[2], math.sqrt(max(c[0], 0.0)),
                   math.sqrt(max(c[7], 0.0)), c[35])
            finite = np.isfinite([p.x, p.y, p.z, q.x, q.y, q.z, q.w]).all() and np.isfinite(c).all()
        if finite and np.isfinite(t):
            rows.append(row)
        else:
            bad += 1
    a = np.array(rows, float).reshape(-1, 7)
    return dict(zip(("t", "x", "y", "yaw", "sx", "sy", "yaw_var"), a.T)), bad


def finite_message(m):
    """False when an attitude (Imu) or position (NavSatFix) output carries NaN/Inf."""
    if hasattr(m, "orientation"):
        q = m.orientation
        return bool(np.isfinite([q.x, q.y, q.z, q.w]).all())
    if hasattr(m, "latitude"):
        return bool(np.isfinite([m.latitude, m.longitude, m.altitude]).all())
    return bool(np.isfinite([m.pose.pose.position.x, m.pose.pose.position.y]).all())


def sigma_check(est, truth, heading_only):
    """(samples over 3σ, max horizontal error m, max error/σ) against truth."""
    t = est["t"]
    keep = (t >= truth["t"][0]) & (t <= truth["t"][-1])
    sub = {k: v[keep] for k, v in est.items()}
    s = error_series({k: sub[k] for k in (("t", "yaw") if heading_only else ("t", "x", "y", "yaw"))}, truth)
    ratios = []
    known = sub["yaw_var"] < SIGMA_UNKNOWN
    ratios.append(np.where(known, np.abs(np.radians(s["yaw"])) / np.sqrt(np.maximum(sub["yaw_var"], 1e-30)), 0.0))
    err = None
    if not heading_only:
        ratios += [np.abs(s["east"] / 100) / np.maximum(sub["sx"], 1e-12),
                   np.abs(s["north"] / 100) / np.maximum(sub["sy"], 1e-12)]
        err = np.hypot(s["east"], s["north"]) / 100
    r = np.max(ratios, axis=0) if sub["t"].size else np.zeros(0)
    return (int(np.sum(r > 3.0)), float(err.max()) if err is not None and err.size else None,
            float(r.max()) if r.size else None)


def diagnostics_table(samples):
    """[(t, {status name: (level, {key: value})})] of the graph's nodes (player and recorder left out)."""
    rows = []
    for t, m in _sorted(samples):
        st = {s.name: (int.from_bytes(s.level, "little") if isinstance(s.level, bytes) else int(s.level),
                       {kv.key: kv.value for kv in s.values})
              for s in m.status if not s.name.startswith(("bag_player", "bag_recorder"))}
        if st:
            rows.append((t, st))
    return rows


def constant_values(rows):
    """{(status, key): value} of the values that never change over a run."""
    seen = {}
    for _, st in rows:
        for name, (_, values) in st.items():
            for k, v in values.items():
                seen.setdefault((name, k), set()).add(v)
    return {k: next(iter(v)) for k, v in seen.items() if len(v) == 1}


STAMP_TOLERANCE = 1e-6  # s: float seconds of the fault time vs the diagnostics' integer-nanosecond stamps


def detected(rows, clean_rows, t_fault):
    """Time (s after t_fault) of the first diagnostic that shows the fault, or None."""
    const = constant_values(clean_rows)
    ct = np.array([t for t, _ in clean_rows])
    for t, st in rows:
        if t < t_fault - STAMP_TOLERANCE:  # a node may report at the very stamp of the faulty message
            continue
        ref = clean_rows[int(np.argmin(np.abs(ct - t)))][1] if ct.size else {}
        for name, (level, values) in st.items():
            if level >= 1 and level > ref.get(name, (0, {}))[0]:
                return max(t - t_fault, 0.0)
            if any(const.get((name, k), v) != v for k, v in values.items()):
                return max(t - t_fault, 0.0)
    return None


def longest_gap(times, end):
    t = np.sort(np.asarray(times, float))
    return float(max(np.diff(t).max(initial=0.0), end - t[-1])) if t.size else math.inf


def score(out, case_bag, graph, case, clean, start):
    """Criteria of one replay (case None: the clean run); clean: the clean run's score (for d and e)."""
    config, _, _, _, topic = GRAPHS[graph]
    bag = read_bag(out, list(DATA_TOPICS) + ["/diagnostics", "/map_datum"])
    inp = read_bag(case_bag, ["/ground_truth/odometry", "/map_datum"])
    span = bag_span(case_bag)
    imu_log = read_log_times(case_bag, IMU)
    est, nan = output_arrays(bag[topic], topic)
    nan += sum(1 for k in DATA_TOPICS if k != topic for _, m in bag[k] if not finite_message(m))
    truth_datum = tuple(getattr(inp["/map_datum"][-1][1], k) for k in ("latitude", "longitude", "altitude")) \
        if inp["/map_datum"] else None
    out_datum = tuple(getattr(bag["/map_datum"][-1][1], k) for k in ("latitude", "longitude", "altitude")) \
        if bag["/map_datum"] else truth_datum
    truth = move_datum(odometry_arrays(inp["/ground_truth/odometry"]), truth_datum, out_datum)
    heading_only = topic == "/heading/imu"
    over, max_err, max_ratio = sigma_check(est, truth, heading_only) if est["t"].size else (0, None, None)
    allowed = max(MAX_GAP, longest_gap(imu_log, span[1]) + GAP_SLACK)
    gap = longest_gap(est["t"], span[1])
    stamps = [t for k in DATA_TOPICS for t, _ in bag[k]]
    outside = int(sum(1 for t in stamps if not (span[0] - SPAN_SLACK <= t <= span[1] + SPAN_SLACK)))
    res = {"graph": graph, "config": config, "case": case.name if case else "clean", "outputs": int(est["t"].size),
           "nan_outputs": nan, "max_gap_s": gap, "allowed_gap_s": allowed, "gap_ok": gap <= allowed,
           "outside_span": outside, "stamps_ok": outside == 0, "over_3sigma": over, "sigma_ok": over == 0,
           "max_error_m": max_err, "max_error_over_sigma": max_ratio, "est": est,
           "diagnostics": diagnostics_table(bag["/diagnostics"])}
    if case is None:
        return res
    fault_end = start + case.end
    ce = clean["est"]
    tq = est["t"][(est["t"] >= fault_end) & (est["t"] <= ce["t"][-1])]
    if heading_only:
        dev = np.abs(np.degrees(wrap_angle(np.interp(tq, est["t"], np.unwrap(est["yaw"]))
                                           - np.interp(tq, ce["t"], np.unwrap(ce["yaw"])))))
        off = dev > RECOVER_YAW_DEG
    else:
        dev = np.hypot(np.interp(tq, est["t"], est["x"]) - np.interp(tq, ce["t"], ce["x"]),
                       np.interp(tq, est["t"], est["y"]) - np.interp(tq, ce["t"], ce["y"]))
        off = dev > RECOVER_M
    recovery = None if tq.size == 0 or off[-1] else (float(tq[off][-1] - fault_end) if off.any() else 0.0)
    first = case_first_hit(case_bag, case, start)
    seen = detected(res["diagnostics"], clean["diagnostics"], first)
    res.update(recovery_s=recovery, recovered_ok=recovery is not None and recovery <= RECOVER_S,
               detected_after_s=seen, detected_ok=seen is not None and seen <= DETECT_S,
               max_deviation_after=float(dev.max()) if dev.size else None)
    return res


def read_log_times(path, topic):
    from rosbags.rosbag2 import Reader
    with Reader(path) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        return [t * 1e-9 for _, t, _ in reader.messages(connections=conns)] if conns else []


def case_first_hit(case_bag, case, start):
    """Log time of the first faulted message: the fault's own start (or, for a drop, the first missing one)."""
    times = read_log_times(case_bag, case.topic)
    after = [t for t in times if t >= start + case.t0 - 1e-9]
    return after[0] if after and case.kind != "drop" else start + case.t0


CRITERIA = ("gap_ok", "stamps_ok", "sigma_ok", "recovered_ok", "detected_ok")


def verdict(r):
    r["crash"] = r.get("rc", 0) != 0
    r["pass"] = not r["crash"] and r["nan_outputs"] == 0 and all(r.get(k, True) for k in CRITERIA)
    return r


def run(graphs, names, domain, keep=None):
    results, cleans = [], []
    with tempfile.TemporaryDirectory(prefix="agnav_faults_") as tmp:
        tmp = Path(keep) if keep else Path(tmp)
        for graph in graphs:
            config, src, t0, crop, _ = GRAPHS[graph]
            cases = [c for c in cases_for(graph, t0) if not names or c.name in names]
            if not cases:
                continue
            clean_bag = tmp / f"{graph}_clean_in"
            start = mutate_bag(src, clean_bag, None, crop)["start"]
            rc, wall, err = replay(config, clean_bag, tmp / f"{graph}_clean_out", domain)
            clean = score(tmp / f"{graph}_clean_out", clean_bag, graph, None, None, start)
            cleans.append(verdict(dict(clean, rc=rc, wall_s=wall, error=err)))
            print(f"faults: {graph} clean rc={rc} wall {wall:.0f} s over3σ {clean['over_3sigma']}", flush=True)
            for case in cases:
                bag, out = tmp / f"{graph}_{case.name}_in", tmp / f"{graph}_{case.name}_out"
                cut = case.end + AFTER_FAULT_S
                rc, wall, err, hit = "not run", 0.0, [], 0
                try:
                    hit = mutate_bag(src, bag, case, min(crop, cut) if crop else None)["hit"]
                    rc, wall, err = replay(config, bag, out, domain)
                    r = score(out, bag, graph, case, clean, start)
                except Exception as exc:  # an unreadable or empty recording is scored as a failure
                    r = {"graph": graph, "config": config, "case": case.name, "nan_outputs": 0, "gap_ok": False,
                         "score_error": f"{type(exc).__name__}: {exc}"}
                r.update(rc=rc, wall_s=wall, error=err, hit=hit, t0=case.t0, duration=case.duration)
                results.append(verdict(r))
                print(f"faults: {graph} {case.name}: {'PASS' if r['pass'] else 'fail'} (rc={rc}, {wall:.0f} s)",
                      flush=True)
    for r in results + cleans:
        r.pop("est", None)
        r.pop("diagnostics", None)
    return results, cleans


def totals(results, cleans):
    rec = [r["recovery_s"] for r in results if r.get("recovery_s") is not None]
    return {"cases": len(results), "passes": sum(r["pass"] for r in results),
            "crashes": sum(r["crash"] for r in results),
            "nan_outputs": sum(r.get("nan_outputs", 0) for r in results),
            "over_3sigma_samples": sum(r.get("over_3sigma", 0) for r in results),
            "clean_over_3sigma_samples": {r["graph"]: r.get("over_3sigma") for r in cleans},
            "not_recovered": sum(1 for r in results if r.get("recovery_s") is None),
            "recovery_s": {"max": max(rec) if rec else None, "mean": float(np.mean(rec)) if rec else None},
            **{f"{k}_failures": sum(1 for r in results if not r.get(k, False)) for k in CRITERIA}}


def main(argv=None):
    from agnav_sim_eval.bench.faults_report import fmt, markdown, memory, merged_docs

    ap = argparse.ArgumentParser(prog="agnav bench faults", description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object on the last line")
    docs_option(ap, "faults.md")
    ap.add_argument("--graph", choices=sorted([*GRAPHS, "drivers"]), action="append",
                    help="run only this graph (repeatable; drivers: the GNSS driver cases)")
    ap.add_argument("--cases", default="", help="comma-separated case names (default: all)")
    ap.add_argument("--domain-id", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0")),
                    help="ROS_DOMAIN_ID of the replays (default: the environment's)")
    ap.add_argument("--keep", metavar="DIR", help="keep the mutated bags and recordings in DIR")
    ap.add_argument("--memory", action="store_true", help="only the memory test: RSS slope of a long nsm replay")
    ap.add_argument("--memory-minutes", type=float, default=10.0, help="wall minutes of the memory test")
    ap.add_argument("--rate", type=float, default=20.0, help="replay rate of the memory test")
    args = ap.parse_args(argv)
    if args.memory:
        with tempfile.TemporaryDirectory(prefix="agnav_faults_mem_") as tmp:
            res = memory(args.memory_minutes, args.rate, args.domain_id, args.keep or tmp)
        print(f"memory: RSS {fmt(res['rss_start_mb'], '.0f')} -> {fmt(res['rss_end_mb'], '.0f')} MB over "
              f"{res['minutes']:g} min at rate {res['rate']:g}: slope {fmt(res['memory_slope_mb_per_min'], '.2f')} "
              f"MB/min ({'pass' if res['pass'] else 'FAIL'}: < 1 MB/min); runner rc {res['rc']}")
        if args.json:
            print(json.dumps(res))
        return 0
    names = {n for n in args.cases.split(",") if n}
    known = {c.name for g, spec in GRAPHS.items() for c in cases_for(g, spec[2])} | \
        {c.name for c in faults_drivers.cases()}
    if names - known:
        ap.error(f"unknown case(s) {', '.join(sorted(names - known))}; known: {', '.join(sorted(known))}")
    if args.keep:
        Path(args.keep).mkdir(parents=True, exist_ok=True)
    graphs = args.graph or [*GRAPHS, "drivers"]
    bag_graphs = [g for g in graphs if g in GRAPHS]
    results, cleans = run(bag_graphs, names, args.domain_id, args.keep) if bag_graphs else ([], [])
    dres = faults_drivers.run(names, args.domain_id, args.keep) if "drivers" in graphs else []
    tot = totals(results, cleans)
    text = markdown(results, cleans, tot) if results or cleans else ""
    if dres:  # one set of totals over every case; the drivers' own criteria under "drivers"
        dtot = faults_drivers.totals(dres)
        tot = dict(tot, drivers=dtot, **{k: tot[k] + dtot[k] for k in ("cases", "passes", "crashes")})
        text += ("\n" if text else "") + faults_drivers.markdown(dres, dtot)
    results = results + dres
    print(text)
    if args.write_docs:
        docs = args.write_docs
        write_docs(docs, merged_docs(docs.read_text() if docs.exists() else "", [r for r in results
                                    if r["graph"] != "drivers"], cleans, dres))
    if args.json:
        print(json.dumps({"cases": results, "clean": cleans, "totals": tot}, default=str))
    return 0
