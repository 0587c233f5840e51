"""Loosely vs tightly coupled GNSS/INS on one simulated run with simulated raw observations (issue 18 benches).

The mems_field run's IMU and receiver fixes drive the loosely coupled InsEkf (the shipped ins backend's core)
from the start; at `handover` s (aligned, RTK fixed) a TightFilter takes over a copy of its INS state (SPEC §7.9
loose → tight) and from then on fuses the simulated rover/base observations instead of fixes (half the random
cycle slips come without LLI). Inside the window the sky is degraded (gnss_raw_sim.SkyMask); the loose filter
keeps getting what a receiver would give there:
  'three_sat' – only 3 GPS satellites above the mask: no receiver fix at all (INS-only with its constraints);
  'float'     – a 2 s full blockage (every satellite loses lock), then a tree line hiding the west half of the sky
                below 45° for 60 s with the receiver in RTK float: its fixes are a float-only kinematic DD filter
                (gnss_raw.baseline, restarted after the blockage) with Doppler velocities (gnss_raw.doppler);
                the tight filter does not fix inside the window either (float against float).
Errors are of the antenna point (truth: simulator base_link + attitude × lever arm), horizontal, at the 1 Hz
observation epochs.
"""
import math
import time
from dataclasses import dataclass

import numpy as np
from agnav_common.frames import wrap_angle

from agnav_fusion.gnss_raw.baseline import BaselineConfig, BaselineFilter
from agnav_fusion.gnss_raw.double_difference import form_double_differences
from agnav_fusion.gnss_raw.doppler import doppler_velocity
from agnav_fusion.gnss_raw.ephemeris import satellite_states
from agnav_fusion.gnss_raw.geometry import ecef_to_llh
from agnav_fusion.gnss_raw.tight import TightConfig, TightFilter, antenna_state
from agnav_fusion.ins import GnssSample, InsEkf, InsEkfSettings

from .gnss_raw_sim import RawSimConfig, SkyMask, simulate_run_raw

FIX_FLOAT = 5
LATENCY = 0.08


@dataclass
class CoupledRun:
    t: np.ndarray            # epoch times [s]
    tight_err: np.ndarray    # (n, 3) ENU antenna error of the tight filter [m]
    loose_err: np.ndarray    # (n, 3) of the loosely coupled InsEkf
    n_dd: np.ndarray
    fixed: np.ndarray
    window: tuple
    stats: dict
    ms_per_epoch: float      # tight filter: satellite states + DDs + update + fixing


def sky(kind, window, seed):
    t0, t1 = window
    if kind == "three_sat":
        masks = [SkyMask(t0, t1, keep=3)]
    else:
        masks = [SkyMask(t0 - 2.0, t0, keep=0), SkyMask(t0, t1, az_deg=(180.0, 360.0), max_el_deg=45.0)]
    return RawSimConfig(seed=seed, masks=masks, slip_flagged=0.5)     # half the slips pass without LLI


def _enu_cov(cov_ecef, axes):
    return axes @ cov_ecef @ axes.T


def float_fixes(raw, nav, start, window):
    """(arrival, GnssSample) of a receiver in RTK float from `start`: kinematic float DD filter + Doppler velocity."""
    filt, out = None, []
    for e in raw.epochs:
        if not start <= e.t < window[1]:
            continue
        cache = {}
        guess = raw.base_pos if filt is None else filt.position
        sv_b = satellite_states(e.base, nav, raw.base_pos, cache)
        sv_r = satellite_states(e.rover, nav, guess, cache)
        dd = form_double_differences(e.rover, e.base, sv_r, sv_b, raw.base_pos)
        if dd is None or len(dd) < 3:
            continue
        filt = filt or BaselineFilter(raw.base_pos, BaselineConfig(fix=False), guess)
        sol = filt.update(dd, e.rover.time)
        vel = doppler_velocity(e.rover, sv_r, sol.float_pos)
        lat, lon, h = ecef_to_llh(sol.float_pos)
        v_enu = None if vel is None else raw.enu_axes @ vel.vel
        v_cov = None if vel is None else _enu_cov(vel.cov, raw.enu_axes)
        out.append((e.t + LATENCY, GnssSample(e.t, lat, lon, h, _enu_cov(sol.float_cov, raw.enu_axes), v_enu, v_cov,
                                              FIX_FLOAT)))
    return out


def coupled_settings(run, mounts):
    """InsEkfSettings of the simulated runs (mounts of sim_streams; initial heading from the truth's start)."""
    return InsEkfSettings(lever_gnss_frd=tuple(mounts.lever_gnss_frd), lever_base_frd=tuple(-mounts.lever_imu_frd),
                          initial_heading=wrap_angle(math.pi / 2 - run.truth.yaw[0] + math.pi))


def run_coupled(run, nav, kind="three_sat", window=(120.0, 180.0), handover=60.0, seed=0, streams=None, config=None):
    """CoupledRun of a SimRun (mems_field-style) with the sky of `kind` (see module docstring); config: the tight
    filter's TightConfig (default: TightConfig())."""
    from agnav_sim_eval.bench.ins import sim_streams
    raw = simulate_run_raw(run, nav, sky(kind, window, seed))
    gyro, accel, gnss, mounts = streams or sim_streams(run)
    blocked = (window[0] - 2.0 if kind == "float" else window[0], window[1])
    fixes = [g for g in gnss if not blocked[0] <= g[1].t < blocked[1]]
    if kind == "float":
        fixes = sorted(fixes + float_fixes(raw, nav, window[0], window), key=lambda g: g[0])
    ekf, tight = InsEkf(coupled_settings(run, mounts)), None
    epochs = {round(e.t * 100): e for e in raw.epochs}
    rows, gi, spent = [], 0, 0.0
    for i, t in enumerate(run.imu.t):
        while gi < len(fixes) and fixes[gi][0] <= t:
            ekf.add_gnss(fixes[gi][1])
            gi += 1
        ekf.add_imu(t, gyro[i], accel[i])
        if tight is None:
            if t >= handover:
                tight = TightFilter.from_ins(ekf, raw.base_pos, config or TightConfig())
            continue
        tight.add_imu(t, gyro[i], accel[i])
        e = epochs.get(round(t * 100))
        if e is None:
            continue
        tight.c.fix = not (kind == "float" and blocked[0] <= t < window[1])
        start = time.perf_counter()
        sol = tight.add_epoch(e.rover, e.base, nav)
        spent += time.perf_counter() - start
        loose = antenna_state(ekf.mech, tight.lever, ekf.omega_b)[0]
        tight_pos = tight.antenna()[0]
        rows.append((t, raw.to_enu(tight_pos) - raw.to_enu(e.antenna), raw.to_enu(loose) - raw.to_enu(e.antenna),
                     0 if sol is None else sol.n_dd, bool(sol is not None and sol.fixed)))
    cols = list(zip(*rows))
    return CoupledRun(np.array(cols[0]), np.array(cols[1]), np.array(cols[2]), np.array(cols[3]),
                      np.array(cols[4]), window, dict(tight.stats), spent / max(len(rows), 1) * 1e3)


def window_errors(res):
    """Horizontal errors [m] inside the window: (times, tight, loose)."""
    sel = (res.t >= res.window[0]) & (res.t < res.window[1])
    return (res.t[sel], np.linalg.norm(res.tight_err[sel, :2], axis=1),
            np.linalg.norm(res.loose_err[sel, :2], axis=1))
