"""`agnav bench steer [--json] [--write-docs PATH]`: straight-line autosteer in the offline closed loop
(TractorSimulator sensor samples -> agnav_fusion NavSensorModule / variable-target VWA -> controller; never truth
to the controller) and the SteeringNode fail-safe reaction through real rclpy.

Thesis conditions (SPEC §5.3 R4-7/8, §3.6 R2-19): rtk_straight_fast = 3 m manual drive from standstill, engage
request (granted once the cold-started fusion passes the engage gates) then 150 m at 4.3 m/s,
RTK 5 Hz, antenna (0, -1.67, 3.23) m, with and without tilt correction, default controller PID (ch. IV);
gds_straight_slow = 5 m manual then 35 m at 0.5 m/s, GDS + FOG VWA variable target, thesis law (2.6)-(2.7).
Settling: the RTK run engaged on a line 0.5 m beside the vehicle; distance until |e| stays < 10 cm (mean over seeds).
Issue 15 acceptance on seeds from 1000 (never tuned on): rtk_straight_fast (RTK 4.3 m/s, tilled field) and
dgps_slope_crab (DGPS 1 Hz, 1.5 m/s across a 5 deg slope, 1.5 deg crab) through the navigation pipeline with the
default gates, and dgps_slope_crab on perfect state with and without the crab feed-forward.
"""
import argparse
import sys

import numpy as np
from agnav_sim_eval.closed_loop import ClosedLoopSettings, run
from agnav_control.controllers import CONTROLLERS
from agnav_control.watchdog_probe import measure_reaction

from agnav_bringup.graph_config import REPO_ROOT
from agnav_sim_eval.bench import docs_option, report

RTK = dict(scenario="rtk_straight_fast", manual_distance=3.0, auto_distance=150.0)
GDS = dict(scenario="gds_straight_slow", manual_distance=5.0, auto_distance=35.0)
DGPS = dict(scenario="dgps_slope_crab", manual_distance=3.0, auto_distance=150.0)
ACCEPTANCE = {"rtk_tilled": RTK, "dgps_slope_crab": DGPS, "truth_crab": dict(DGPS, estimator="truth"),
              "truth_crab_no_ff": dict(DGPS, estimator="truth", crab_feed_forward=False)}
FIRST_REPORT_SEED = 1000  # seeds below are for tuning
DEFAULT = {"rtk": "pid", "gds": "thesis_pi"}


def _rms_cm(a):
    return 100 * float(np.sqrt(np.mean(np.square(a))))


def _mean_runs(seeds, **kw):
    runs = [run(ClosedLoopSettings(seed=s, **kw)) for s in seeds]
    return {"rms_cm": float(np.mean([100 * r.rms for r in runs])),
            "max_cm": float(np.max([100 * r.max_abs for r in runs])),
            "distance_m": float(np.mean([r.along[-1] for r in runs])),
            "engaged_at_m": float(np.mean([r.engaged_at for r in runs])),
            "per_seed_rms_cm": [100 * r.rms for r in runs],
            # error budget per seed: true = tracking (the controller's cross-track) - estimation error
            "budget": [{"seed": s, "rms_cm": 100 * r.rms, "estimate_rms_cm": _rms_cm(r.estimated - r.cross_track),
                        "estimate_mean_cm": 100 * float(np.mean(r.estimated - r.cross_track)),
                        "tracking_rms_cm": _rms_cm(r.estimated),
                        "gnss_lateral_mean_cm": 100 * float(np.mean(r.gnss_error)) if len(r.gnss_error) else None,
                        "gnss_lateral_rms_cm": _rms_cm(r.gnss_error) if len(r.gnss_error) else None}
                       for s, r in zip(seeds, runs)]}


def measure(seeds, watchdog_trials):
    out = {"seeds": list(seeds)}
    cases = {"rtk_tilt": dict(RTK, tilt=True), "rtk_notilt": dict(RTK, tilt=False), "gds": GDS}
    controllers = {}
    for name in CONTROLLERS:
        row = {}
        for case, kw in cases.items():
            row[case] = _mean_runs(seeds, controller=name, **kw)
        offsets = [run(ClosedLoopSettings(seed=s, controller=name, line_offset=0.5, **RTK)) for s in seeds]
        row["settling_m"] = float(np.mean([r.settling_distance(0.1) for r in offsets]))
        controllers[name] = row
    out["controllers"] = controllers
    for case, key in (("rtk_tilt", "rtk_fast_tilt"), ("rtk_notilt", "rtk_fast_notilt"), ("gds", "gds_slow")):
        best = controllers[DEFAULT["gds" if case == "gds" else "rtk"]][case]
        out[f"{key}_rms_cm"], out[f"{key}_max_cm"] = best["rms_cm"], best["max_cm"]
    reactions = measure_reaction(watchdog_trials)
    out["watchdog_reaction_ms"] = 1000 * float(np.mean(reactions))
    out["watchdog_reaction_max_ms"] = 1000 * float(np.max(reactions))
    return out


def _acceptance_case(seeds, kw):
    """Default controller on each seed: RMS / mean of the true cross-track, fail-safe disengages (never engaged
    counts as one)."""
    rms, means, disengages = [], [], 0
    for seed in seeds:
        try:
            r = run(ClosedLoopSettings(seed=seed, controller=DEFAULT["rtk"], **kw))
        except RuntimeError:
            disengages += 1
            continue
        disengages += r.disengaged is not None
        rms.append(100 * r.rms)
        means.append(100 * r.mean)
    return {"rms_cm": float(np.mean(rms)) if rms else float("nan"), "max_rms_cm": max(rms, default=float("nan")),
            "mean_cm": float(np.mean(means)) if means else float("nan"),
            "max_abs_mean_cm": max(map(abs, means), default=float("nan")), "disengages": disengages,
            "per_seed_rms_cm": rms, "per_seed_mean_cm": means}


def measure_acceptance(seeds):
    out = {"acceptance_seeds": list(seeds), "acceptance": {k: _acceptance_case(seeds, kw) for k, kw in ACCEPTANCE.items()}}
    a = out["acceptance"]
    out.update(rtk_tilled_xtrack_rms_cm=a["rtk_tilled"]["rms_cm"], rtk_tilled_disengages=a["rtk_tilled"]["disengages"],
               dgps_slope_crab_xtrack_rms_cm=a["dgps_slope_crab"]["rms_cm"],
               dgps_slope_crab_mean_cm=a["dgps_slope_crab"]["mean_cm"],
               dgps_slope_crab_max_abs_mean_cm=a["dgps_slope_crab"]["max_abs_mean_cm"],
               dgps_slope_crab_disengages=a["dgps_slope_crab"]["disengages"],
               truth_crab_mean_cm=a["truth_crab"]["mean_cm"], truth_crab_no_ff_mean_cm=a["truth_crab_no_ff"]["mean_cm"])
    return out


def acceptance_table(r):
    a = r["acceptance"]
    rows = [("RTK 4.3 m/s, tilled field (rtk_straight_fast)", "rtk_tilled", "RMS ≤ 2.5"),
            ("DGPS 1 Hz, 1.5 m/s, 5° slope, 1.5° crab (dgps_slope_crab)", "dgps_slope_crab",
             "RMS ≤ 8, abs(mean) ≤ 2, 0 disengages"),
            ("same, perfect state, crab feed-forward (twist linear.y)", "truth_crab", "abs(mean) ≤ 1"),
            ("same, perfect state, no feed-forward (integral only)", "truth_crab_no_ff", "—")]
    lines = [f"Issue 15 closed-loop acceptance, default controller ({DEFAULT['rtk']}) and default gates, seeds "
             f"{r['acceptance_seeds']} (not used for tuning):", "",
             "| run | RMS mean / worst (cm) | mean offset: mean / worst abs (cm) | fail-safe disengages | goal |",
             "|---|---|---|---|---|"]
    for label, key, goal in rows:
        c = a[key]
        lines.append(f"| {label} | {c['rms_cm']:.2f} / {c['max_rms_cm']:.2f} | {c['mean_cm']:+.2f} / "
                     f"{c['max_abs_mean_cm']:.2f} | {c['disengages']} | {goal} |")
    return lines


MATERIAL = 0.05  # relative RMS gain below which a controller does not "clearly" beat the default


def _versus_default(r):
    """Each other controller against the RTK default on the same seeds: relative RTK tilt RMS change, seeds won,
    settling change (m), relative no-tilt RMS change, and whether it clearly wins (the bar for changing the product
    default): tilt and no-tilt RMS both lower by >= MATERIAL, lower tilt RMS on all seeds but one, shorter settling."""
    d = r["controllers"][DEFAULT["rtk"]]
    out = []
    for name, row in r["controllers"].items():
        if name == DEFAULT["rtk"]:
            continue
        tilt = row["rtk_tilt"]["rms_cm"] / d["rtk_tilt"]["rms_cm"] - 1.0
        notilt = row["rtk_notilt"]["rms_cm"] / d["rtk_notilt"]["rms_cm"] - 1.0
        wins = sum(a < b for a, b in zip(row["rtk_tilt"]["per_seed_rms_cm"], d["rtk_tilt"]["per_seed_rms_cm"]))
        settling = row["settling_m"] - d["settling_m"]
        clear = tilt <= -MATERIAL and notilt <= -MATERIAL and wins >= len(r["seeds"]) - 1 and settling < 0.0
        out.append((name, tilt, wins, settling, notilt, clear))
    return out


def table(r):
    rtk, gds = DEFAULT["rtk"], DEFAULT["gds"]
    lines = [
        "# Steering benchmark (`agnav bench steer`)", "", *acceptance_table(r), "",
        "Offline closed loop: simulated sensor samples -> agnav_fusion NavSensorModule (RTK rows, configured as the live",
        "`steer` graph) or the variable-target VWA (GDS row) -> controller -> simulated tractor; scored on the true",
        "base_link cross-track to the desired line. "
        f"Seeds {r['seeds']} (RMS = mean over seeds, max = max over seeds).", "",
        "| run | thesis RMS / max (cm) | agnav RMS / max (cm) | goal |", "|---|---|---|---|",
        f"| RTK 4.3 m/s, tilt-corrected ({rtk}) | 3.8 / 9.6 | {r['rtk_fast_tilt_rms_cm']:.2f} / {r['rtk_fast_tilt_max_cm']:.2f} | RMS ≤ 2.5 |",
        f"| RTK 4.3 m/s, no tilt correction ({rtk}) | 10.4 / 25 | {r['rtk_fast_notilt_rms_cm']:.2f} / {r['rtk_fast_notilt_max_cm']:.2f} | — |",
        f"| GDS + FOG VWA 0.5 m/s, 35 m ({gds}) | 6.4 / 11.4 | {r['gds_slow_rms_cm']:.2f} / {r['gds_slow_max_cm']:.2f} | RMS ≤ 5 |",
        f"| watchdog: last odometry -> neutral command (rclpy) | — | {r['watchdog_reaction_ms']:.0f} ms mean, "
        f"{r['watchdog_reaction_max_ms']:.0f} ms max | ≤ 200 ms |", "",
        "Per controller (RMS / max cm; settling = metres after engaging 0.5 m off the line until |e| < 10 cm, "
        "mean over seeds):", "",
        "| controller | RTK tilt | RTK tilt RMS per seed | RTK no tilt | GDS VWA | settling (m) |",
        "|---|---|---|---|---|---|"]
    for name, row in r["controllers"].items():
        cells = [f"{row[c]['rms_cm']:.2f} / {row[c]['max_cm']:.2f}" for c in ("rtk_tilt", "rtk_notilt", "gds")]
        seeds = ", ".join(f"{v:.2f}" for v in row["rtk_tilt"]["per_seed_rms_cm"])
        lines.append(f"| {name} | {cells[0]} | {seeds} | {cells[1]} | {cells[2]} | {row['settling_m']:.1f} |")
    versus = _versus_default(r)
    lines += ["", f"Default RTK controller: **{rtk}** (product decision). It changes only if another controller clearly "
              f"beats it on the same seeds: RTK tilt and no-tilt RMS both lower by >= {100 * MATERIAL:.0f} %, lower tilt "
              "RMS on all seeds but one, and shorter settling.", "",
              f"| vs {rtk} | RTK tilt RMS | seeds won (tilt) | settling | RTK no-tilt RMS | clearly better |",
              "|---|---|---|---|---|---|"]
    for name, tilt, wins, settling, notilt, clear in versus:
        lines.append(f"| {name} | {100 * tilt:+.1f} % | {wins} / {len(r['seeds'])} | {settling:+.1f} m | "
                     f"{100 * notilt:+.1f} % | {'yes' if clear else 'no'} |")
    winners = [v[0] for v in versus if v[5]]
    lines += ["", f"Decision: {'revisit the default: ' + ', '.join(winners) + ' clearly better' if winners else 'keep ' + rtk + ' (no controller clearly better)'}."]
    lines += ["", f"Error budget of the default RTK tilt-corrected run (cm): true cross-track = controller's cross-track "
              "(tracking) minus the estimate's error; the GNSS column is the fix error across the line while engaged.", "",
              "| seed | true RMS | estimate error RMS / mean | tracking RMS | GNSS lateral RMS / mean |", "|---|---|---|---|---|"]
    for b in r["controllers"][rtk]["rtk_tilt"]["budget"]:
        lines.append(f"| {b['seed']} | {b['rms_cm']:.2f} | {b['estimate_rms_cm']:.2f} / {b['estimate_mean_cm']:+.2f} | "
                     f"{b['tracking_rms_cm']:.2f} | {b['gnss_lateral_rms_cm']:.2f} / {b['gnss_lateral_mean_cm']:+.2f} |")
    engaged, scored = (r["controllers"][rtk]["rtk_tilt"][k] for k in ("engaged_at_m", "distance_m"))
    lines += ["", "Reproduce: `agnav bench steer --json --write-docs docs/benchmarks/steer.md [--seeds N]`.",
              "RTK start as the thesis' operator: 3 m manual from standstill, then the engage request; the steering "
              "node's engage gate (position std <= 5 cm, yaw std <= 0.01 rad) grants it at "
              f"{engaged:.1f} m travelled (mean); {scored:.0f} m are scored (mean, at most 150 m: up to the braking "
              "for the end of the scenario's 170 m route). The cold-started "
              "NavSensorModule takes its heading from the 3 m chord between moving fixes (module default "
              "heading_init_speed 0.3 m/s) and its lever-arm velocity from rates averaged over 0.2 s, so the former "
              "40 m drive at >= 3 m/s on a 230 m route is gone. One setting stays in "
              "agnav_sim_eval.fusion_adapters.rtk_fog_settings (= config/steer.yaml): still_rate_sigma = 0.148 rad/s, "
              "the FOG's per-sample rate noise (differentiated 0.06 deg angle noise at 100 Hz). With the module's "
              "0.01 rad/s default (a vibratory gyro's) the standstill zero-rate update followed the last samples "
              "(seed 4 learnt -0.019 rad/s at the moment of moving off), the heading then drifted ~1 deg for 25 m "
              "while its std said 0.2 deg, and the 3 m start measured 4.04 cm RMS (seed 4: 6.03 / 20.9 cm) with PID.",
              "No-tilt row: the level attitude leaves the antenna's sway (3.23 m x roll rate, ~0.2 m/s on this "
              "field) in the GNSS velocity the module now fuses by default and in the 3 m chord, so the cold start "
              "swings the heading: its max is a start transient (seed 3: 52 cm RMS 20-30 m after engaging, ~5 cm "
              "beyond 60 m). Measured while choosing the start (PID, seeds 1-5): a 15 m manual start still gives "
              "11.1 cm RMS, GNSS velocity fusion off 21.8 cm; the 40 m start with the previous module gave 7.20 / 25.7.",
              "The simulated 7400MSi RTK fix carries a slow Gauss-Markov bias (sigma 2 cm, tau 60 s): its lateral mean "
              "over a 35 s run is invisible to every estimator and is the floor of the RTK rows (estimate error mean "
              "follows the GNSS lateral mean above).", ""]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="agnav bench steer", description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object on the last line")
    docs_option(ap, "steer.md")
    ap.add_argument("--seeds", type=int, default=5, help="simulator seeds 1..N per case")
    ap.add_argument("--watchdog-trials", type=int, default=5)
    ap.add_argument("--acceptance-seeds", type=int, default=5, help=f"seeds {FIRST_REPORT_SEED}.. of the issue 15 cases")
    args = ap.parse_args(argv)
    result = measure(list(range(1, args.seeds + 1)), args.watchdog_trials)
    result.update(measure_acceptance(range(FIRST_REPORT_SEED, FIRST_REPORT_SEED + args.acceptance_seeds)))
    text = table(result)
    report(args, text, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
