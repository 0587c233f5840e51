"""Loose / tight / INS-only switching (gnss_raw.switching) on one simulated mems_field run (issue 18 item 5).

Receiver and sky per window (SWITCH_WINDOWS, simulation s): RTK fixed (the simulator's fixes, loose) → RTK float
(the same fixes flagged float, σ × 10; full sky: tight) → only 3 GPS satellites (no receiver fix: tight on 2 DDs)
→ full outage (no satellite: INS only) → sky back with the receiver still float (tight, its own integer re-fix)
→ RTK fixed again (loose). `refix_time_s`: from the end of the outage to the tight filter's first integer fix.
"""
from dataclasses import dataclass, replace

import numpy as np

from agnav_fusion.gnss_raw.switching import Switching
from agnav_fusion.ins import InsEkf

from .gnss_raw_sim import RawSimConfig, SkyMask, simulate_run_raw
from .gnss_raw_sim_runs import coupled_settings

FIX_FLOAT = 5
SWITCH_WINDOWS = {"float": (60.0, 90.0), "three_sat": (90.0, 120.0), "outage": (120.0, 140.0),
                  "refloat": (140.0, 170.0)}


@dataclass
class SwitchRun:
    t: np.ndarray             # raw epoch times [s]
    mode: list                # mode after each epoch
    err: np.ndarray           # (n, 3) ENU antenna error of the switched output [m]
    transitions: list         # Switching.transitions
    refix_time_s: float       # end of the outage -> first tight integer fix (inf: none)


def receiver_fixes(gnss, windows=SWITCH_WINDOWS):
    """The simulator's (arrival, GnssSample) fixes as the receiver would give them in the windows."""
    out = []
    for arrival, g in gnss:
        if any(windows[k][0] <= g.t < windows[k][1] for k in ("three_sat", "outage")):
            continue
        if any(windows[k][0] <= g.t < windows[k][1] for k in ("float", "refloat")):
            g = replace(g, fix_type=FIX_FLOAT, pos_cov_enu=np.asarray(g.pos_cov_enu) * 100.0)
        out.append((arrival, g))
    return out


def run_switching(run, nav, seed=0, windows=SWITCH_WINDOWS, streams=None):
    """SwitchRun of a SimRun (mems_field-style)."""
    from agnav_sim_eval.bench.ins import sim_streams
    masks = [SkyMask(*windows["three_sat"], keep=3), SkyMask(*windows["outage"], keep=0)]
    raw = simulate_run_raw(run, nav, RawSimConfig(seed=seed, masks=masks, slip_flagged=0.5))
    gyro, accel, gnss, mounts = streams or sim_streams(run)
    fixes = receiver_fixes(gnss, windows)
    sw = Switching(InsEkf(coupled_settings(run, mounts)), raw.base_pos)
    epochs = {round(e.t * 100): e for e in raw.epochs}
    rows, gi, refix = [], 0, np.inf
    for i, t in enumerate(run.imu.t):
        while gi < len(fixes) and fixes[gi][0] <= t:
            sw.add_gnss(fixes[gi][1])
            gi += 1
        sw.add_imu(t, gyro[i], accel[i])
        e = epochs.get(round(t * 100))
        if e is None or t < windows["float"][0] - 10.0:
            continue
        mode = sw.add_epoch(e.rover, e.base, nav)
        sol = sw.last_solution if mode == "tight" else None
        if sol is not None and sol.fixed and t >= windows["outage"][1] and refix == np.inf:
            refix = t - windows["outage"][1]
        rows.append((t, mode, raw.to_enu(sw.output()[0]) - raw.to_enu(e.antenna)))
    t, mode, err = zip(*rows)
    return SwitchRun(np.array(t), list(mode), np.array(err), sw.transitions, refix)
