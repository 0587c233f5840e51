"""`agnav bench sim [--seed N] [--scenarios A,B] [--json]`: simulated sensor statistics against their specs.

Part 1 drives each sensor model alone (noise, bandwidth/lag, drift, acceleration sensitivity, field angles,
GNSS error and latency); part 2 simulates the scenarios and measures the raw-sensor baselines of SPEC §10
(integrated gyro, inclinometer, GPS, GDS) next to the thesis' values, plus the generation time per scenario.
"""
import argparse
import json
import math
import time
from dataclasses import replace

import numpy as np

from agnav_sim_eval.sim import SCENARIOS, simulate, stats
from agnav_sim_eval.sim.scenarios import D5R, STARFIRE, env05f, fog
from agnav_sim_eval.sim.sensors.fluxgate import Fluxgate, FluxgateParams
from agnav_sim_eval.sim.sensors.gnss import GnssReceiver
from agnav_sim_eval.sim.sensors.gyro import Gyro
from agnav_sim_eval.sim.sensors.inclinometer import G, Inclinometer
from agnav_sim_eval.sim.sensors.magnetic_field import earth_field_enu

DEG = 180.0 / math.pi


def _row(rows, name, sim, spec, unit, ok):
    rows.append({"quantity": name, "sim": sim, "spec": spec, "unit": unit, "ok": bool(ok)})


def sensor_rows(seed):
    """Model-level statistics of every sensor against its data sheet (SPEC §11)."""
    rng = np.random.default_rng(seed)
    rows = []
    p = env05f((0.0, 0.0, 0.0))
    g = Gyro(p, rng)
    out = np.array([g.sample(k * 0.01, 0.01, np.zeros(3), False) for k in range(5000)])
    noise = float(np.mean(out.std(axis=0)) * DEG)
    _row(rows, "ENV-05F gyro noise r.m.s.", noise, "<= 0.4", "deg/s", noise <= 0.4)
    g = Gyro(replace(p, noise_dps=0.0, offset_dps=0.0, random_walk_dps_rt_s=0.0, scale_error=0.0), rng)
    dt = 1e-4
    g.sample(0.0, dt, np.zeros(3), False)
    resp = np.array([g.sample(k * dt, dt, np.array([0, 0, 1.0]), False)[2] for k in range(1, 400)])
    bw = 1 / (2 * math.pi * (np.argmax(resp >= 1 - math.exp(-1)) + 1) * dt)
    _row(rows, "ENV-05F gyro bandwidth", bw, "10", "Hz", abs(bw - 10) < 0.5)
    g = Gyro(replace(p, noise_dps=0.0), rng)
    drift = np.array([g.sample(k, 1.0, np.zeros(3), False) for k in range(86400)])
    sd = float(np.mean((drift - drift[0]).std(axis=0)) * DEG)
    _row(rows, "vibratory gyro 24 h SD of output change", sd, "0.1 (R3-4)", "deg/s", 0.05 < sd < 0.2)
    f = fog(0.005)
    g = Gyro(f, rng)
    rates = np.array([g.sample(k * 0.01, 0.01, np.zeros(3), True) for k in range(20000)])
    angle = np.cumsum(rates, axis=0) * 0.01 * DEG
    t = np.arange(20000) * 0.01
    slope = np.array([np.polyfit(t, a, 1)[0] for a in angle.T])
    anoise = float(np.mean(np.diff(angle - np.outer(t, slope), axis=0).std(axis=0)) / math.sqrt(2))
    _row(rows, "JCS-7401A FOG drift rate (max |axis|)", float(np.abs(slope).max()), "0.003-0.005, < 2 deg/min",
         "deg/s", np.abs(slope).max() < 2 / 60)
    _row(rows, "JCS-7401A FOG angle noise", anoise, "0.06", "deg", abs(anoise - 0.06) < 0.01)
    inc = Inclinometer(replace(D5R, offset_deg=0, scale_error=0, cross_axis=0, noise_deg=0), rng)
    inc.sample(0.01, 0.0, 0.0, np.array([0, 0, G]))
    roll = math.radians(10)
    resp = np.array([inc.sample(0.01, roll, 0.0, np.array([0, G * math.sin(roll), G * math.cos(roll)]))[0]
                     for _ in range(600)]) / roll
    tau = (np.argmax(resp >= 1 - math.exp(-1)) + 1) * 0.01
    t90 = (np.argmax(resp >= 0.9) + 1) * 0.01
    _row(rows, "D5R inclinometer time constant", tau, "~1.1 (90 % <= 2.5 s)", "s", t90 <= 2.5)
    _row(rows, "D5R inclinometer 90 % step time", t90, "<= 2.5", "s", t90 <= 2.5)
    inc = Inclinometer(replace(D5R, offset_deg=0, scale_error=0, cross_axis=0, noise_deg=0), rng)
    for _ in range(2000):
        r_meas, p_meas = inc.sample(0.01, 0.0, 0.0, np.array([0.5, 0.5, G]))
    _row(rows, "inclinometer pitch per 0.5 m/s^2 forward accel", p_meas * DEG, -math.asin(0.5 / G) * DEG, "deg",
         abs(p_meas + math.asin(0.5 / G)) < 1e-3)
    _row(rows, "inclinometer roll per 0.5 m/s^2 lateral accel", r_meas * DEG, math.asin(0.5 / G) * DEG, "deg",
         abs(r_meas - math.asin(0.5 / G)) < 1e-3)
    fp = FluxgateParams()
    mag = Fluxgate(fp, rng)
    b_enu = earth_field_enu(*SCENARIOS["gds_straight_slow"].datum)[0]
    field = np.array([mag.sample(1 / 15, np.eye(3), b_enu) for _ in range(3000)])
    mnoise = float(np.mean(field.std(axis=0)) / 1e-7)
    _row(rows, "FGM-200A noise (ripple)", mnoise, "1.25", "mG", abs(mnoise - 1.25) < 0.15)
    rx = GnssReceiver(STARFIRE, rng)
    err = np.array([rx.sample(1.0, np.zeros(3), np.zeros(3))[0] for _ in range(20000)])
    hz = float(np.sqrt(np.mean(np.sum(err[:, :2] ** 2, axis=1))) * 100)
    honest = float(np.sqrt(np.trace(rx.position_cov[:2, :2])) * 100)
    _row(rows, "StarFire horizontal error r.m.s. (long run)", hz, f"{honest:.1f} (cov); 8.0 (R5-2)", "cm",
         abs(hz - honest) < 0.25 * honest)
    return rows


# SPEC §10 raw-sensor baselines: (label, thesis value, function of the run -> simulated value)
def _gyro(axis):
    return lambda run: stats.integrated_gyro_errors(run)["rms_deg"][axis]


BASELINES = {
    "asphalt_loop": [("R5-2 gyro roll rms", 12.49, _gyro(0)), ("R5-2 gyro pitch rms", 12.07, _gyro(1)),
                     ("R5-2 gyro heading rms", 4.37, _gyro(2)),
                     ("R5-2 inclinometer roll rms", 0.46, lambda r: stats.inclinometer_errors(r)["roll_rms_deg"]),
                     ("R5-2 inclinometer pitch rms", 0.48, lambda r: stats.inclinometer_errors(r)["pitch_rms_deg"]),
                     ("R5-2 GPS position rms cm", 8.00, lambda r: stats.gnss_position_errors(r)["rms_cm"])],
    "grass_slope": [("R5-5 gyro roll rms", 2.33, _gyro(0)), ("R5-5 gyro pitch rms", 6.78, _gyro(1)),
                    ("R5-5 gyro heading rms", 3.51, _gyro(2)),
                    ("R5-5 inclinometer roll rms", 0.88, lambda r: stats.inclinometer_errors(r)["roll_rms_deg"]),
                    ("R5-5 inclinometer pitch rms", 0.71, lambda r: stats.inclinometer_errors(r)["pitch_rms_deg"]),
                    ("R5-5 GPS position rms cm", 25.90, lambda r: stats.gnss_position_errors(r)["rms_cm"])],
    "rough_road": [("R5-8 gyro roll rms", 4.54, _gyro(0)), ("R5-8 gyro pitch rms", 6.25, _gyro(1)),
                   ("R5-8 gyro heading rms", 7.60, _gyro(2)),
                   ("R5-8 inclinometer roll rms", 3.28, lambda r: stats.inclinometer_errors(r)["roll_rms_deg"]),
                   ("R5-8 inclinometer pitch rms", 1.84, lambda r: stats.inclinometer_errors(r)["pitch_rms_deg"]),
                   ("R5-8 GPS position rms cm", 8.40, lambda r: stats.gnss_position_errors(r)["rms_cm"])],
    "sleeper_tilt": [("R4-6 uncorrected GPS mean cm", 17.1, lambda r: stats.gnss_position_errors(r)["mean_cm"]),
                     ("R4-6 uncorrected GPS max cm", 21.3, lambda r: stats.gnss_position_errors(r)["max_cm"]),
                     ("R4-6 roll max deg", 6.0, lambda r: float(r.truth.roll.max() * DEG))],
    "rtk_straight_fast": [("R4-7 uncorrected GPS rms cm", 10.4, lambda r: stats.gnss_position_errors(r)["rms_cm"]),
                          ("R4-7 uncorrected GPS max cm", 25.0, lambda r: stats.gnss_position_errors(r)["max_cm"]),
                          ("R4-7 roll range deg", 4.33, lambda r: float(np.ptp(r.truth.roll[r.truth.speed > 4]) * DEG))],
    "gds_straight_slow": [("Table 2.3 GDS heading noise deg", 0.42,
                           lambda r: stats.gds_heading_errors(r)["deviation_rms_deg"])],
    "vwa_straight": [("R2-11 FOG heading rms", 0.71, _gyro(2)),
                     ("R2-11 GDS heading-deviation rms", 0.26,
                      lambda r: stats.gds_heading_errors(r)["deviation_rms_deg"])],
    "gps_gyro_straight": [("R4-1 GPS heading rms", 2.36, lambda r: stats.gnss_course_errors(r)["rms_deg"]),
                          ("R4-2 gyro heading rms", 1.83, _gyro(2)),
                          ("R4-2 gyro heading end (thesis sign)", -3.60,
                           lambda r: -stats.integrated_gyro_errors(r)["end_deg"][2])],
}


def scenario_rows(names, seed):
    """Raw-sensor baselines, geometry checks and generation time of each scenario."""
    rows, timing = [], {}
    for name in names:
        start = time.perf_counter()
        run = simulate(name, seed=seed)
        timing[name] = {"generation_s": round(time.perf_counter() - start, 2),
                        "simulated_s": round(float(run.truth.t[-1]), 1)}
        for label, thesis, fn in BASELINES.get(name, []):
            value = float(fn(run))
            rows.append({"scenario": name, "quantity": label, "sim": value, "thesis": thesis,
                         "ratio": value / thesis if thesis else None})
        if run.gnss is not None:
            lever = stats.lever_arm(run)
            rows.append({"scenario": name, "quantity": "antenna lever arm (m)", "sim": lever,
                         "thesis": list(run.mounts["gnss_link"][0]), "ratio": None})
        if run.mag is not None:
            decl, incl = stats.field_angles(run)
            rows.append({"scenario": name, "quantity": "field declination/inclination (deg)", "sim": [decl, incl],
                         "thesis": [run.extras["declination_deg"], run.extras["inclination_deg"]], "ratio": None})
    return rows, timing


def _fmt(v):
    if isinstance(v, (list, tuple)):
        return "(" + ", ".join(f"{x:.3f}" for x in v) + ")"
    return f"{v:.3f}" if isinstance(v, float) else str(v)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="agnav bench sim", description=__doc__)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--scenarios", default=",".join(SCENARIOS), help="comma-separated scenario names")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    names = [n for n in args.scenarios.split(",") if n]
    unknown = [n for n in names if n not in SCENARIOS]
    if unknown:
        print(f"unknown scenarios: {unknown}; available: {list(SCENARIOS)}")
        return 2
    sensors = sensor_rows(args.seed)
    print(f"{'sensor statistic':48s} {'simulated':>12s}  {'specified':28s} ok")
    for r in sensors:
        print(f"{r['quantity']:48s} {_fmt(r['sim']):>12s}  {_fmt(r['spec']):28s} {'yes' if r['ok'] else 'NO'}")
    baselines, timing = scenario_rows(names, args.seed)
    print(f"\n{'scenario':18s} {'raw-sensor baseline (SPEC §10)':38s} {'simulated':>24s} {'thesis':>24s}")
    for r in baselines:
        print(f"{r['scenario']:18s} {r['quantity']:38s} {_fmt(r['sim']):>24s} {_fmt(r['thesis']):>24s}")
    print(f"\n{'scenario':18s} {'simulated s':>12s} {'generation s':>13s}")
    for name, t in timing.items():
        print(f"{name:18s} {t['simulated_s']:12.1f} {t['generation_s']:13.2f}")
    if args.json:
        print(json.dumps({"seed": args.seed, "sensors": sensors, "baselines": baselines, "timing": timing}))
    return 0 if all(r["ok"] for r in sensors) else 1
