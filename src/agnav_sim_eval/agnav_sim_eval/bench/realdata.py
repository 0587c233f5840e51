"""`agnav bench realdata [--json] [--write-docs PATH]`: the navigation sensor module graph on real recordings.

Runs `agnav run CONFIG --bag BAG --record` (the real nodes, as fast as the graph goes) on robot_localization's
test1 (Husky, rotated Microstrain IMU, SBAS 2.5 Hz; config test1) and the VN-100 car-circles log (config nuance;
bag from agnav_drivers.csv_import). No ground truth: heading is scored against the GNSS course over ground (the
chord between the fixes about ±half-chord s around each fix, where its speed exceeds MIN_SPEED; the chord's own
noise, ≈ √2 σ_fix / length, is listed; the nuance log has no GPS accuracy and 2.5 m is assumed, so there it is an
upper bound), position against the fixes themselves (the filter's own input: a
consistency check, not accuracy), and every output is checked for NaN and divergence (> DIVERGED_M from the fixes).
GNSS outages: test1 is replayed again with the fixes removed over OUTAGES (30 s each, s after the first fix), with
and without its wheel odometry (/husky_velocity_controller/odom replayed as /wheel/odometry: the module's optional
speed input); the dead-reckoned position is scored against the removed fixes (end of the outage, worst, and the
RMS over the 10 s after the fixes return).
Cost: bag duration / wall time of the whole replay (graph start-up included) = × real time; the simulated
asphalt_loop replay of `agnav run nsm` (the `make run` graph) is timed and scored against its truth as well.
"""
import argparse
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from rosbags.highlevel import AnyReader

from agnav_sim_eval.evaluate import KEYS, evaluate_bags, odometry_arrays, read_bag
from agnav_bringup.graph_config import REPO_ROOT, load_config
from agnav_sim_eval.bench import docs_option, report
from agnav_common.bagio import filter_bag
from agnav_common.frames import wrap_angle
from agnav_common.geodesy import LocalTangentPlane

REPO = REPO_ROOT
DATASETS = {  # name: (config, bag, the bag's fix topic, half-chord s of the course over ground, wheel odometry)
    "test1": ("test1", REPO / "bags" / "test1", "/fix", 3.0, True),         # 2.5 Hz SBAS at ~1 m/s: 6 m chord
    "test1 without wheel odometry": ("test1", REPO / "bags" / "test1", "/fix", 3.0, False),
    "nuance_car_circles": ("nuance", REPO / "bags" / "nuance_car_circles", "/gnss/fix", 1.5, False),  # 1 Hz
}
WHEEL_TOPIC = "/wheel/odometry"
OUTAGES = ((100.0, 130.0), (250.0, 280.0))  # s after test1's first fix
AFTER_OUTAGE = 10.0  # s after the fixes return, scored for re-convergence
DEAD_RECKONING_FROM = 20.0  # s after test1's first fix: no fixes after (the heading is initialised by then)
SIMULATED = ("nsm", REPO / "bags" / "asphalt_loop")
MIN_SPEED = 1.0     # m/s, GNSS course is scored above this speed
DIVERGED_M = 10.0   # m from the fixes: diverged
RL_FINAL = (-40.05, -77.00)  # m, robot_localization's regression end point on test1 (its odom frame), ± 1.05 m
DEG = 180.0 / math.pi


def _rms(a):
    a = np.asarray(a, float)
    return float(np.sqrt(np.mean(a * a))) if a.size else None


def config_variant(config, tmp, wheel):
    """The config (name or path), or a copy in tmp whose player does not replay the wheel odometry."""
    cfg = load_config(config)
    raw = yaml.safe_load(cfg.path.read_text())
    remap = raw.get("bag_remap") or {}
    if wheel or WHEEL_TOPIC not in remap.values():
        return config
    raw["bag_remap"] = {k: v for k, v in remap.items() if v != WHEEL_TOPIC}
    path = Path(tmp) / f"{cfg.path.stem}_no_wheel.yaml"
    path.write_text(yaml.safe_dump(raw))
    return str(path)


def without_fixes(src, dst, topic, windows):
    """Copy of bag src at dst without the `topic` messages inside windows (s after its first `topic` message)."""
    with AnyReader([Path(src)]) as reader:
        t0 = next(t for _, t, _ in reader.messages([c for c in reader.connections if c.topic == topic]))
    filter_bag(src, dst, lambda name, t: name != topic or not any(a <= (t - t0) * 1e-9 <= b for a, b in windows))


def replay(config, bag, out):
    """Run the graph; returns wall seconds."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "agnav_bringup.cli", "run", config, "--bag", str(bag),
                           "--record", str(out), "--quiet", "--no-eval"], env=env, cwd=REPO,
                          capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(f"agnav run {config} failed:\n{proc.stdout}\n{proc.stderr}")
    return time.perf_counter() - start


def fixes_enu(samples, datum):
    plane = LocalTangentPlane(*datum)
    a = np.array([(t, m.latitude, m.longitude, m.altitude) for t, m in samples
                  if m.status.status >= 0 and np.isfinite(m.latitude)], float)
    e, n, _ = plane.to_enu(a[:, 1], a[:, 2], a[:, 3])
    return a[:, 0], np.asarray(e, float), np.asarray(n, float)


def course_over_ground(t, e, n, half):
    """(t, course yaw rad, speed m/s, chord length m) from the chord between the fixes about `half` s before and
    after each fix."""
    rows = []
    for k in range(len(t)):
        i, j = np.searchsorted(t, t[k] - half), np.searchsorted(t, t[k] + half, side="right") - 1
        if i < k < j:
            de, dn, dt = e[j] - e[i], n[j] - n[i], t[j] - t[i]
            rows.append((t[k], math.atan2(dn, de), math.hypot(de, dn) / dt, math.hypot(de, dn)))
    return np.array(rows, float).reshape(-1, 4).T


def outputs_and_fixes(out, source, fix_topic):
    """The recorded odometry (arrays + horizontal σ per sample) and the input bag's fixes in its map frame."""
    bag = read_bag(out, ["/odometry/filtered", "/map_datum"])
    fixes = read_bag(source, [fix_topic])[fix_topic]
    datum = bag["/map_datum"][-1][1]
    tf, e, n = fixes_enu(fixes, (datum.latitude, datum.longitude, datum.altitude))
    sigma = np.array([math.sqrt(m.pose.covariance[0] + m.pose.covariance[7]) for _, m in bag["/odometry/filtered"]])
    return odometry_arrays(bag["/odometry/filtered"]), sigma, fixes, tf, e, n


def position_error(est, tf, e, n, sel):
    """Horizontal distance (m) of the odometry from the fixes selected by sel, at their epochs."""
    return np.hypot(np.interp(tf[sel], est["t"], est["x"]) - e[sel], np.interp(tf[sel], est["t"], est["y"]) - n[sel])


def score(out, source, fix_topic, half, bag_duration):
    """Scores the recorded outputs against the fixes of the input bag `source`."""
    est, sigma, fixes, tf, e, n = outputs_and_fixes(out, source, fix_topic)
    fix_sigma = float(np.median([math.sqrt(m.position_covariance[0]) for _, m in fixes]))
    values = np.column_stack([est[k] for k in ("x", "y", "z", "roll", "pitch", "yaw")])
    dpos = position_error(est, tf, e, n, (tf >= est["t"][0]) & (tf <= est["t"][-1]))
    tc, cog, speed, chord = course_over_ground(tf, e, n, half)
    moving = (speed > MIN_SPEED) & (tc >= est["t"][0]) & (tc <= est["t"][-1])
    yaw = wrap_angle(np.interp(tc[moving], est["t"], np.unwrap(est["yaw"])))
    dyaw = wrap_angle(yaw - cog[moving]) * DEG
    return {
        "duration_s": bag_duration, "odometry": int(len(est["t"])), "fixes": int(len(tf)),
        "initialised_after_s": float(est["t"][0] - tf[0]),
        "finite": bool(np.all(np.isfinite(values)) and np.all(np.isfinite(sigma))),
        "diverged": bool(dpos.size == 0 or dpos.max() > DIVERGED_M),
        "odometry_to_last_fix_s": float(tf[-1] - est["t"][-1]),  # > 0: the output stopped before the input
        "heading_vs_cog_deg": {"rms": _rms(dyaw), "max": float(np.abs(dyaw).max()) if dyaw.size else None,
                               "mean": float(dyaw.mean()) if dyaw.size else None, "epochs": int(dyaw.size),
                               "cog_noise": float(np.median(math.sqrt(2) * fix_sigma / chord[moving]) * DEG)
                               if dyaw.size else None},
        "position_vs_fix_m": {"rms": _rms(dpos), "max": float(dpos.max()) if dpos.size else None},
        "position_sigma_m": {"median": float(np.median(sigma)), "max": float(sigma.max())},
        "end_displacement_m": [float(est["x"][-1] - est["x"][0]), float(est["y"][-1] - est["y"][0])],
        "fix_end_displacement_m": [float(e[-1] - e[0]), float(n[-1] - n[0])],
        "roll_pitch_deg_p99": [float(np.percentile(np.abs(est[k]), 99) * DEG) for k in ("roll", "pitch")],
    }


def score_outages(out, source, fix_topic, windows):
    """Per outage window: the output's position against the removed fixes and its reported σ, up to its last output
    (the node stops publishing once its heading σ passes heading_lost_sigma: `published_s` of the window)."""
    est, sigma, _, tf, e, n = outputs_and_fixes(out, source, fix_topic)
    rel = tf - tf[0]
    rows = []
    for a, b in windows:
        inside, after = (rel >= a) & (rel <= b) & (tf <= est["t"][-1]), (rel > b) & (rel <= b + AFTER_OUTAGE)
        err = position_error(est, tf, e, n, inside)
        t_in = est["t"][(est["t"] >= tf[0] + a) & (est["t"] <= tf[0] + b)]
        rows.append({"window_s": [a, b], "travelled_m": float(np.sum(np.hypot(np.diff(e[inside]), np.diff(n[inside])))),
                     "end_m": float(err[-1]), "max_m": float(err.max()),
                     "after_rms_m": _rms(position_error(est, tf, e, n, after)),
                     "sigma_end_m": float(np.interp(tf[inside][-1], est["t"], sigma)),
                     "published_s": float(tf[inside][-1] - tf[0] - a),
                     "max_output_gap_s": float(np.diff(t_in).max()) if t_in.size > 1 else None})
    return rows


def bag_duration(path):
    with AnyReader([Path(path)]) as reader:
        return (reader.end_time - reader.start_time) * 1e-9


def run(names, simulated=True):
    results = {}
    with tempfile.TemporaryDirectory(prefix="agnav_realdata_") as tmp:
        for k, name in enumerate(names):
            config, bag, fix_topic, half, wheel = DATASETS[name]
            out = Path(tmp) / f"run{k}"
            variant = config_variant(config, tmp, wheel)
            wall = replay(variant, bag, out)
            res = score(out, bag, fix_topic, half, bag_duration(bag))
            res.update(config=config if variant == config else f"{config} without {WHEEL_TOPIC}",
                       wall_s=wall, x_real_time=res["duration_s"] / wall)
            results[name] = res
        if "test1" in names:
            config, bag, fix_topic, _, _ = DATASETS["test1"]
            gapped = Path(tmp) / "test1_outages"
            without_fixes(bag, gapped, fix_topic, OUTAGES)
            results["outages"] = {}
            for wheel in (True, False):
                out = Path(tmp) / f"outage_{wheel}"
                replay(config_variant(config, tmp, wheel), gapped, out)
                results["outages"]["wheel odometry" if wheel else "no wheel odometry"] = score_outages(
                    out, bag, fix_topic, OUTAGES)
            # robot_localization's regression is wheel odometry + IMU without GNSS: ours the same way from 20 s
            dr_bag, out = Path(tmp) / "test1_dead_reckoning", Path(tmp) / "dead_reckoning"
            without_fixes(bag, dr_bag, fix_topic, ((DEAD_RECKONING_FROM, math.inf),))
            replay(config, dr_bag, out)
            est = odometry_arrays(read_bag(out, ["/odometry/filtered"])["/odometry/filtered"])
            last = score_outages(out, bag, fix_topic, ((DEAD_RECKONING_FROM, math.inf),))[0]
            results["dead_reckoning"] = dict(last, end_from_first_pose_m=[float(est["x"][-1] - est["x"][0]),
                                                                          float(est["y"][-1] - est["y"][0])])
        if simulated:
            config, bag = SIMULATED
            out = Path(tmp) / bag.name
            wall = replay(config, bag, out)
            metrics = evaluate_bags(out, bag)[0]
            results[bag.name] = {"config": config, "duration_s": bag_duration(bag), "wall_s": wall,
                                 "x_real_time": bag_duration(bag) / wall,
                                 **{k: metrics[k] for k in KEYS}}
    return results


def _f(v, fmt=".2f"):
    return "–" if v is None else format(v, fmt)


def markdown(results):
    lines = [f"# Real data (`agnav bench realdata --write-docs docs/benchmarks/realdata.md`)", "", __doc__.split("\n\n", 1)[1].strip(), "",
             "| data | config | duration s | heading − COG RMS / max / mean deg (epochs > 1 m/s) | COG noise deg "
             "| position − fix RMS / max m | σ_xy median / max m | NaN | diverged | init after s | last fix after last output s "
             "| replay × real time |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    real = {k: r for k, r in results.items() if "heading_vs_cog_deg" in r}
    for name, r in real.items():
        h, p, s = r["heading_vs_cog_deg"], r["position_vs_fix_m"], r["position_sigma_m"]
        lines.append(f"| {name} | {r['config']} | {r['duration_s']:.0f} | {_f(h['rms'])} / {_f(h['max'])} / "
                     f"{_f(h['mean'])} ({h['epochs']}) | {_f(h['cog_noise'], '.1f')} | {_f(p['rms'])} / {_f(p['max'])} | {_f(s['median'])} / "
                     f"{_f(s['max'])} | {'no' if r['finite'] else 'YES'} | {'YES' if r['diverged'] else 'no'} | "
                     f"{r['initialised_after_s']:.1f} | {r['odometry_to_last_fix_s']:.2f} | {r['x_real_time']:.1f} |")
    if results.get("outages"):
        lines += ["", "GNSS outages on test1 (fixes removed from the input; errors against the removed fixes, whose "
                  "own noise is the σ_xy above):", "",
                  "| outage s after first fix | travelled m | input | error at the end m | max error m | σ_xy at the end m "
                  "| RMS error 10 s after m | longest output gap s |", "|---|---|---|---|---|---|---|---|"]
        for label, rows in results["outages"].items():
            for r in rows:
                lines.append(f"| {r['window_s'][0]:.0f}–{r['window_s'][1]:.0f} | {r['travelled_m']:.1f} | {label} | "
                             f"{r['end_m']:.2f} | {r['max_m']:.2f} | {r['sigma_end_m']:.2f} | {_f(r['after_rms_m'])} | "
                             f"{_f(r['max_output_gap_s'], '.3f')} |")
    name = SIMULATED[1].name
    if name in results:
        r = results[name]
        lines += ["", f"Simulated {name} through `agnav run {r['config']}` (the `make run` graph, against truth): "
                  + ", ".join(f"{k} RMS {_f(r[k]['rms'])} (max {_f(r[k]['max'])})" for k in KEYS)
                  + f"; replay {r['duration_s']:.0f} s in {r['wall_s']:.0f} s wall = **{r['x_real_time']:.1f} × real "
                  "time** (one process: the graph's nodes, bag player and recorder on one EventsExecutor; the "
                  "machine's load at the time counts)."]
    if "test1" in results:
        d, f = results["test1"]["end_displacement_m"], results["test1"]["fix_end_displacement_m"]
        lines += ["", f"test1 end point: robot_localization's own regression (its EKF on wheel-odometry velocity + "
                  f"the IMU's absolute orientation, in its odom frame from the first pose) ends at ({RL_FINAL[0]}, "
                  f"{RL_FINAL[1]}) m ± 1.05 m, {math.hypot(*RL_FINAL):.1f} m from the start. The SBAS fixes put the "
                  f"end ({f[0]:.1f}, {f[1]:.1f}) m ENU from the first fix ({math.hypot(*f):.1f} m), and our module "
                  f"(GNSS + gyro + wheel odometry) ({d[0]:.1f}, {d[1]:.1f}) m from its first published pose "
                  f"({math.hypot(*d):.1f} m). That regression value is wheel-odometry dead reckoning over the whole "
                  f"run without GNSS, at least {math.hypot(*RL_FINAL) - math.hypot(*f):.0f} m from where the fixes "
                  "end whatever the rotation between the frames, so it is no reference for a GNSS-aided position."]
        if "dead_reckoning" in results:
            r = results["dead_reckoning"]
            e = r["end_from_first_pose_m"]
            lines[-1] += (f" With every fix after {DEAD_RECKONING_FROM:.0f} s removed, the module dead-reckons on "
                          f"wheel odometry + gyro for {r['published_s']:.0f} s ({r['travelled_m']:.0f} m) and then stops "
                          f"publishing (its heading σ passes heading_lost_sigma); its last output is {r['end_m']:.1f} m "
                          f"from the removed fix of that moment (worst {r['max_m']:.1f} m) with σ_xy "
                          f"{r['sigma_end_m']:.1f} m, ({e[0]:.1f}, {e[1]:.1f}) m from its first pose.")
    lines += ["", "Data notes: test1's IMU mount is upstream's `static_transform_publisher 0 -0.3 0.52 -1.5708 0 1.5708` "
              "(x y z yaw pitch roll), i.e. rpy (π/2, 0, −π/2) — its +y axis points up and reads +9.8 m/s² at rest; "
              "nuance's GPS stamps run 4.8 s behind its IMU clock (fixed in the bag by csv_import --gps-time-offset; "
              "uncorrected, the module loses the heading at the first lap and drives backwards), and its IMU log ends 6.1 s "
              "before the last fix, hence the output's early end there. test1's own /imu/data is the raw Microstrain "
              "stream: the config replays it as /imu/data_raw (bag_remap), since /imu/data is the module's output."]
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(prog="agnav bench realdata", description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object on the last line")
    docs_option(ap, "realdata.md")
    ap.add_argument("--only", choices=sorted(DATASETS), action="append", help="run only this real data set")
    ap.add_argument("--no-sim", action="store_true", help="skip the simulated asphalt_loop timing run")
    args = ap.parse_args(argv)
    results = run(args.only or list(DATASETS), simulated=not args.no_sim)
    text = markdown(results)
    report(args, text, results)
    return 0
