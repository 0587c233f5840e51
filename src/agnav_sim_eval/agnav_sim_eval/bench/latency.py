"""`agnav bench latency`: live graph latency /imu/data_raw -> /odometry/filtered, CPU per node, scaling.

A synthetic source (a vehicle driving straight east at 1 m/s: /imu/data_raw + /inclinometer at the IMU rate,
/gnss/fix + /gnss/vel at 1 Hz per receiver, the config's mounts on /tf_static) feeds the nsm graph in real time;
a probe matches each /odometry/filtered to the /imu/data_raw of the same stamp: latency = arrival - wall clock taken
just before that IMU publish (a fix epoch's /gnss/fix and /gnss/vel are built before it and published after it).
Layouts: `one_process` (graph, source and probe on one EventsExecutor in one process, as `agnav run --live` runs
drivers and nodes) and `processes` (each graph node its own OS process via its console script, source and probe in
this one). Baseline in the same run and layout: a bare rclpy relay (one subscription that republishes the same
Imu) - `bare_hop` is source -> relay (one hop), `bare_relay` source -> relay -> probe (two hops, like source -> nav
node -> probe). The node takes one fix topic, so 2-3 receivers publish their 1 Hz fixes interleaved on /gnss/fix.
A phase breaks on dropped outputs, p99 > 10x the bare hop, or a source below rate.
"""
import argparse
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

import numpy as np  # noqa: E402
import rclpy  # noqa: E402
import yaml  # noqa: E402
from rclpy.experimental import EventsExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from sensor_msgs.msg import Imu  # noqa: E402

from agnav_bringup.graph_config import REPO_ROOT, load_config  # noqa: E402
from agnav_common.node_main import PARENT_ENV, init_without_signal_handlers  # noqa: E402
from agnav_sim_eval.bench.latency_graph import Source, Probe, relay_node, run_relay_process  # noqa: E402
from agnav_sim_eval.bench import docs_option, write_docs  # noqa: E402

LAYOUTS = ("one_process", "processes")


def start_process(cmd, name, workdir, params=None):
    if params is not None:
        pfile = Path(workdir) / f"{name}.yaml"
        pfile.write_text(yaml.safe_dump({"/**": {"ros__parameters": params}}))
        cmd = cmd + ["--params-file", str(pfile)]
    env = dict(os.environ, **{PARENT_ENV: str(os.getpid())})  # children stop when the bench dies
    return name, subprocess.Popen(cmd, start_new_session=True, env=env)


def stop_processes(procs):
    for _, p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGINT)
    for _, p in procs:
        try:
            p.wait(timeout=5)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def cpu_seconds(pid):
    if pid is None:
        return time.process_time()
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def spin_for(executor, seconds, until=None, procs=()):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and not (until and until()):
        executor.spin_once(timeout_sec=0.005)
        for name, p in procs:
            if p.poll() is not None:
                raise RuntimeError(f"{name} exited with code {p.returncode}")


def pct(a, q):
    return round(float(np.percentile(a, q)), 3) if len(a) else None


def run_layout(layout, graph, phases, settle, config):
    """Phases [(rate, receivers, seconds)] of the graph (or the bare relay) in one layout -> list of rows."""
    init_without_signal_handlers(["--ros-args"])
    executor = EventsExecutor()
    node = rclpy.create_node("latency_bench")
    source = Source(node, config, "/imu/data_raw" if graph else "/bench/imu", graph)
    probe = Probe(node, graph)
    nodes, procs, workdir = [node], [], tempfile.mkdtemp(prefix="agnav_latency_")
    try:
        if layout == "processes":  # graph nodes via their console scripts, or the relay, as child processes
            exe = lambda n: shutil.which(n.executable) or str(Path(sys.prefix) / "bin" / n.executable)  # noqa: E731
            procs += [start_process([exe(n)] + n.ros_args(), n.label, workdir, dict(n.parameters))
                      for n in config.nodes] if graph else [start_process(
                [sys.executable, "-m", "agnav_sim_eval.bench.latency", "--relay"], "relay", workdir)]
        else:
            nodes += [n.node_class()(cli_args=n.ros_args(), parameter_overrides=[Parameter(k, value=v) for k, v in
                                                                                 n.parameters.items()])
                      for n in config.nodes] if graph else [relay_node()]
        for n in nodes:
            executor.add_node(n)
        out_topic = "/odometry/filtered" if graph else "/bench/imu_echo"
        spin_for(executor, 60.0, procs=procs, until=lambda: source.imu_pub.get_subscription_count() >= 1 and (
            node.count_publishers(out_topic) >= 1) and (not graph or source.fix_pub.get_subscription_count() >= 2))
        if graph:  # warm-up: heading from a 3 m chord of the 1 m/s drive, ~5 s after the first fix
            source.set_phase(phases[0][0])
            spin_for(executor, 30.0, until=lambda: probe.arrived, procs=procs)
            if not probe.arrived:
                raise RuntimeError(f"{layout}: no /odometry/filtered within 30 s")
            spin_for(executor, settle, procs=procs)
        pids = {name: p.pid for name, p in procs}
        pids["bench" if procs else "process"] = None
        windows = []
        for rate, receivers, seconds in phases:
            source.set_phase(rate, receivers)
            spin_for(executor, settle, procs=procs)
            t0, cpu0, skip0 = time.monotonic(), {k: cpu_seconds(p) for k, p in pids.items()}, source.skipped[-1]
            spin_for(executor, seconds, procs=procs)
            t1 = time.monotonic()
            cpu = {k: round(100 * (cpu_seconds(p) - cpu0[k]) / (t1 - t0), 1) for k, p in pids.items()}
            windows.append((rate, receivers, source.phase, t0, t1, cpu, source.skipped[-1] - skip0,
                            round(os.getloadavg()[0], 2)))
        source.stop()
        spin_for(executor, 2.0, procs=procs)  # drain
    finally:
        stop_processes(procs)
        for n in reversed(nodes):
            n.destroy_node()
        rclpy.try_shutdown()
        shutil.rmtree(workdir, ignore_errors=True)
    return [summarise(layout, graph, w, source, probe) for w in windows]


def summarise(layout, graph, window, source, probe):
    rate, receivers, phase, t0, t1, cpu, skipped, load = window
    keys = [k for k, (t, ph) in source.sent.items() if ph == phase and t0 <= t < t1]
    got = [k for k in keys if k in probe.arrived]
    lat = np.array([probe.arrived[k] - source.sent[k][0] for k in got]) * 1e3
    dur = t1 - t0
    row = {"layout": layout, "imu_hz": rate, "imu_sent_hz": round(len(keys) / dur, 1), "samples": len(keys),
           "dropped": len(keys) - len(got), "source_skipped": skipped,
           "out_hz": round(sum(t0 <= t < t1 for t in probe.arrived.values()) / dur, 1), "load_1min": load}
    if graph:
        graph_cpu = sum(v for k, v in cpu.items() if k not in ("bench", "process"))
        row.update(gnss_receivers=receivers, imu_to_odom_p50_ms=pct(lat, 50), imu_to_odom_p99_ms=pct(lat, 99),
                   imu_to_odom_max_ms=round(float(lat.max()), 3) if len(lat) else None, cpu_percent=cpu,
                   graph_cpu_percent=round(graph_cpu, 1) if layout == "processes" else None)
    else:
        hop = np.array([probe.hop[k] - source.sent[k][0] for k in got]) * 1e3
        row.update(bare_hop_p50_ms=pct(hop, 50), bare_hop_p99_ms=pct(hop, 99), bare_relay_p50_ms=pct(lat, 50),
                   bare_relay_p99_ms=pct(lat, 99), cpu_percent=cpu)
    return row


def breaks(row, bare):
    why = []
    if row["dropped"]:
        why.append(f"{row['dropped']} outputs dropped")
    if bare and row["imu_to_odom_p99_ms"] and row["imu_to_odom_p99_ms"] > 10 * bare["bare_hop_p99_ms"]:
        why.append(f"p99 {row['imu_to_odom_p99_ms'] / bare['bare_hop_p99_ms']:.0f}x bare hop")
    if row["source_skipped"] or row["imu_sent_hz"] < 0.95 * row["imu_hz"]:
        why.append(f"source {row['imu_sent_hz']:.0f}/{row['imu_hz']} Hz")
    return why


def run(args):
    config = load_config(args.config)
    rates = (100, 400) if args.no_scaling else (100, 200, 400, 1000)
    long = args.seconds
    short = long if args.no_scaling else args.scaling_seconds
    plan = [(100, 1, long)] + ([] if args.no_scaling else [(100, 2, short), (100, 3, short), (200, 1, short)]) + \
        [(400, 1, long)] + ([] if args.no_scaling else [(1000, 1, short)])
    bare_plan = [(r, 1, long if r in (100, 400) else short) for r in rates]
    settle = 1.0 if long >= 3 else 0.5
    out = {"config": args.config, "load_average_start": [round(v, 2) for v in os.getloadavg()], "cores": os.cpu_count()}
    rows = []
    for layout in args.layouts:
        g = run_layout(layout, True, plan, settle, config)
        b = run_layout(layout, False, bare_plan, settle, config)
        bare = {r["imu_hz"]: r for r in b}
        for r in g:
            ref = bare.get(r["imu_hz"])
            r["bare_hop_p99_ms"] = ref and ref["bare_hop_p99_ms"]
            if layout == "one_process" and ref:  # graph ~ process minus the bare relay run (source, probe, relay)
                r["graph_cpu_percent"] = round(r["cpu_percent"]["process"] - ref["cpu_percent"]["process"], 1)
            r["breaks"] = breaks(r, ref)
        rows += g + b
        out[layout] = {}
        for hz in (100, 400):
            r, ref = next(x for x in g if x["imu_hz"] == hz and x["gnss_receivers"] == 1), bare[hz]
            out[layout][f"{hz}hz"] = {
                **{k: r[k] for k in ("imu_to_odom_p50_ms", "imu_to_odom_p99_ms", "imu_to_odom_max_ms", "dropped",
                                     "imu_sent_hz", "cpu_percent", "graph_cpu_percent", "load_1min")},
                **{k: ref[k] for k in ("bare_hop_p50_ms", "bare_hop_p99_ms", "bare_relay_p50_ms", "bare_relay_p99_ms")},
                "bare_cpu_percent": ref["cpu_percent"],
                "p99_over_bare_hop": round(r["imu_to_odom_p99_ms"] / ref["bare_hop_p99_ms"], 1)}
    main_layout = out.get("one_process") or out[args.layouts[0]]
    out.update({k: main_layout["100hz"][k] for k in ("imu_to_odom_p50_ms", "imu_to_odom_p99_ms", "imu_to_odom_max_ms",
                                                      "bare_hop_p50_ms", "bare_hop_p99_ms")})
    if "processes" in out:
        out["graph_cpu_percent_100hz"] = out["processes"]["100hz"]["graph_cpu_percent"]
        out["cpu_percent_per_node_100hz"] = out["processes"]["100hz"]["cpu_percent"]
    out["goals"] = {"p99_le_3x_bare_hop": out["imu_to_odom_p99_ms"] <= 3 * out["bare_hop_p99_ms"],
                    "graph_cpu_under_10_percent": out.get("graph_cpu_percent_100hz", math.inf) < 10.0}
    out["scaling"] = [r for r in rows if "gnss_receivers" in r]
    out["bare"] = [r for r in rows if "gnss_receivers" not in r]
    out["load_average_end"] = [round(v, 2) for v in os.getloadavg()]
    return out


def fmt(v):
    return "-" if v is None else f"{v:g}" if isinstance(v, (int, float)) else str(v)


def table(out):
    lines = [f"Machine: {out['cores']} cores shared with other jobs; load average (1/5/15 min) "
             f"{out['load_average_start']} at start, {out['load_average_end']} at end.", "",
             "| layout | IMU Hz | imu->odom p50 / p99 / max ms | bare hop p50 / p99 ms | bare relay (2 hops) p99 ms "
             "| p99 / bare hop | CPU % of a core | dropped |", "|---|---|---|---|---|---|---|---|"]
    for layout in LAYOUTS:
        for hz, r in out.get(layout, {}).items():
            cpu = ", ".join(f"{k} {v}" for k, v in r["cpu_percent"].items())
            lines.append(f"| {layout} | {hz[:-2]} | {fmt(r['imu_to_odom_p50_ms'])} / {fmt(r['imu_to_odom_p99_ms'])} / "
                         f"{fmt(r['imu_to_odom_max_ms'])} | {fmt(r['bare_hop_p50_ms'])} / {fmt(r['bare_hop_p99_ms'])}"
                         " | "
                         f"{fmt(r['bare_relay_p99_ms'])} | {fmt(r['p99_over_bare_hop'])} | {cpu} | {r['dropped']} |")
    g = out["goals"]
    met = {True: "met", False: "not met"}
    lines += ["", f"Goals: p99 <= 3x bare hop (100 Hz, one process): **{met[g['p99_le_3x_bare_hop']]}**"
              f" ({out['imu_to_odom_p99_ms']} vs {out['bare_hop_p99_ms']} ms); graph < 10 % of a core at 100 Hz: "
              f"**{met[g['graph_cpu_under_10_percent']]}** "
              f"({fmt(out.get('graph_cpu_percent_100hz'))} %).", "",
              "Scaling (graph CPU % of a core: processes = the nav graph processes' sum; one_process = the process "
              "minus the same process in the bare relay run at that rate, an estimate):", "",
              "| layout | IMU Hz | GNSS rx | source Hz | odom Hz | p50 / p99 / max ms | bare hop p99 ms | CPU % | load "
              "| breaks |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in out["scaling"]:
        cpu = r["graph_cpu_percent"]
        lines.append(f"| {r['layout']} | {r['imu_hz']} | {r['gnss_receivers']} | {r['imu_sent_hz']} | {r['out_hz']} | "
                     f"{fmt(r['imu_to_odom_p50_ms'])} / {fmt(r['imu_to_odom_p99_ms'])} / {fmt(r['imu_to_odom_max_ms'])}"
                     f" | {fmt(r['bare_hop_p99_ms'])} | {fmt(cpu)} | {r['load_1min']} | "
                     f"{'; '.join(r['breaks']) or 'ok'} |")
    lines.append("")
    for layout in LAYOUTS:  # where it breaks: the first failing phase of the rate sweep / the receiver sweep
        rows = [r for r in out["scaling"] if r["layout"] == layout]
        for what, sweep in (("IMU rate", [r for r in rows if r["gnss_receivers"] == 1]),
                            ("GNSS receivers at 100 Hz", [r for r in rows if r["imu_hz"] == 100])):
            bad = next((r for r in sweep if r["breaks"]), None)
            if sweep:
                lines.append(f"- {layout}, {what}: " + (f"breaks at {r_label(bad)} ({'; '.join(bad['breaks'])})" if bad
                             else f"no break up to {r_label(sweep[-1])}"))
    return "\n".join(lines)


def r_label(r):
    return f"{r['imu_hz']} Hz, {r['gnss_receivers']} receiver(s)"


def main(argv):
    ap = argparse.ArgumentParser(prog="agnav bench latency", description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--config", default="nsm", help="graph config (default nsm)")
    ap.add_argument("--seconds", type=float, default=10.0, help="measured seconds at 100 and 400 Hz (default 10)")
    ap.add_argument("--scaling-seconds", type=float, default=5.0, help="measured seconds of the other phases")
    ap.add_argument("--no-scaling", action="store_true", help="only 100 and 400 Hz with one receiver")
    ap.add_argument("--layouts", default=",".join(LAYOUTS), help="comma list of one_process,processes")
    docs_option(ap, "latency.md")
    ap.add_argument("--relay", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.relay:
        return run_relay_process()
    args.layouts = [x for x in args.layouts.split(",") if x]
    if not set(args.layouts) <= set(LAYOUTS):
        ap.error(f"--layouts: choose from {', '.join(LAYOUTS)}")
    started = time.monotonic()
    out = run(args)
    out["wall_s"] = round(time.monotonic() - started, 1)
    text = table(out)
    print(text)
    if args.write_docs:
        write_docs(args.write_docs, DOC_HEAD + text + "\n\nRaw JSON: see `agnav bench latency --json`.\n")
    if args.json:
        print(json.dumps(out))
    return 0


DOC_HEAD = f"""# Latency benchmark (issue 14 items 4-5)

Reproduce: `agnav bench latency --json --write-docs docs/benchmarks/latency.md` (about 3 minutes). All numbers below come from one run on
a 2-core machine shared with other jobs (load average printed with them): the p99s and the bare hop swing by
several ms with that load, so compare ratios within the run, not across runs.

{__doc__.split(chr(10), 1)[1]}
"""

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
