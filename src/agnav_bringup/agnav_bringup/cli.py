"""`agnav`: one command for the graph runner (this package) and the simulator, evaluator, calibration and
benchmarks of agnav_sim_eval (imported on use: a product install without it still runs graphs)."""
import atexit
import importlib
import os
import sys
import threading

COMMANDS = {
    "run": ("agnav_bringup.runner", "start a graph config (replay a bag, record, evaluate)"),
    "bench": (None, "agnav bench NAME [--json]: run a benchmark (see `agnav bench --list`)"),
    "sim": ("agnav_sim_eval.sim.cli", "simulate a scenario into a bag"),
    "eval": ("agnav_sim_eval.evaluate", "score a recorded output against ground truth"),
    "calibrate": ("agnav_sim_eval.calibrate", "tilt-sensor zeros and IMU level from a park / turn round / park drive"),
    "recover": (None, "agnav recover DIR: finish a recording whose run was killed (keeps every flushed chunk)"),
}


def bench(argv):
    from agnav_sim_eval import bench as bench_pkg
    names = bench_pkg.available()
    if not argv or argv[0] in ("-h", "--help", "--list"):
        print("usage: agnav bench NAME [--json] [...]\nbenchmarks: " + ", ".join(names))
        return 0 if argv else 2
    if argv[0] not in names:
        print(f"agnav bench: unknown benchmark '{argv[0]}'; available: {', '.join(names)}", file=sys.stderr)
        return 2
    return importlib.import_module(f"agnav_sim_eval.bench.{argv[0]}").main(argv[1:])


def recover(argv):
    if len(argv) != 1 or argv[0].startswith("-"):
        print("usage: agnav recover DIR\nfinish the rosbag2 folder of a killed `agnav run --record DIR` (messages "
              "up to about a second before the kill are kept)")
        return 0 if argv and argv[0] in ("-h", "--help") else 2
    from agnav_common.mcap_recording import recover_bag
    try:
        count = recover_bag(argv[0])
    except (OSError, ValueError) as exc:
        print(f"agnav recover: error: {exc}", file=sys.stderr)
        return 2
    print(f"agnav recover: {argv[0]}: {count} messages kept")
    return 0


def exit_now(status):
    """End the process as the interpreter would (other threads joined, atexit handlers run, stdio flushed) minus its
    teardown: freeing every module (~0.1 s CPU after a replay) and Fast DDS's participant factory, whose destructor
    sleeps 100 ms."""
    for thread in threading.enumerate():
        if thread is not threading.current_thread() and not thread.daemon:
            thread.join()
    atexit._run_exitfuncs()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status or 0)


def main(argv=None):
    """Called as the program (argv None: the console script, python -m) the process ends in exit_now."""
    if argv is None:
        exit_now(main(sys.argv[1:]))
    if not argv or argv[0] in ("-h", "--help") or argv[0] not in COMMANDS:
        print("usage: agnav COMMAND [...]\n" + "\n".join(f"  {k:9s} {v[1]}" for k, v in COMMANDS.items()))
        return 0 if argv and argv[0] in ("-h", "--help") else 2
    if argv[0] == "bench":
        return bench(argv[1:])
    if argv[0] == "recover":
        return recover(argv[1:])
    try:
        module = importlib.import_module(COMMANDS[argv[0]][0])
    except ModuleNotFoundError as exc:
        if exc.name != "agnav_sim_eval":
            raise
        print(f"agnav {argv[0]}: needs the agnav_sim_eval package (not installed)", file=sys.stderr)
        return 2
    try:
        return int(module.main(argv[1:]) or 0)
    except KeyboardInterrupt:  # Ctrl-C outside a graph run (e.g. during an evaluation): no traceback
        return 130


if __name__ == "__main__":
    sys.exit(main())
