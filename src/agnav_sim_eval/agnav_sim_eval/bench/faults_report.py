"""The report side of `agnav bench faults`: the markdown page (merged per graph into docs/benchmarks/faults.md) and
the memory test (RSS slope of a long replay)."""
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from agnav_sim_eval.bench import faults, faults_drivers
from agnav_sim_eval.bench.faults import AFTER_FAULT_S, CRITERIA, GRAPHS, REPO, totals
from agnav_sim_eval.fault_injection import bag_span, repeat_bag


def rss_mb(pid):
    """Resident set size of a process in MB (/proc; psutil is not a dependency)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return math.nan


def memory(minutes, rate, domain, tmp):
    """RSS slope (MB/min) of `agnav run nsm` replaying asphalt_loop repeated end to end at `rate` for `minutes`
    of wall time (no recording), fitted after the first fifth (start-up)."""
    config, src, _, _, _ = GRAPHS["nsm"]
    bag = Path(tmp) / "nsm_long"
    length = bag_span(src)[1] - bag_span(src)[0]
    log_s = repeat_bag(src, bag, max(1, math.ceil(minutes * 60 * rate / length)))
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_DOMAIN_ID=str(domain))
    proc = subprocess.Popen([sys.executable, "-m", "agnav_bringup.cli", "run", config, "--bag", str(bag), "--rate",
                             str(rate), "--duration", str(minutes * 60), "--quiet", "--no-eval"], env=env, cwd=REPO,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    start, samples = time.monotonic(), []
    while proc.poll() is None:
        try:
            samples.append((time.monotonic() - start, rss_mb(proc.pid)))
        except OSError:
            break
        time.sleep(2.0)
    err = proc.communicate()[1]
    a = np.array([s for s in samples if s[0] >= 0.2 * minutes * 60 and math.isfinite(s[1])], float).reshape(-1, 2)
    slope = float(np.polyfit(a[:, 0] / 60, a[:, 1], 1)[0]) if len(a) > 2 else None
    return {"memory_slope_mb_per_min": slope, "pass": slope is not None and slope < 1.0, "rc": proc.returncode,
            "minutes": minutes, "rate": rate, "bag_log_s": log_s, "rss_start_mb": samples[0][1] if samples else None,
            "rss_end_mb": samples[-1][1] if samples else None, "error": err.strip().splitlines()[-3:]}


def fmt(v, spec=".2f"):
    return "–" if v is None else format(v, spec)


def _ok(r, key):
    return "–" if key not in r else ("ok" if r[key] else "**FAIL**")


def markdown(results, cleans, tot):
    lines = ["# Fault injection (`agnav bench faults --write-docs docs/benchmarks/faults.md`)", "", faults.__doc__.split("\n\n", 1)[1].strip(), "",
             "| case | graph | pass | crash | NaN | (a) gap s | (b) stamps | (c) >3σ samples | (d) recovery s "
             "| (e) diagnostics s | max error m | max error/σ |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in cleans + results:
        lines.append(
            f"| {r['case']} | {r['graph']} | {'yes' if r['pass'] else '**no**'} | {'**yes**' if r['crash'] else 'no'} "
            f"| {r.get('nan_outputs', 0)} | {fmt(r.get('max_gap_s'))} {_ok(r, 'gap_ok')} "
            f"| {r.get('outside_span', '–')} {_ok(r, 'stamps_ok')} | {r.get('over_3sigma', '–')} {_ok(r, 'sigma_ok')} "
            f"| {fmt(r.get('recovery_s'), '.1f') if 'recovery_s' in r else '–'} {_ok(r, 'recovered_ok')} "
            f"| {fmt(r.get('detected_after_s'))} {_ok(r, 'detected_ok')} | {fmt(r.get('max_error_m'), '.3f')} "
            f"| {fmt(r.get('max_error_over_sigma'), '.1f')} |")
    lines += ["", f"Totals: {tot['cases']} cases, {tot['passes']} pass, {tot['crashes']} crashes, "
              f"{tot['nan_outputs']} NaN outputs, {tot['over_3sigma_samples']} samples over 3σ (clean runs: "
              f"{tot['clean_over_3sigma_samples']}), {tot['not_recovered']} not recovered, recovery max "
              f"{fmt(tot['recovery_s']['max'], '.1f')} s / mean {fmt(tot['recovery_s']['mean'], '.1f')} s; failures per "
              "criterion: " + ", ".join(f"{k[:-3]} {tot[k + '_failures']}" for k in CRITERIA) + ".", "",
              "Recovery '–' with FAIL: still off the clean run at the end of the replay (fault end + "
              f"{AFTER_FAULT_S:.0f} s) or no output after the fault. Diagnostics '–' with FAIL: no visible change."]
    return "\n".join(lines) + "\n"


def _doc_parts(text):
    """(rows by graph, totals line by graph ('legacy': one for all bag graphs), drivers section) of a written doc."""
    rows, tots, drivers = {}, {}, ""
    head, sep, tail = text.partition("\n## Drivers")
    if sep:
        drivers = sep.lstrip("\n") + tail
    for line in head.splitlines():
        cells = [c.strip() for c in line.split("|")]
        if line.startswith("| ") and len(cells) > 3 and cells[2] in GRAPHS:
            rows.setdefault(cells[2], []).append(line)
        elif line.startswith("Totals: "):
            tots["legacy"] = line
        elif line.startswith("Totals ") and line.split(":")[0].split()[-1] in GRAPHS:
            tots[line.split(":")[0].split()[-1]] = line
    return rows, tots, drivers


def merged_docs(old, results, cleans, driver_results):
    """The doc with the graphs run replaced (bag rows and totals per graph, the drivers section) and the others kept."""
    rows, tots, drivers = _doc_parts(old)
    for graph in {r["graph"] for r in cleans + results}:
        res = [r for r in results if r["graph"] == graph]
        cln = [r for r in cleans if r["graph"] == graph]
        text = markdown(res, cln, totals(res, cln)).splitlines()
        rows[graph] = [ln for ln in text if ln.startswith("| ") and not ln.startswith("| case ")]
        tots[graph] = next(ln for ln in text if ln.startswith("Totals: ")).replace("Totals: ", f"Totals {graph}: ", 1)
        tots.pop("legacy", None)  # one graph's new totals make the old all-graph line stale
    if driver_results:
        drivers = faults_drivers.markdown(driver_results, faults_drivers.totals(driver_results))
    base = markdown([], [], totals([], [])).splitlines()
    table = [ln for g in GRAPHS for ln in rows.get(g, []) if ln.startswith("| clean ")] + \
            [ln for g in GRAPHS for ln in rows.get(g, []) if not ln.startswith("| clean ")]
    lines = base[:base.index("|---|---|---|---|---|---|---|---|---|---|---|---|") + 1] + table + [""] + \
        [tots[g] for g in ("legacy", *GRAPHS) if g in tots] + base[next(i for i, ln in enumerate(base)
                                                                         if ln.startswith("Totals: ")) + 1:]
    return "\n".join(lines).rstrip("\n") + "\n" + ("\n" + drivers if drivers else "")
