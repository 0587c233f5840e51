"""`agnav bench ins`: wander-azimuth GNSS/INS (SPEC §7) on simulated MEMS IMU + RTK 5 Hz / DGPS 1 Hz runs.

    agnav bench ins [--seed N] [--json] [--write-docs] [--no-sim]

Part 1 (synthetic field runs, `agnav_fusion.ins.synthetic`): 240 s of 40 m passes with U-turns at 2 m/s,
consumer MEMS IMU (`MemsGrade`: gyro 0.01 °/s/√Hz, 0.1 °/s turn-on bias, 10 °/h instability; accel
150 µg/√Hz, 10 mg turn-on bias, 0.1 mg instability; 0.2 % scale; 100 Hz), antenna 2.2 m from the IMU,
heading unknown at start (guess off by 180°). Metrics after alignment: position / velocity / roll / pitch /
heading RMS, time until the heading error stays below 1°, horizontal drift at the end of 10 s and 30 s
GNSS outages, cost per IMU sample. Part 2: the simulator's scenarios (`agnav_drivers.sim`) replayed
through the INS and, side by side, the thesis' navigation sensor module (`bench.thesis.run_module`).
"""
import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from agnav_common.frames import rotation_matrix, wrap_angle
from agnav_common.geodesy import LocalTangentPlane
from agnav_fusion.ins import synthetic as sy
from agnav_fusion.ins.ekf import InsEkf, InsEkfSettings
from agnav_fusion.ins.lever_arm import imu_to_point_position
from agnav_fusion.ins.measurements import GnssSample

DEG = 180.0 / math.pi
DOCS = Path(__file__).resolve().parents[4] / "docs" / "benchmarks" / "ins.md"
FLU_TO_FRD = np.diag([1.0, -1.0, -1.0])
LEVER = (-1.0, 0.0, -2.0)
OUTAGE_START = 150.0
SIM_SCENARIOS = (("rtk_straight_fast", "RTK 5 Hz"), ("asphalt_loop", "DGPS 1 Hz"), ("grass_slope", "DGPS 1 Hz"))


def rms(a):
    a = np.asarray(a, dtype=float)
    return float(np.sqrt(np.mean(a * a))) if a.size else float("nan")


def align_time(t, heading_err, t0, limit=math.radians(1.0)):
    """Seconds from t0 until |heading error| stays below limit for the rest of the run."""
    bad = np.nonzero(np.abs(heading_err) >= limit)[0]
    if bad.size == 0:
        return 0.0
    return float(t[bad[-1] + 1] - t0) if bad[-1] + 1 < t.size else float("nan")


def synthetic_case(grade, seed):
    """One field run: accuracy, alignment time, cost; plus the 10 s and 30 s outage drifts."""
    traj = sy.field_drive(duration=240.0, speed=2.0, leg=40.0, heading0=0.8)
    gyro, accel = sy.ideal_imu(traj)
    out = {}
    for outage in (None, 10.0, 30.0):
        rng = np.random.default_rng(seed)
        g, a, _, _ = sy.MemsGrade().corrupt(gyro, accel, 0.01, rng)
        gnss = sy.gnss_samples(traj, gyro, LEVER, grade, rng)
        ekf = InsEkf(InsEkfSettings(lever_gnss_frd=LEVER, initial_heading=0.8 + math.pi))
        win = [(OUTAGE_START, OUTAGE_START + outage)] if outage else []
        start = time.perf_counter()
        err = sy.run_ins(ekf, traj, g, a, gnss, win)
        cost = (time.perf_counter() - start) / len(g) * 1e6
        if outage is None:
            t_align = align_time(err.t, err.att[:, 2], err.t[0])
            ok = err.t >= err.t[0] + (t_align if math.isfinite(t_align) else 0.0)
            out.update(position_cm=100 * rms(np.linalg.norm(err.pos[ok, :2], axis=1)),
                       height_cm=100 * rms(err.pos[ok, 2]),
                       velocity_cm_s=100 * rms(np.linalg.norm(err.vel[ok], axis=1)),
                       roll_deg=rms(err.att[ok, 0]) * DEG, pitch_deg=rms(err.att[ok, 1]) * DEG,
                       heading_deg=rms(err.att[ok, 2]) * DEG, align_s=t_align, us_per_sample=cost,
                       nis_position=ekf.health().get("nis_mean_position"),
                       nis_velocity=ekf.health().get("nis_mean_velocity"))
        else:
            end = np.argmin(np.abs(err.t - (OUTAGE_START + outage)))
            out[f"drift_{int(outage)}s_m"] = float(np.linalg.norm(err.pos[end, :2]))
    return out


def sim_streams(run):
    """SimRun -> IMU in base_link FRD axes, GNSS samples (arrival, sample), levers (IMU->antenna, base->IMU)."""
    imu_xyz, imu_rpy = run.mounts["imu_link"]
    r = FLU_TO_FRD @ rotation_matrix(*imu_rpy)
    gyro, accel = run.imu.gyro @ r.T, run.imu.accel @ r.T
    lever_imu = FLU_TO_FRD @ np.asarray(imu_xyz, float)
    lever_gnss = FLU_TO_FRD @ np.asarray(run.mounts["gnss_link"][0], float) - lever_imu
    g = run.gnss
    samples = [(g.t_arrival[j], GnssSample(g.t[j], math.radians(g.lat[j]), math.radians(g.lon[j]), g.alt[j],
                                           g.cov[j], g.vel[j], np.eye(3) * 0.05 ** 2, int(g.fix_type[j])))
               for j in np.argsort(g.t_arrival)]
    return gyro, accel, samples, lever_gnss, lever_imu


def run_ins_sim(run):
    """Replay a SimRun through InsEkf (heading unknown); base_link estimate dict at IMU epochs and cost."""
    gyro, accel, gnss, lever_gnss, lever_imu = sim_streams(run)
    ekf = InsEkf(InsEkfSettings(lever_gnss_frd=tuple(lever_gnss)))
    plane = LocalTangentPlane(*run.datum)
    n = len(run.imu.t)
    est = np.full((n, 6), np.nan)
    gi = 0
    start = time.perf_counter()
    for i, t in enumerate(run.imu.t):
        while gi < len(gnss) and gnss[gi][0] <= t:
            ekf.add_gnss(gnss[gi][1])
            gi += 1
        ekf.add_imu(t, gyro[i], accel[i])
        s = ekf.solution()
        if s is not None:
            lat, lon, h = imu_to_point_position(s.lat, s.lon, s.h, -lever_imu, s.c_b_ned)
            est[i] = (lat, lon, s.roll, -s.pitch, math.pi / 2 - s.heading, ekf.heading_sigma())
    cost = (time.perf_counter() - start) / n * 1e6
    ok = ~np.isnan(est[:, 0])
    x, y = np.full(n, np.nan), np.full(n, np.nan)
    e, nn, _ = plane.to_enu(np.degrees(est[ok, 0]), np.degrees(est[ok, 1]), np.zeros(ok.sum()) + run.datum[2])
    x[ok], y[ok] = e, nn
    return dict(x=x, y=y, roll=est[:, 2], pitch=est[:, 3], yaw=wrap_angle(est[:, 4]), sigma=est[:, 5], us=cost)


def compare_sim(seed):
    """INS vs thesis module on the simulator's scenarios, over the samples after the INS heading aligned."""
    from agnav_drivers.sim import simulate
    from agnav_bringup.bench.thesis import run_module
    rows = []
    for name, gnss in SIM_SCENARIOS:
        run = simulate(name, seed=seed)
        if run.imu.accel is None:
            continue
        ins, nsm = run_ins_sim(run), run_module(run)
        tr = run.truth
        err_h = wrap_angle(ins["yaw"] - tr.yaw)
        t_align = align_time(tr.t, np.nan_to_num(err_h, nan=math.pi), tr.t[0])
        ok = tr.t >= (t_align if math.isfinite(t_align) else tr.t[-1] / 2)
        row = {"scenario": name, "gnss": gnss, "align_s": t_align}
        for label, est in (("ins", ins), ("module", nsm)):
            row[label] = {"position_cm": 100 * rms(np.hypot(est["x"][ok] - tr.x[ok], est["y"][ok] - tr.y[ok])),
                          "roll_deg": rms(wrap_angle(est["roll"][ok] - tr.roll[ok])) * DEG,
                          "pitch_deg": rms(wrap_angle(est["pitch"][ok] - tr.pitch[ok])) * DEG,
                          "heading_deg": rms(wrap_angle(est["yaw"][ok] - tr.yaw[ok])) * DEG,
                          "us_per_sample": est["us"]}
        rows.append(row)
    return rows


def markdown(res):
    lines = ["# GNSS/INS (wander azimuth, 16-state EKF) benchmark", "",
             "Reproduce: `agnav bench ins --json --write-docs` (seed %d). Module docstring of "
             "`agnav_bringup/bench/ins.py` describes the runs and the MEMS model." % res["seed"], "",
             "## Synthetic field runs (consumer MEMS, heading guess off by 180°)", "",
             "| GNSS | pos RMS cm | height cm | vel cm/s | roll ° | pitch ° | heading ° | align <1° s | "
             "drift 10 s outage m | drift 30 s outage m | µs/IMU sample | NIS pos/vel (3 dof) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for label, r in res["synthetic"].items():
        lines.append(f"| {label} | {r['position_cm']:.1f} | {r['height_cm']:.1f} | {r['velocity_cm_s']:.1f} | "
                     f"{r['roll_deg']:.2f} | {r['pitch_deg']:.2f} | {r['heading_deg']:.2f} | {r['align_s']:.1f} | "
                     f"{r['drift_10s_m']:.2f} | {r['drift_30s_m']:.2f} | {r['us_per_sample']:.0f} | "
                     f"{r['nis_position']:.2f} / {r['nis_velocity']:.2f} |")
    if res.get("sim"):
        lines += ["", "## Simulator scenarios: INS vs the thesis' navigation sensor module (same runs)", "",
                  "Errors of base_link after the INS heading stays within 1° (INS starts with an unknown heading).", "",
                  "| scenario | GNSS | INS align s | pos cm INS / module | roll ° INS / module | pitch ° INS / module | "
                  "heading ° INS / module | µs/sample INS / module |", "|---|---|---|---|---|---|---|---|"]
        for r in res["sim"]:
            i, m = r["ins"], r["module"]
            lines.append(f"| {r['scenario']} | {r['gnss']} | {r['align_s']:.1f} | {i['position_cm']:.1f} / "
                         f"{m['position_cm']:.1f} | {i['roll_deg']:.2f} / {m['roll_deg']:.2f} | {i['pitch_deg']:.2f} / "
                         f"{m['pitch_deg']:.2f} | {i['heading_deg']:.2f} / {m['heading_deg']:.2f} | "
                         f"{i['us_per_sample']:.0f} / {m['us_per_sample']:.0f} |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(prog="agnav bench ins", description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", action="store_true", help="print one JSON object on the last line")
    ap.add_argument("--write-docs", action="store_true", help=f"write the table to {DOCS}")
    ap.add_argument("--no-sim", action="store_true", help="skip the simulator / thesis-module comparison")
    args = ap.parse_args(argv)
    res = {"seed": args.seed, "synthetic": {"RTK 5 Hz": synthetic_case(sy.RTK_5HZ, args.seed),
                                            "DGPS 1 Hz": synthetic_case(sy.DGPS_1HZ, args.seed)}}
    if not args.no_sim:
        res["sim"] = compare_sim(args.seed)
    text = markdown(res)
    print(text)
    if args.write_docs:
        DOCS.parent.mkdir(parents=True, exist_ok=True)
        DOCS.write_text(text)
    if args.json:
        print(json.dumps(res))
    return 0
