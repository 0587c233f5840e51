"""`agnav bench replay`: graph replay throughput, /imu/data_raw hop latency at 200 Hz, install/test times.

Throughput: wall and CPU seconds of the whole `agnav run CONFIG --record OUT --no-eval` (start-up included) for the
default (nsm), gds and ins graphs in deterministic mode (agnav_common.local_bus), nsm over DDS (`--dds`, the
former one-process mode), and the player + recorder alone (`replay` config on the nsm bag); next to them the CPU of
the navigation core alone on that bag (agnav_sim_eval.offline.replay: the node's pipeline, messages in log order).
Latency is publish-to-callback time of sensor_msgs/Imu at 200 Hz (stamp = wall time at publish):
agnav nodes on one EventsExecutor in one process, agnav nodes in two processes (`--processes`
layout) and a bare rclpy pub/sub pair (default executor, two processes) measured in the same run.
"""
import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

import numpy as np  # noqa: E402
import rclpy  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.experimental import EventsExecutor  # noqa: E402
from sensor_msgs.msg import Imu  # noqa: E402

from agnav_bringup.graph_config import REPO_ROOT, load_config  # noqa: E402
from agnav_common.qos import PUBLISHER_QOS, SENSOR_QOS  # noqa: E402
from agnav_common.stamps import to_sec, to_stamp  # noqa: E402
from agnav_drivers.bag_source import BagSource  # noqa: E402
from agnav_sim_eval.bench import docs_option, write_docs  # noqa: E402

RATE_HZ = 200.0


def source_node(count):
    node = rclpy.create_node("latency_source")
    pub = node.create_publisher(Imu, "/imu/data_raw", PUBLISHER_QOS)
    sent = []

    def tick():
        if len(sent) < count and pub.get_subscription_count() > 0:
            msg = Imu()
            msg.header.stamp = to_stamp(time.time())
            pub.publish(msg)
            sent.append(1)
    node.create_timer(1.0 / RATE_HZ, tick)
    return node, sent


def sink_node(latencies):
    node = rclpy.create_node("latency_sink")
    node.create_subscription(Imu, "/imu/data_raw", lambda m: latencies.append(time.time() - to_sec(m.header.stamp)),
                             SENSOR_QOS)
    return node


def spin_until(executor, done, timeout):
    deadline = time.monotonic() + timeout
    while not done() and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)


def run_sink_process(count, bare, out):
    """Child process: receive `count` messages, write latencies (s) as JSON."""
    rclpy.init()
    latencies = []
    node = sink_node(latencies)
    executor = SingleThreadedExecutor() if bare else EventsExecutor()
    executor.add_node(node)
    spin_until(executor, lambda: len(latencies) >= count, timeout=60 + count / RATE_HZ)
    Path(out).write_text(json.dumps(latencies))
    node.destroy_node()
    rclpy.try_shutdown()


def latency_single_process(count):
    rclpy.init()
    latencies = []
    source, _ = source_node(count)
    sink = sink_node(latencies)
    executor = EventsExecutor()
    executor.add_node(source)
    executor.add_node(sink)
    spin_until(executor, lambda: len(latencies) >= count, timeout=30 + count / RATE_HZ)
    source.destroy_node()
    sink.destroy_node()
    rclpy.try_shutdown()
    return latencies


def latency_two_processes(count, bare):
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "lat.json"
        child = subprocess.Popen([sys.executable, "-m", "agnav_sim_eval.bench.replay", "--sink", str(count), str(out)]
                                 + (["--bare"] if bare else []))
        rclpy.init()
        source, sent = source_node(count)
        executor = SingleThreadedExecutor() if bare else EventsExecutor()
        executor.add_node(source)
        spin_until(executor, lambda: child.poll() is not None, timeout=90 + count / RATE_HZ)
        source.destroy_node()
        rclpy.try_shutdown()
        child.wait(timeout=10)
        return json.loads(out.read_text()) if out.exists() else []


def percentiles_ms(latencies):
    a = np.asarray(latencies) * 1e3
    return {"p50_ms": round(float(np.percentile(a, 50)), 3), "p99_ms": round(float(np.percentile(a, 99)), 3),
            "n": int(a.size)}


GRAPHS = [("nsm", []), ("gds", []), ("ins", []), ("nsm", ["--dds"]), ("replay", ["--bag", "nsm"])]


def replay_throughput(config, extra=()):
    """One `agnav run` in a child process: wall and CPU seconds (user + system), x real time."""
    extra = [str(load_config(a).bag_path()) if i and extra[i - 1] == "--bag" else a for i, a in enumerate(extra)]
    cfg = load_config(config)
    bag = BagSource(extra[extra.index("--bag") + 1] if "--bag" in extra else cfg.bag_path())
    duration, count = (bag.end_ns - bag.start_ns) / 1e9, bag.message_count
    bag.close()
    with tempfile.TemporaryDirectory() as tmp:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.monotonic()
        result = subprocess.run([sys.executable, "-m", "agnav_bringup.cli", "run", config, *extra, "--record",
                                 str(Path(tmp) / "rec"), "--quiet", "--no-eval"], capture_output=True, text=True)
        wall = time.monotonic() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if result.returncode != 0:
        raise RuntimeError(f"agnav run {config} failed: {result.stderr[-2000:]}")
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    return {"config": config + ("" if "--bag" in extra else "".join(f" {a}" for a in extra)),
            "mode": "dds" if "--dds" in extra else "deterministic", "bag": Path(bag.path).name,
            "bag_messages": count, "bag_seconds": round(duration, 1), "wall_s": round(wall, 2), "cpu_s": round(cpu, 2),
            "messages_per_s": round(count / wall), "x_real_time": round(duration / wall, 1),
            "x_real_time_cpu": round(duration / cpu, 1)}


def core_cpu(config="nsm"):
    """CPU seconds of the navigation core alone on the config's bag (offline replay, bag reading included)."""
    from agnav_sim_eval.offline import replay
    cfg = load_config(config)
    start = time.process_time()
    states, _ = replay(cfg, cfg.bag_path())
    return {"config": config, "cpu_s": round(time.process_time() - start, 2), "states": len(states)}


def install_and_test_times():
    """Fresh clone of HEAD: wall time of `make setup` (new venv) and of `make test` after it."""
    with tempfile.TemporaryDirectory() as tmp:
        clone = Path(tmp) / "main"
        subprocess.run(["git", "clone", "-q", str(REPO_ROOT), str(clone)], check=True)
        (Path(tmp) / "shared").symlink_to((REPO_ROOT.parent / "shared").resolve())
        times = {}
        for target in ("setup", "test"):
            start = time.monotonic()
            subprocess.run(["make", target], cwd=clone, check=True, capture_output=True)
            times[f"make_{target}_s"] = round(time.monotonic() - start, 1)
        return times


def table(results):
    core = results["core"]
    lines = ["| agnav run (whole command, --record, --no-eval) | mode | bag | messages | bag s | wall s | CPU s | "
             "x real time (wall) | x real time (CPU) |", "|---|---|---|---|---|---|---|---|---|"]
    for r in results["replay"]:
        lines.append(f"| {r['config']} | {r['mode']} | {r['bag']} | {r['bag_messages']} | {r['bag_seconds']} | "
                     f"{r['wall_s']} | {r['cpu_s']} | {r['x_real_time']} | {r['x_real_time_cpu']} |")
    lines += ["", f"Navigation core alone on the {core['config']} bag (offline replay, bag reading included): "
                  f"{core['cpu_s']} s CPU; the deterministic {core['config']} graph costs "
                  f"{results['graph_cpu_over_core']}x that (goal <= 2).", "",
              "| /imu/data_raw hop at 200 Hz | p50 ms | p99 ms | n |", "|---|---|---|---|"]
    for key in ("latency_single_process", "latency_processes", "latency_bare_rclpy"):
        v = results[key]
        lines.append(f"| {key.removeprefix('latency_')} | {v['p50_ms']:.3f} | {v['p99_ms']:.3f} | {v['n']} |")
    if "install" in results:
        lines += ["", "| fresh clone | seconds |", "|---|---|"] + [
            f"| {k.removesuffix('_s').replace('_', ' ')} | {v} |" for k, v in results["install"].items()]
    return "\n".join(lines)


def main(argv):
    ap = argparse.ArgumentParser(prog="agnav bench replay", description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--config", action="append", help="graph replayed for throughput (repeatable; default: nsm, "
                    "gds, ins, nsm --dds and the replay config on the nsm bag)")
    ap.add_argument("--samples", type=int, default=2000, help="latency samples per variant (200 Hz)")
    ap.add_argument("--install", action="store_true", help="also time make setup + make test on a fresh clone")
    docs_option(ap, "foundation.md")
    ap.add_argument("--sink", nargs=2, metavar=("COUNT", "OUT"), help=argparse.SUPPRESS)
    ap.add_argument("--bare", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.sink:
        run_sink_process(int(args.sink[0]), args.bare, args.sink[1])
        return 0
    graphs = [(c, []) for c in args.config] if args.config else GRAPHS
    results = {"replay": [replay_throughput(config, extra) for config, extra in graphs], "core": core_cpu(),
               "latency_single_process": percentiles_ms(latency_single_process(args.samples)),
               "latency_processes": percentiles_ms(latency_two_processes(args.samples, bare=False)),
               "latency_bare_rclpy": percentiles_ms(latency_two_processes(args.samples, bare=True))}
    graph = next((r for r in results["replay"] if r["config"] == results["core"]["config"]
                  and r["mode"] == "deterministic"), None)
    results["graph_cpu_over_core"] = graph and round(graph["cpu_s"] / results["core"]["cpu_s"], 2)
    if args.install:
        results["install"] = install_and_test_times()
    text = table(results)
    print(text)
    if args.write_docs:
        DOC = args.write_docs
        kept = ""
        if "install" not in results and DOC.exists() and "| fresh clone |" in DOC.read_text():  # not re-measured
            kept = "\n\n(fresh clone: from an earlier `--install` run)\n\n" + DOC.read_text()[
                DOC.read_text().index("| fresh clone |"):].strip()
        write_docs(DOC, "# Foundation benchmark\n\nReproduce: `agnav bench replay --json --write-docs docs/benchmarks/foundation.md [--install]` "
                       "(2-core machine, shared with other work: wall figures vary with its load, CPU less).\n"
                       "Deterministic mode is `agnav run`'s default at rate 0 in one process (agnav_common.local_bus); "
                       "its profile: docs/benchmarks/replay_profile.md.\n\n" + text + kept + "\n")
    if args.json:
        print(json.dumps(results))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
