"""`agnav bench ins_tight [--json] [--write-docs PATH]`: raw-GNSS double-difference baselines on real data.

Issue 18 (tightly coupled GNSS/INS), raw-GNSS slices: the static real pair of MatRTKLIB (Septentrio mosaic-X5
rover + base, 1 Hz, 301 epochs, GPS L1C/L2W, Galileo E1C/E5aQ, QZSS L1C/L2L, BeiDou B1I/B2bI, 15° elevation
and 35 dB-Hz masks) through agnav_fusion.gnss_raw: satellite states from the broadcast ephemerides (cssrlib),
DDs with their correlated covariance (σ_code 1.5 m: multipath correlated over ~10 s), the float EKF (rover
position + DD ambiguities in metres, ambiguity random walk 3e-4 m/√s) and instantaneous integer fixing (numpy
LAMBDA, ratio ≥ 3) at every epoch; `first_slice` repeats the runs with the first slice's σ_code 0.3 m / 1e-4. Errors are against the known
baseline (rover_position.txt − base_position.txt, |b| ≈ 0.99 m); the fix rate sits next to RTKLIB's on the
same data (rover_rtk.pos: kinematic, L1+L2, instantaneous AR, 301/301 fixed).
Two runs: 'kinematic' (position re-estimated each epoch, as RTKLIB's run and a moving rover) gives the fix rate,
the fixed errors and the cost; 'static' (position held, float only) gives the converged float baseline.
Cost: ms per epoch of satellite states + DDs + EKF + LAMBDA (RINEX parsing excluded) of the kinematic run;
`cost_ms_per_epoch_20sat` the same with both receivers cut to the 20 satellites highest at the first epoch.
Simulated part, through the shipped pipeline (agnav_sim_eval.offline.pipeline_for('ins_tight'): what `agnav run
ins_tight` publishes): the switching runs of sim.gnss_raw_sim_bag (mems_field, seeds `--seeds`, default SIM_SEEDS;
RTK fixed, float under a tree line, 3 GPS satellites, outage, float, fixed) replayed from their bags; the loosely
coupled / INS-only comparison is pipeline_for('ins') on the same bag. Horizontal base_link errors against the
truth; `switch_max_jump_sigma` over every mode change (Switching.transitions), `refix_time_s` after the outage;
the worst seed's value of each at the top level, every seed's in `sim_per_seed`; replay speeds of the graph and the
pipeline (x real time).
"""
import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from agnav_sim_eval.bench import docs_option, write_docs
from agnav_sim_eval.sim.gnss_raw_sim_bag import record_raw_run, windows
from agnav_sim_eval.sim.messages import START_EPOCH_S
from agnav_fusion.gnss_raw.baseline import BaselineConfig, process
from agnav_fusion.gnss_raw.geometry import llh_to_ecef, to_enu
from agnav_drivers.ubx import GnssObservations, NavDataFrame, UbxParser
from agnav_fusion.gnss_raw.double_difference import DDConfig
from agnav_fusion.gnss_raw.doppler import code_position, doppler_velocity
from agnav_fusion.gnss_raw.ephemeris import satellite_states
from agnav_fusion.gnss_raw.geometry import elevation_azimuth
from agnav_fusion.gnss_raw.observations import ObsEpoch, match_epochs
from agnav_fusion.gnss_raw.raw_input import SubframeNav, epochs_from_events
from agnav_fusion.gnss_raw.rinex import read_nav, read_obs

SIM_SEEDS = tuple(range(1000, 1010))   # reported; tuned on seeds < 1000 (`--seeds 1,2,3`)
PER_SEED_MAX = ("three_sat_end_err_cm", "three_sat_loose_end_err_cm", "three_sat_max_err_cm", "float_rms_cm",
                "float_loose_rms_cm", "float_max_err_cm", "switch_max_jump_sigma")
DATA = Path("/work/shared/data/real/gnss_raw/matrtklib_static")
WALK = Path("/work/shared/data/real/gnss_raw/gnss_imu_walk")


def load(data=DATA, max_epochs=None):
    """(pairs, nav, base ECEF, rover ECEF) of the static pair."""
    def position(name):
        return llh_to_ecef(*map(float, (data / name).read_text().split()))
    pairs = match_epochs(read_obs(data / "rover.obs", max_epochs=max_epochs),
                         read_obs(data / "base.obs", max_epochs=max_epochs))
    return pairs, read_nav(data / "base.nav"), position("base_position.txt"), position("rover_position.txt")


def rtklib_solution(data=DATA):
    """(fixed epochs, epochs, rover ECEF per fixed epoch) of RTKLIB's rover_rtk.pos."""
    rows = [line.split() for line in (data / "rover_rtk.pos").read_text().splitlines() if line[:1] != "%"]
    fixed = [r for r in rows if r[5] == "1"]
    return len(fixed), len(rows), np.array([llh_to_ecef(*map(float, r[2:5])) for r in fixed])


def _cm(a):
    return round(float(a) * 100, 2)


def subset(epoch, sats):
    """The ObsEpoch restricted to the satellites in `sats`."""
    rows = [i for i, sid in enumerate(epoch.sats) if sid in sats]
    return ObsEpoch(epoch.week, epoch.tow, [epoch.sats[i] for i in rows], epoch.code[rows], epoch.phase[rows],
                    epoch.doppler[rows], epoch.snr[rows], epoch.lli[rows], epoch.wavelength[rows])


def highest(pairs, nav, base, count=20):
    """The `count` satellites (GPS/Galileo/QZSS/BeiDou, seen by both) highest at the first epoch."""
    rover0, base0 = pairs[0]
    sv = satellite_states(base0, nav, base)
    common = [i for i, sid in enumerate(base0.sats) if sv.valid[i] and rover0.row(sid) is not None]
    el = elevation_azimuth(base, sv.pos[common])[0]
    return {base0.sats[common[j]] for j in np.argsort(-el)[:count]}


def _timed(pairs, nav, base, config):
    start = time.perf_counter()
    sols = process(pairs, nav, base, config)
    return sols, (time.perf_counter() - start) / len(sols) * 1e3


def _errors(sols, rover):
    fixed = np.array([np.linalg.norm(s.fixed_pos - rover) for s in sols if s.fixed])
    return fixed, np.array([np.linalg.norm(s.float_pos - rover) for s in sols])


def _gps_tow(date, clock):
    t = np.datetime64(date.replace("/", "-") + "T" + clock) - np.datetime64("1980-01-06T00:00:00")
    return (t / np.timedelta64(1, "us") * 1e-6) % 604800.0


def walk_doppler(data=WALK):
    """Doppler velocity of the u-blox walk (RAWX + SFRBX through the UBX driver's parser) against the receiver's
    own velocity and the central differences of its RTK positions (gnss_1730_sf.pos, 4 Hz)."""
    events = UbxParser().feed((data / "gnss_1730.ubx").read_bytes(), 0.0)
    nav, last = SubframeNav(), None
    for e in events:
        if isinstance(e, GnssObservations):
            last = e
        elif isinstance(e, NavDataFrame) and last is not None:
            nav.add(e.gnss_id, e.sv_id, e.sig_id, e.words, last.week, last.receiver_tow)
    rows = [r.split() for r in (data / "gnss_1730_sf.pos").read_text().splitlines() if r[:1] != "%"]
    tows = np.array([_gps_tow(r[0], r[1]) for r in rows])
    xyz = np.array([llh_to_ecef(*map(float, r[2:5])) for r in rows])
    vel = {round(t * 20): np.array([float(r[16]), float(r[15]), float(r[17])]) for t, r in zip(tows, rows)}
    start, guess, d_vel, d_diff, n_sat = time.perf_counter(), xyz[0], [], [], []
    epochs = epochs_from_events([e for e in events if isinstance(e, GnssObservations)])
    for ep in epochs:
        pos = code_position(ep, satellite_states(ep, nav.nav, guess), guess)
        if pos is None:
            continue
        guess = pos
        v = doppler_velocity(ep, satellite_states(ep, nav.nav, pos), pos)
        k = round(ep.tow * 20)
        if v is None or k not in vel:
            continue
        enu = to_enu(v.vel, pos)
        d_vel.append(enu - vel[k])
        n_sat.append(v.n)
        i = int(np.argmin(np.abs(tows - ep.tow)))
        if 0 < i < len(tows) - 1 and abs(tows[i + 1] - tows[i - 1] - 0.5) < 1e-3:
            d_diff.append(enu - to_enu((xyz[i + 1] - xyz[i - 1]) / 0.5, pos))
    ms = (time.perf_counter() - start) / len(epochs) * 1e3
    d_vel, d_diff = np.array(d_vel), np.array(d_diff)

    def rms(a, cols=slice(None)):
        return round(float(np.sqrt(np.mean(np.sum(a[:, cols] ** 2, axis=1)))) * 100, 1)
    return {"walk_doppler_vel_rms_cm_s": rms(d_vel), "walk_doppler_vel_rms_horizontal_cm_s": rms(d_vel, slice(0, 2)),
            "walk_doppler_vel_rms_enu_cm_s": [round(float(v) * 100, 1) for v in np.sqrt(np.mean(d_vel ** 2, 0))],
            "walk_doppler_vs_pos_diff_rms_cm_s": rms(d_diff),
            "walk_doppler_vs_pos_diff_rms_horizontal_cm_s": rms(d_diff, slice(0, 2)),
            "walk_epochs": f"{len(d_vel)}/{len(epochs)}", "walk_sats_mean": round(float(np.mean(n_sat)), 1),
            "walk_ephemerides": len(nav.nav.eph), "walk_doppler_ms_per_epoch": round(ms, 1)}


def _horizontal_cm(states, plane, bag):
    """(t - START_EPOCH_S, horizontal base_link error [cm]) of pipeline states against the bag's ground truth."""
    from agnav_sim_eval.evaluate import error_series, move_datum, odometry_arrays, read_bag
    ref = read_bag(bag, ["/ground_truth/odometry", "/map_datum"])
    sim = ref["/map_datum"][0][1]
    truth = move_datum(odometry_arrays(ref["/ground_truth/odometry"]), (sim.latitude, sim.longitude, sim.altitude),
                       (plane.lat_deg, plane.lon_deg, plane.alt_m))
    est = {"t": np.array([st.t for st in states]), "x": np.array([st.position[0] for st in states]),
           "y": np.array([st.position[1] for st in states])}
    err = error_series(est, truth)
    return err["t"] - START_EPOCH_S, np.hypot(err["east"], err["north"])


def simulated_seed(seed, tmp, graph=False):
    """One simulated switching run (sim.gnss_raw_sim_bag, windows()) through offline.pipeline_for('ins_tight') and,
    for the loosely coupled / INS-only comparison, pipeline_for('ins') on the same bag; graph: also `agnav run
    ins_tight` on it (replay speed)."""
    from agnav_bringup.graph_config import load_config
    from agnav_common.bagio import filter_bag
    from agnav_sim_eval import offline
    bag = tmp / f"ins_tight_s{seed}"
    record_raw_run(bag, seed=seed)
    config = load_config("ins_tight")
    pipeline, epochs = offline.pipeline_for(config), []

    def observe(topic, msg):     # mode, DDs and integer fix after each rover epoch
        if topic == "/gnss/raw_observations":
            sw = pipeline.backend.ekf
            sol = sw.last_solution if sw.mode == "tight" else None
            epochs.append((msg.header.stamp.sec - START_EPOCH_S, sw.mode, sol is not None and sol.fixed,
                           0 if sol is None else sol.n_dd))
    start = time.perf_counter()
    states, _ = offline.replay(config, bag, pipeline, observe)
    seconds = time.perf_counter() - start
    # the ins comparison ends with the 3-satellite window: InsEkf's re-initialisation when the fixes return after
    # 75 s without any raises NameError `hv` (ins/ekf.py _update since 5bb5ba7)
    end_ns = int((START_EPOCH_S + windows()["three_sat"][1] + 1.0) * 1e9)
    filter_bag(bag, tmp / f"ins_s{seed}", lambda topic, t_ns: t_ns <= end_ns)
    loose, loose_pipeline = offline.replay(load_config("ins"), tmp / f"ins_s{seed}")
    (t, tight), (tl, lerr) = (_horizontal_cm(st, p.plane, bag) for st, p in ((states, pipeline),
                                                                               (loose, loose_pipeline)))
    w, ep = windows(), np.array([(e[0], e[2], e[3]) for e in epochs])
    three, flt = (w[k] for k in ("three_sat", "float"))

    def inside(times, win):
        return (times >= win[0]) & (times <= win[1])
    after = ep[(ep[:, 0] >= w["outage"][1]) & (ep[:, 1] > 0)]
    transitions = pipeline.backend.ekf.transitions
    out = {"three_sat_end_err_cm": round(float(tight[inside(t, three)][-1]), 2),
           "three_sat_loose_end_err_cm": round(float(lerr[inside(tl, three)][-1]), 2),
           "three_sat_max_err_cm": round(float(tight[inside(t, three)].max()), 2),
           "three_sat_dd_per_epoch": round(float(np.mean(ep[inside(ep[:, 0], three), 2])), 1),
           "float_rms_cm": round(float(np.sqrt(np.mean(tight[inside(t, flt)] ** 2))), 2),
           "float_loose_rms_cm": round(float(np.sqrt(np.mean(lerr[inside(tl, flt)] ** 2))), 2),
           "float_max_err_cm": round(float(tight[inside(t, flt)].max()), 2),
           "float_fix_rate": round(float(np.mean(ep[inside(ep[:, 0], flt), 1])), 3),
           "switch_max_jump_sigma": round(max(tr["jump_sigma"] for tr in transitions), 2),
           "switch_transitions": [{"t": round(float(tr["t"] - START_EPOCH_S), 2), "from": tr["from"], "to": tr["to"],
                                   "jump_sigma": round(tr["jump_sigma"], 2), "jump_cm": _cm(tr["jump_m"])}
                                  for tr in transitions],
           "refix_time_s": round(float(after[0, 0] - w["outage"][1]), 2) if len(after) else None,
           "pipeline_replay_x_real_time": round(float(t[-1] - t[0]) / seconds, 1)}
    if graph:
        out["graph_replay_x_real_time"] = graph_speed(bag)
    return out


def graph_speed(bag):
    """x real time of `agnav run ins_tight` on `bag` (one process, deterministic replay, start-up included)."""
    import subprocess
    import sys
    from agnav_sim_eval.evaluate import read_bag
    imu = read_bag(bag, ["/imu/data_raw"])["/imu/data_raw"]
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "agnav_bringup.cli", "run", "ins_tight", "--bag", str(bag), "--quiet",
                    "--no-eval"], check=True, capture_output=True,
                   env=dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"))
    return round((imu[-1][0] - imu[0][0]) / (time.perf_counter() - start), 1)


def simulated(seeds=SIM_SEEDS):
    """Per-seed keys of the simulated switching runs and, at the top level, the worst seed's value of each."""
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        runs = {seed: simulated_seed(seed, Path(tmp), graph=k == 0) for k, seed in enumerate(seeds)}
    worst = {key: max(r[key] for r in runs.values()) for key in PER_SEED_MAX}
    worst["refix_time_s"] = max((r["refix_time_s"] for r in runs.values() if r["refix_time_s"] is not None),
                                default=None)
    worst["pipeline_replay_x_real_time"] = min(r["pipeline_replay_x_real_time"] for r in runs.values())
    return {"sim_seeds": list(seeds), "sim_per_seed": runs, **worst,
            "graph_replay_x_real_time": runs[seeds[0]]["graph_replay_x_real_time"]}


def measure(data=DATA, seeds=SIM_SEEDS):
    pairs, nav, base, rover = load(data)
    kin, kin_ms = _timed(pairs, nav, base, BaselineConfig(dynamics="kinematic"))
    sta, _ = _timed(pairs, nav, base, BaselineConfig(dynamics="static", fix=False))
    fixed_err, kin_float = _errors(kin, rover)
    sta_float = _errors(sta, rover)[1]
    sats20 = highest(pairs, nav, base)
    pairs20 = [(subset(r, sats20), subset(b, sats20)) for r, b in pairs]
    kin20, ms20 = _timed(pairs20, nav, base, BaselineConfig(dynamics="kinematic"))
    old = dict(sigma_amb_rate=1e-4, dd=DDConfig(sigma_code=0.3))
    old_kin = _errors(_timed(pairs, nav, base, BaselineConfig(dynamics="kinematic", **old))[0], rover)
    old_sta = _errors(_timed(pairs, nav, base, BaselineConfig(dynamics="static", fix=False, **old))[0], rover)[1]
    n_rtk_fixed, n_rtk, rtk_pos = rtklib_solution(data)
    return {
        "epochs": len(pairs),
        "known_baseline_m": round(float(np.linalg.norm(rover - base)), 4),
        "static_float_baseline_err_cm": _cm(sta_float[-1]),
        "static_float_baseline_err_enu_cm": [_cm(v) for v in to_enu(sta[-1].float_pos - rover, rover)],
        "static_float_err_after_60s_cm": _cm(sta_float[60:].max()) if len(sta) > 60 else None,
        "static_float_err_median_after_60s_cm": _cm(np.median(sta_float[60:])) if len(sta) > 60 else None,
        "kinematic_float_err_median_cm": _cm(np.median(kin_float)),
        "kinematic_float_err_end_cm": _cm(kin_float[-1]),
        "static_fixed_baseline_err_cm": _cm(fixed_err.max()) if fixed_err.size else None,
        "static_fixed_err_median_cm": _cm(np.median(fixed_err)) if fixed_err.size else None,
        "static_fix_rate": round(len(fixed_err) / len(kin), 4),
        "static_fixed_epochs": int(len(fixed_err)),
        "rtklib_fix_rate": round(n_rtk_fixed / n_rtk, 4),
        "rtklib_fixed_epochs": f"{n_rtk_fixed}/{n_rtk}",
        "rtklib_fixed_err_max_cm": _cm(np.linalg.norm(rtk_pos - rover, axis=1).max()),
        "ratio_median": round(float(np.median([s.ratio for s in kin])), 1),
        "dd_per_epoch_mean": round(float(np.mean([s.n_dd for s in kin])), 1),
        "cost_ms_per_epoch": round(kin_ms, 1),
        "cost_ms_per_epoch_20sat": round(ms20, 1),
        "dd_per_epoch_20sat": round(float(np.mean([s.n_dd for s in kin20])), 1),
        "fix_rate_20sat": round(float(np.mean([s.fixed for s in kin20])), 4),
        "first_slice": {"static_float_baseline_err_cm": _cm(old_sta[-1]),
                        "static_float_err_median_after_60s_cm": _cm(np.median(old_sta[60:])),
                        "static_fix_rate": round(len(old_kin[0]) / len(kin), 4),
                        "static_fixed_baseline_err_cm": _cm(old_kin[0].max()) if old_kin[0].size else None},
        **walk_doppler(),
        **simulated(seeds),
        "load_average_1min": round(os.getloadavg()[0], 2),
    }


def report(res):
    return "\n".join([
        "# ins_tight: raw-GNSS DD baselines and Doppler velocity (issue 18, raw-GNSS slices)", "",
        "Generated by `agnav bench ins_tight --write-docs docs/benchmarks/ins_tight.md`; the method is in the "
        "docstring of `agnav_sim_eval/bench/ins_tight.py` and the modules of `agnav_fusion/gnss_raw`.", "",
        f"MatRTKLIB static pair: {res['epochs']} epochs at 1 Hz, known baseline {res['known_baseline_m']} m, "
        f"{res['dd_per_epoch_mean']} DDs per epoch on average (code + phase each).", "",
        "| quantity | agnav gnss_raw | RTKLIB 2.4.3 (rover_rtk.pos) | goal |", "|---|---|---|---|",
        f"| fix rate (kinematic, instantaneous AR, ratio ≥ 3) | {res['static_fix_rate']:.1%} "
        f"({res['static_fixed_epochs']}/{res['epochs']}) | {res['rtklib_fix_rate']:.1%} "
        f"({res['rtklib_fixed_epochs']}) | reported |",
        f"| fixed baseline error, worst fixed epoch | {res['static_fixed_baseline_err_cm']} cm "
        f"(median {res['static_fixed_err_median_cm']} cm) | {res['rtklib_fixed_err_max_cm']} cm | ≤ 1 cm |",
        f"| float baseline error, static filter after {res['epochs']} epochs | "
        f"{res['static_float_baseline_err_cm']} cm (E/N/U {res['static_float_baseline_err_enu_cm']}) "
        "| – | ≤ 5 cm |",
        f"| float baseline error, static filter, worst after 60 s | {res['static_float_err_after_60s_cm']} cm "
        "| – | |",
        "| float baseline error, kinematic filter: median / last epoch | "
        f"{res['kinematic_float_err_median_cm']} / "
        f"{res['kinematic_float_err_end_cm']} cm | – | |",
        f"| median ratio (second-best / best) | {res['ratio_median']} | | |",
        f"| first slice's settings (σ_code 0.3 m, walk 1e-4): fix rate / static float end / median after 60 s | "
        f"{res['first_slice']['static_fix_rate']:.1%} / {res['first_slice']['static_float_baseline_err_cm']} / "
        f"{res['first_slice']['static_float_err_median_after_60s_cm']} cm | | |",
        f"| static float, median after 60 s | {res['static_float_err_median_after_60s_cm']} cm | | |",
        f"| 20 satellites ({res['dd_per_epoch_20sat']} DDs per epoch): cost / fix rate | "
        f"{res['cost_ms_per_epoch_20sat']} ms / {res['fix_rate_20sat']:.1%} | | |",
        f"| cost per epoch (satellite states + DDs + EKF + LAMBDA) | {res['cost_ms_per_epoch']} ms "
        f"(load {res['load_average_1min']}, 2 cores) | | |", "",
        "Doppler velocity, u-blox walk (gnss_imu_walk: RAWX + SFRBX through the UBX driver's parser, GPS LNAV + "
        f"Galileo I/NAV ephemerides decoded from SFRBX: {res['walk_ephemerides']}; {res['walk_sats_mean']} "
        f"satellites per epoch; {res['walk_epochs']} epochs at 4 Hz; undifferenced, receiver clock drift "
        f"estimated; {res['walk_doppler_ms_per_epoch']} ms per epoch):", "",
        "| reference | 3-D RMS | horizontal RMS | E/N/U RMS |", "|---|---|---|---|",
        f"| receiver's velocity (NAV-PVT, filtered) | {res['walk_doppler_vel_rms_cm_s']} cm/s | "
        f"{res['walk_doppler_vel_rms_horizontal_cm_s']} cm/s | {res['walk_doppler_vel_rms_enu_cm_s']} cm/s |",
        f"| central differences of the receiver's RTK positions | {res['walk_doppler_vs_pos_diff_rms_cm_s']} cm/s "
        f"| {res['walk_doppler_vs_pos_diff_rms_horizontal_cm_s']} cm/s | |", "",
        "Single-epoch Doppler velocity is unfiltered: while walking, per-satellite range-rate residuals against the "
        "receiver's velocity reach 0.2–0.8 m/s (handheld antenna), the receiver's own velocity agrees with its "
        "position differences to ~9 cm/s per axis.", "",
        "Switching GNSS/INS through the shipped pipeline (`offline.pipeline_for('ins_tight')`, what "
        "`agnav run ins_tight` publishes; the loosely coupled / INS-only comparison is `pipeline_for('ins')` on the "
        "same bag). Simulated runs (`sim/gnss_raw_sim_bag.py`: mems_field, 2 m/s, consumer MEMS IMU, rover + base "
        "code/phase/Doppler from base.nav orbits, 1 km baseline, 1 Hz, LNAV / I/NAV frames on /gnss/nav_data): RTK "
        "fixed until 60 s; 2 s without satellites, then RTK float under a tree line (west half of the sky below 45°) "
        "60–120 s; 3 GPS satellites 120–180 s (no receiver fix); nothing 180–195 s; the sky back with the receiver "
        "float 195–210 s; RTK fixed after. Horizontal base_link errors against the truth at the IMU rate; seeds "
        f"{res['sim_seeds']} (tuning used seeds < 1000):", "",
        "| seed | 3 sat: end (max) [cm] | 3 sat, ins: end [cm] | float: RMS (max) [cm] | float, ins: RMS [cm] | "
        "float fix rate | max switch jump [σ] | re-fix [s] |", "|---|---|---|---|---|---|---|---|",
        *[f"| {seed} | {r['three_sat_end_err_cm']} ({r['three_sat_max_err_cm']}) | {r['three_sat_loose_end_err_cm']} "
          f"| {r['float_rms_cm']} ({r['float_max_err_cm']}) | {r['float_loose_rms_cm']} | {r['float_fix_rate']:.0%} "
          f"| {r['switch_max_jump_sigma']} | {r['refix_time_s']} |" for seed, r in res["sim_per_seed"].items()],
        f"| **worst** | **{res['three_sat_end_err_cm']}** ({res['three_sat_max_err_cm']}) | "
        f"{res['three_sat_loose_end_err_cm']} | **{res['float_rms_cm']}** ({res['float_max_err_cm']}) | "
        f"{res['float_loose_rms_cm']} | | **{res['switch_max_jump_sigma']}** | {res['refix_time_s']} |",
        "| goal | ≤ 10 | | ≤ 5 | | | ≤ 3 | reported |", "",
        "The tight filter fixes integers where LAMBDA's ratio test allows even while the receiver reports float "
        "(its own step beyond the report's float-only §7.7); the 3-satellite window has "
        f"{res['sim_per_seed'][res['sim_seeds'][0]]['three_sat_dd_per_epoch']:g} DDs per epoch, with the antenna "
        "height held to the reference learnt before it (gnss_raw.height_aid). Output jump = the "
        "output's change beyond dead reckoning in the 3 s after a switch, over the larger σ along it before and "
        "after. Re-fix = from the end of the outage to the tight filter's first integer fix. Transitions of seed "
        f"{res['sim_seeds'][0]}:", "",
        "| t [s] | transition | max jump [σ] | that jump [cm] |", "|---|---|---|---|",
        *[f"| {tr['t']} | {tr['from']} → {tr['to']} | {tr['jump_sigma']} | {tr['jump_cm']} |"
          for tr in res["sim_per_seed"][res["sim_seeds"][0]]["switch_transitions"]], "",
        f"Replay speed: `agnav run ins_tight` (one process, deterministic, start-up included) "
        f"{res['graph_replay_x_real_time']}× real time; the offline pipeline alone at least "
        f"{res['pipeline_replay_x_real_time']}× (load {res['load_average_1min']}, 2 cores).", ""])


def main(argv=None):
    ap = argparse.ArgumentParser(prog="agnav bench ins_tight", description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object last")
    ap.add_argument("--seeds", type=lambda v: tuple(int(x) for x in v.split(",")), default=SIM_SEEDS,
                    help="simulation seeds, comma-separated (default: the reported 1000-1009)")
    docs_option(ap, "ins_tight.md")
    args = ap.parse_args(argv)
    res = measure(seeds=args.seeds)
    print(report(res))
    if args.write_docs:
        write_docs(args.write_docs, report(res))
    if args.json:
        print(json.dumps(res))
    return 0
