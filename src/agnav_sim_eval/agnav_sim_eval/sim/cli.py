"""`agnav sim SCENARIO --seed N --out DIR`: simulate a scenario and write its rosbag2 (mcap)."""
import argparse
import json
import time
from pathlib import Path

from .bag import record
from .scenarios import SCENARIOS
from .simulator import TractorSimulator


def _size(path):
    return sum(f.stat().st_size for f in Path(path).rglob("*") if f.is_file())


def main(argv=None):
    parser = argparse.ArgumentParser(prog="agnav sim", description=__doc__)
    parser.add_argument("scenario", nargs="?", choices=sorted(SCENARIOS), help="scenario (omit with --list)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", help="output bag directory (default out/sim/<scenario>_s<seed>)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing output directory")
    parser.add_argument("--list", action="store_true", help="list scenarios and exit")
    parser.add_argument("--json", action="store_true", help="print a JSON summary as the last line")
    args = parser.parse_args(argv)
    if args.list or not args.scenario:
        for name, sc in SCENARIOS.items():
            print(f"{name:20s} {sc.description}")
        return 0 if args.list else 2
    out = Path(args.out or f"out/sim/{args.scenario}_s{args.seed}")
    start = time.perf_counter()
    sim = TractorSimulator(args.scenario, args.seed)
    try:
        counts = record(sim, out, overwrite=args.overwrite)
    except FileExistsError as exc:
        print(f"agnav sim: {exc}")
        return 1
    elapsed = time.perf_counter() - start
    summary = dict(scenario=args.scenario, seed=args.seed, out=str(out), duration_s=round(sim.t, 2),
                   generation_s=round(elapsed, 2), size_bytes=_size(out), datum=list(sim.scenario.datum),
                   messages=counts)
    for topic, n in sorted(counts.items()):
        print(f"{topic:28s} {n:7d}")
    print(f"{args.scenario} seed {args.seed}: {sim.t:.1f} s simulated in {elapsed:.1f} s -> {out} "
          f"({summary['size_bytes'] / 1e6:.2f} MB), datum {sim.scenario.datum}")
    if args.json:
        print(json.dumps(summary))
    return 0
