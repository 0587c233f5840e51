"""`agnav run`: start a graph config in one process (one executor) or one OS process per node.

The bag player and recorder always live in the runner's process; configured nodes join them there, or
run as child processes (`--processes`, the same graph over DDS). A replay at rate 0 in one process is
deterministic: the nodes talk through agnav_common.local_bus, the player publishes the bag in log-time order and
each message reaches the whole graph (and the recorder) before the next one, timers fire at their sim time. SIGINT/SIGTERM stop everything (exit 0).
Exit 2 with one line for a config or node that cannot start (YAML error, unknown key or parameter, bad value);
exit 1 with one line when a node raises while running or a child process dies.
"""
import argparse
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

from agnav_bringup.graph_config import REPO_ROOT, ConfigError, load_config

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")  # DDS never leaves this host

import rclpy  # noqa: E402  (after the discovery range is fixed)
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor  # noqa: E402
from rclpy.experimental import EventsExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402

from agnav_common.mcap_recording import unfinished  # noqa: E402
from agnav_common.frames import quaternion_from_euler  # noqa: E402
from agnav_common.local_bus import LocalBus  # noqa: E402
from agnav_common.node_main import (PARENT_ENV, ParameterNameError, check_parameter_names,  # noqa: E402
                                    init_without_signal_handlers, one_line, stop_on_signals)
from agnav_common.tf import StaticTransformPublisher, make_transform  # noqa: E402
from agnav_drivers.bag_player_node import BagPlayerNode  # noqa: E402
from agnav_drivers.bag_recorder_node import BagRecorderNode  # noqa: E402


# Across processes, rate 0 keeps every message but not their order across topics: a sample that a lagging
# reader's full history rejects is resent at the writer's next heartbeat, seconds later, while other topics flow
# on; filters that fuse several topics then see skewed inputs (nsm: horizontal 14.9 cm instead of 7.7). A paced
# replay that the nodes keep up with avoids it (nsm at 5x real time over processes: same errors as one process).
PROCESSES_RATE = 5.0
BATCH = 256  # deterministic replay: bag messages between checks for signals, --duration, services, wall timers


def parse_args(argv):
    ap = argparse.ArgumentParser(prog="agnav run", description=__doc__.splitlines()[0])
    ap.add_argument("config", nargs="?", default="nsm", help="bundled config name or YAML path (default nsm)")
    ap.add_argument("--bag", help="input bag to replay (default: the config's bag)")
    ap.add_argument("--live", action="store_true", help="no replay: run the nodes on live drivers/simulator")
    ap.add_argument("--sim-time", action="store_true",
                    help="live runs: nodes follow /clock of an external simulator (config key use_sim_time)")
    ap.add_argument("--rate", type=float, default=None,
                    help=f"replay rate; 0 = as fast as possible without drops (default; {PROCESSES_RATE:g} with "
                         "--processes)")
    ap.add_argument("--exclude", action="append", default=[], metavar="TOPIC",
                    help="bag topic not to replay (e.g. outputs of an earlier run that the graph publishes again)")
    ap.add_argument("--record", metavar="OUT", help="record to this rosbag2 folder (an earlier finished recording there is replaced)")
    ap.add_argument("--processes", action="store_true", help="one OS process per node")
    transport = ap.add_mutually_exclusive_group()
    transport.add_argument("--dds", action="store_true",
                           help="rate 0 in one process: replay over DDS with flow control, not the deterministic bus")
    transport.add_argument("--publish", action="store_true",
                           help="deterministic replay: also publish every message on DDS (for a live viewer)")
    ap.add_argument("--duration", type=float, default=0.0, help="stop after this many seconds (0: bag end / SIGINT)")
    ap.add_argument("--no-eval", action="store_true", help="skip the accuracy evaluation after a recorded replay")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    return ap.parse_args(argv)


def replay_rate(args):
    if args.rate is not None:
        if args.rate == 0.0 and args.processes:
            print("agnav run: warning: --rate 0 across processes may reorder topics (see PROCESSES_RATE)",
                  file=sys.stderr)
        return args.rate
    return PROCESSES_RATE if args.processes else 0.0


def deterministic(args, bag):
    """Replay through the in-process bus: a bag at rate 0, nodes in this process, --dds not given."""
    return bag is not None and not args.processes and not args.dds and replay_rate(args) == 0.0


def static_transform_node(config, use_sim_time=False):
    """A tiny node publishing the config's static mounts on /tf_static (None when there are none); on sim time
    (deterministic replay) they are stamped 0, before the bag's clock starts."""
    if not config.static_transforms:
        return None
    node = rclpy.create_node("agnav_static_transforms",
                             parameter_overrides=[Parameter("use_sim_time", value=True)] if use_sim_time else [])
    publisher = StaticTransformPublisher(node)
    publisher.send([make_transform(t["parent"], t["child"], node.get_clock().now().to_msg(),
                                   t.get("xyz", [0, 0, 0]), quaternion_from_euler(*t.get("rpy", [0, 0, 0])))
                    for t in config.static_transforms])
    node._agnav_publisher = publisher  # keep alive with the node
    return node


def drained(recorder, finished_at, quiet):
    """True once the graph has been quiet (nothing recorded) for `quiet` seconds after the replay ended
    (at monotonic time `finished_at`; also when nothing was recorded at all)."""
    if recorder is None:
        return True
    return time.monotonic() - max(recorder.last_write or 0.0, finished_at) >= quiet


def params_of(spec, use_sim_time):
    params = dict(spec.parameters)
    params["use_sim_time"] = use_sim_time
    return params


class ChildProcesses:
    """Configured nodes as OS processes, each in its own session so that signals are ours to send."""

    def __init__(self, specs, use_sim_time, workdir):
        self.procs = []
        env = dict(os.environ, **{PARENT_ENV: str(os.getpid())})  # children stop if this runner is killed
        for spec in specs:
            exe = shutil.which(spec.executable) or str(Path(sys.prefix) / "bin" / spec.executable)
            pfile = Path(workdir) / f"{spec.label}.yaml"
            pfile.write_text(yaml.safe_dump({"/**": {"ros__parameters": params_of(spec, use_sim_time)}}))
            cmd = [exe] + spec.ros_args() + ["--params-file", str(pfile)]
            self.procs.append((spec, subprocess.Popen(cmd, start_new_session=True, env=env)))

    def wait_until_discovered(self, probe, timeout, stop):
        """Block until every child node is in the ROS graph (a replay must not start before)."""
        names = {spec.label for spec, _ in self.procs}
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not self.failure() and not self.finished() and not stop:
            if names <= set(probe.get_node_names()):
                break
            time.sleep(0.1)
        probe.destroy_node()

    def failure(self):
        """(description, exit status for the runner) of the first child that has exited with an error, else None;
        status 2 when the child could not start (it printed the reason)."""
        for spec, proc in self.procs:
            if proc.poll() is not None and proc.returncode != 0:
                return f"node '{spec.label}' exited with code {proc.returncode}", 2 if proc.returncode == 2 else 1
        return None

    def finished(self):
        """True when a child has ended cleanly (e.g. a simulator at the end of its scenario)."""
        return any(proc.poll() == 0 for _, proc in self.procs)

    def stop(self):
        for _, proc in self.procs:
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
        deadline = time.monotonic() + 5.0
        for _, proc in self.procs:
            try:
                proc.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def prepare_record(record):
    """Make way for a recording at `record`: an earlier recording is replaced, anything else is kept."""
    if record is None or not record.exists():
        return
    if unfinished(record):
        raise ConfigError(f"{record} holds an unfinished recording (a killed run): keep it with "
                          f"`agnav recover {record}`, or delete it")
    if not record.is_dir() or (any(record.iterdir()) and not (record / "metadata.yaml").exists()):
        raise ConfigError(f"{record} exists and is not a recording; refusing to replace it")
    shutil.rmtree(record)


def build_nodes(config, use_sim_time, nodes):
    """Append the configured nodes to `nodes` (the caller destroys them); each must declare every parameter
    the config gives it. ConfigError (one line) for a node that cannot start."""
    for spec in config.nodes:
        try:
            overrides = [Parameter(k, value=v) for k, v in params_of(spec, use_sim_time).items()]
            nodes.append(spec.node_class()(parameter_overrides=overrides, cli_args=spec.ros_args()))
            check_parameter_names(nodes[-1], spec.parameters)
        except ParameterNameError as exc:
            raise ConfigError(str(exc)) from None
        except Exception as exc:  # bad value (descriptor range, node check), unknown executable
            raise ConfigError(f"node '{spec.label}': {one_line(exc)}") from exc


def run(args):
    try:
        config = load_config(args.config)
        record = Path(args.record) if args.record else None
        prepare_record(record)
    except ConfigError as exc:
        print(f"agnav run: error: {exc}", file=sys.stderr)
        return 2
    bag = None if args.live else (Path(args.bag) if args.bag else config.bag_path())
    use_sim_time = bag is not None or args.sim_time or config.use_sim_time

    init_without_signal_handlers(["--ros-args"])
    stopping = stop_on_signals()  # Ctrl-C / SIGTERM: leave the loop, close everything, exit 0
    nodes, children, player, recorder, error, status = [], None, None, None, None, 0
    workdir = tempfile.mkdtemp(prefix="agnav_run_")
    bus = LocalBus(publish_dds=args.publish).install() if deterministic(args, bag) else None
    try:
        if args.processes:
            children = ChildProcesses(config.nodes, use_sim_time, workdir)
        else:
            build_nodes(config, use_sim_time, nodes)
        static = static_transform_node(config, use_sim_time=bus is not None)
        if static is not None:
            nodes.append(static)
        if children:
            children.wait_until_discovered(rclpy.create_node("agnav_runner"), timeout=30.0, stop=stopping)
        if bag is not None:
            try:
                player = BagPlayerNode(parameter_overrides=[
                    Parameter("bag", value=str(bag)), Parameter("rate", value=replay_rate(args)),
                    Parameter("remap", value=[f"{a}:={b}" for a, b in config.bag_remap.items()] or [""]),
                    Parameter("exclude", value=args.exclude or [""]),
                    Parameter("progress", value=not args.quiet),
                    Parameter("cache_dir", value=str(REPO_ROOT / "build" / "bag_cache")),
                    Parameter("start_delay", value=2.0 if args.processes else 0.5),
                    Parameter("min_subscribers", value=1 if record is not None else 0),
                    Parameter("external_drive", value=bus is not None), Parameter("use_sim_time", value=bus is not None)])
            except Exception as exc:  # no such bag, an empty bag, nothing to replay
                raise ConfigError(f"replay: {one_line(exc)}") from exc
            nodes.append(player)
        if record is not None:
            recorder = BagRecorderNode(parameter_overrides=[
                Parameter("output", value=str(record)), Parameter("topics", value=config.record or [""]),
                Parameter("use_sim_time", value=use_sim_time)])
            nodes.append(recorder)
        executor = EventsExecutor() if bus is None else SingleThreadedExecutor()  # bus: services, wall timers
        for node in nodes:
            executor.add_node(node)
        started, finished_at, next_spin = time.monotonic(), None, 0.0
        print(f"agnav run: {config.path.name}: {len(config.nodes)} node(s)"
              f"{' as processes' if args.processes else ''}{' deterministic' if bus else ''}"
              f"{f', replaying {bag}' if bag else ''}{' on sim time (/clock)' if use_sim_time and not bag else ''}"
              f"{f', recording {record}' if record else ''}", flush=True)
        while rclpy.ok() and not stopping:
            if bus is not None:  # the player drives the whole graph; the executor only between batches
                if not player.play(BATCH):
                    break
                if time.monotonic() >= next_spin:
                    executor.spin_once(timeout_sec=0.0)
                    next_spin = time.monotonic() + 0.1
            else:
                executor.spin_once(timeout_sec=0.05)
            failed = children.failure() if children else None
            if failed:
                error, status = failed
                break
            if args.duration and time.monotonic() - started > args.duration:
                break
            if player is not None and player.finished:
                finished_at = finished_at or time.monotonic()
                if drained(recorder, finished_at, quiet=2.0 if args.processes else 0.3):
                    break
            if player is None and (any(getattr(n, "finished", False) for n in nodes) or
                                   (children and children.finished())):
                break  # a live source (the simulator) has ended its run
    except (KeyboardInterrupt, ExternalShutdownException):
        stopping.append("SIGINT")
    except ConfigError as exc:  # a node could not start: one line, status 2
        error, status = str(exc), 2
    except Exception as exc:  # a node raised while running: one line, status 1
        error, status = f"{type(exc).__name__}: {one_line(exc)}", 1
    finally:
        if children:
            children.stop()
        for node in reversed(nodes):
            node.destroy_node()
        if bus is not None:
            bus.uninstall()
        rclpy.try_shutdown()
        shutil.rmtree(workdir, ignore_errors=True)
        for sig in (signal.SIGINT, signal.SIGTERM):  # the evaluation below is interruptible again
            signal.signal(sig, signal.SIG_DFL if sig == signal.SIGTERM else signal.default_int_handler)
    if error:
        print(f"agnav run: error: {error}", file=sys.stderr)
        return status
    if recorder is not None:
        print(f"agnav run: recorded {sum(recorder.counts.values())} messages on {len(recorder.counts)} topics "
              f"to {record}")
        if bag is not None and not args.no_eval and not stopping and "/ground_truth/odometry" in recorder.counts \
                and "/odometry/filtered" in recorder.counts:
            from agnav_sim_eval.evaluate import main as evaluate
            return evaluate([str(record), "--truth", str(bag), "--plots", str(record / "plots")])
    return 0


def main(argv=None):
    return run(parse_args(sys.argv[1:] if argv is None else argv))
