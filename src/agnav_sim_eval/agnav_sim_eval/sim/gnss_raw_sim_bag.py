"""A simulated switching run with raw GNSS as a rosbag2 (issue 18): what `agnav run ins_tight` replays.

The mems_field run (seed N: consumer MEMS IMU at 100 Hz, RTK 5 Hz receiver, 2 m/s passes with U-turns, ground truth)
plus the simulated rover and base observations of gnss_raw_sim (orbits of base.nav, 1 km baseline, half the random
cycle slips without LLI) on the drivers' topics: /gnss/raw_observations and /gnss/base/observations
(agnav_msgs/GnssObservations, u-blox numbering, lock times that fall at a flagged slip), /gnss/base/position
(PointStamped ECEF, latched), /gnss/nav_data (the ephemerides as LNAV / I/NAV frames, gnss_raw_sim_nav, repeated
every NAV_PERIOD s as a receiver decodes them again). Base and
rover epochs are logged at their epoch (base first). Sky and receiver per window (`windows`, back to back):
  fixed      – RTK fixed fixes (the simulator's) until `start`, and again after `refloat`;
  float      – every satellite hidden for 2 s before it (all lose lock), then a tree line hides the west half of the
               sky below 45°; the receiver is in RTK float (/gnss/status RTK_FLOAT): its fixes are the simulator's
               plus a float solution's slowly wandering error (first-order Gauss-Markov, FLOAT_SIGMA per axis
               horizontally, twice that vertically, FLOAT_TAU, a fresh draw at each window) with that covariance;
  three_sat  – only the 3 highest GPS satellites above 15°: no receiver fix;
  outage     – no satellite, no fix;
  refloat    – the sky back, the receiver float again (a fresh float error).
"""
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
from agnav_common.bagio import typestore
from agnav_common.geodesy import LocalTangentPlane
from agnav_common.qos import LATCHED_QOS, bag_profiles
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode, StoragePlugin

from agnav_fusion.gnss_raw.rinex import read_nav

from .gnss_raw_sim import RawSimConfig, SkyMask, antenna_truth, enu_frame, simulate_raw
from .gnss_raw_sim_nav import UBX_GNSS, nav_frames
from .messages import MESSAGE_TYPES, START_EPOCH_S
from .run import simulate

NAV = Path("/work/shared/data/real/gnss_raw/matrtklib_static/base.nav")
RAW_TYPES = {"/gnss/raw_observations": "agnav_msgs/msg/GnssObservations",
             "/gnss/base/observations": "agnav_msgs/msg/GnssObservations",
             "/gnss/base/position": "geometry_msgs/msg/PointStamped", "/gnss/nav_data": "agnav_msgs/msg/GnssNavData"}
RECEIVER = ("/gnss/fix", "/gnss/vel", "/gnss/status")
FIX_RTK_FLOAT = 3          # agnav_msgs/GnssStatus
BLOCKAGE_S = 2.0
FLOAT_SIGMA = 0.3          # m, horizontal per axis, of the receiver's RTK float error
FLOAT_TAU = 30.0           # s, its correlation time
NAV_PERIOD = 30.0          # s between repeats of the navigation frames (a GPS LNAV frame lasts 30 s)


def windows(start=60.0, float_s=60.0, three_sat_s=60.0, outage_s=15.0, refloat_s=15.0):
    """{window: (t0, t1)} (simulation s) back to back from `start`."""
    out, t = {}, start
    for name, length in (("float", float_s), ("three_sat", three_sat_s), ("outage", outage_s),
                         ("refloat", refloat_s)):
        out[name], t = (t, t + length), t + length
    return out


def receiver_state(t, w):
    """fixed | float | none: the receiver at simulation time t."""
    if w["float"][0] - BLOCKAGE_S <= t < w["float"][0] or w["three_sat"][0] <= t < w["outage"][1]:
        return "none"
    return "float" if any(w[k][0] <= t < w[k][1] for k in ("float", "refloat")) else "fixed"


def sky(w, seed):
    f0, f1 = w["float"]
    masks = [SkyMask(f0 - BLOCKAGE_S, f0, keep=0), SkyMask(f0, f1, az_deg=(180.0, 360.0), max_el_deg=45.0),
             SkyMask(*w["three_sat"], keep=3), SkyMask(*w["outage"], keep=0)]
    return RawSimConfig(seed=seed, masks=masks, slip_flagged=0.5)


def _seconds(header):
    return header.stamp.sec + header.stamp.nanosec * 1e-9 - START_EPOCH_S


class _Messages:
    """rosbags messages of the raw topics (stamps START_EPOCH_S + simulation time)."""

    def __init__(self, types):
        self.T = types
        self.lock_start = {"rover": {}, "base": {}}

    def header(self, t, frame):
        ns = int(round((START_EPOCH_S + t) * 1e9))
        stamp = self.T["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
        return self.T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)

    def observations(self, t, epoch, receiver):
        """GnssObservations of a one-frequency ObsEpoch (L1 C/A, E1: u-blox sigId 0)."""
        starts, obs = self.lock_start[receiver], []
        for i, sid in enumerate(epoch.sats):
            if epoch.lli[i, 0] or sid not in starts:
                starts[sid] = t
            obs.append(self.T["agnav_msgs/msg/GnssObservation"](
                gnss_id=UBX_GNSS[sid[0]], sv_id=int(sid[1:]), sig_id=0, freq_id=0,
                pseudorange=float(epoch.code[i, 0]), carrier_phase=float(epoch.phase[i, 0]),
                doppler=float(epoch.doppler[i, 0]), cno=float(epoch.snr[i, 0]), lock_time=float(t - starts[sid]),
                pseudorange_std=0.3, carrier_phase_std=0.01, doppler_std=0.1, pseudorange_valid=True,
                carrier_phase_valid=True, half_cycle_resolved=True, half_cycle_subtracted=False))
        for sid in set(starts) - set(epoch.sats):
            del starts[sid]
        return self.T["agnav_msgs/msg/GnssObservations"](
            header=self.header(t, "gnss_link" if receiver == "rover" else "gnss_base"), receiver_tow=epoch.tow,
            week=epoch.week, leap_seconds=18, leap_seconds_known=True, clock_reset=False, observations=obs)

    def nav_data(self, t, frame):
        gnss_id, sv_id, sig_id, words = frame
        return self.T["agnav_msgs/msg/GnssNavData"](header=self.header(t, "gnss_link"), gnss_id=gnss_id,
                                                    sv_id=sv_id, sig_id=sig_id, freq_id=0,
                                                    words=np.array(words, dtype=np.uint32))

    def base_position(self, xyz):
        point = self.T["geometry_msgs/msg/Point"](x=float(xyz[0]), y=float(xyz[1]), z=float(xyz[2]))
        return self.T["geometry_msgs/msg/PointStamped"](header=self.header(0.0, "ecef"), point=point)


class _FloatReceiver:
    """Receiver messages of an RTK float solution: the simulator's fix moved by a Gauss-Markov error (ENU m)."""

    def __init__(self, datum, rng):
        self.plane, self.rng = LocalTangentPlane(*datum), rng
        self.sigma = np.array([FLOAT_SIGMA, FLOAT_SIGMA, 2.0 * FLOAT_SIGMA])
        self.err, self.t = None, None

    def fix(self, msg, t):
        if self.err is None or t - self.t > 1.0:          # a new float window: a fresh solution
            self.err = self.rng.normal(0.0, self.sigma)
        else:
            phi = np.exp(-(t - self.t) / FLOAT_TAU)
            self.err = phi * self.err + np.sqrt(1.0 - phi * phi) * self.rng.normal(0.0, self.sigma)
        self.t = t
        lat, lon, alt = self.plane.to_geodetic(*(np.array(self.plane.to_enu(msg.latitude, msg.longitude,
                                                                             msg.altitude)) + self.err))
        return replace(msg, latitude=float(lat), longitude=float(lon), altitude=float(alt),
                       position_covariance=np.diag(self.sigma ** 2).ravel())


def raw_run_rows(seed=1, w=None, duration=None, nav=None):
    """(typestore, [(log time s, topic, msg)] in log order, RawSim) of the run (see the module docstring)."""
    w = w or windows()
    nav = nav or read_nav(NAV)
    run = simulate("mems_field", seed=seed, messages=True)
    end = duration if duration is not None else run.truth.t[-1]
    t, pos, vel = antenna_truth(run)
    keep = t <= end
    raw = simulate_raw(t[keep], pos[keep], vel[keep], nav, *enu_frame(run.datum), sky(w, seed))
    floating = _FloatReceiver(run.datum, np.random.default_rng(seed))
    rows = []
    for when, topic, msg in run.messages:
        if when > end or topic == "/inclinometer":
            continue
        if topic in RECEIVER:
            state = receiver_state(_seconds(msg.header), w)
            if state == "none":
                continue
            if state == "float" and topic == "/gnss/fix":
                msg = floating.fix(msg, _seconds(msg.header))
            elif state == "float" and topic == "/gnss/status":
                msg = replace(msg, fix_type=FIX_RTK_FLOAT)
        rows.append((when, topic, msg))
    store = typestore()
    m = _Messages(store.types)
    rows += [(0.0, "/gnss/base/position", m.base_position(raw.base_pos))]
    rows += [(t, "/gnss/nav_data", m.nav_data(t, f)) for t in np.arange(0.0, end, NAV_PERIOD)
             for f in nav_frames(nav, RawSimConfig().systems, raw.config.tow0 + t)]
    for e in raw.epochs:
        rows += [(e.t, "/gnss/base/observations", m.observations(e.t, e.base, "base")),
                 (e.t, "/gnss/raw_observations", m.observations(e.t, e.rover, "rover"))]
    rows.sort(key=lambda r: r[0])
    return store, rows, raw


def record_raw_run(out, seed=1, w=None, duration=None, overwrite=True):
    """Write the run's bag at `out` (mcap, zstd); returns {topic: messages}."""
    out = Path(out)
    if out.exists() and overwrite:
        shutil.rmtree(out)
    store, rows, _ = raw_run_rows(seed, w, duration)
    types = {**MESSAGE_TYPES, **RAW_TYPES}
    writer = Writer(out, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    counts, connections = {}, {}
    with writer:
        for when, topic, msg in rows:
            if topic not in connections:
                qos = bag_profiles(topic, [LATCHED_QOS] if topic == "/gnss/base/position" else None)
                connections[topic] = writer.add_connection(topic, types[topic], typestore=store,
                                                           offered_qos_profiles=qos)
            writer.write(connections[topic], int(round((START_EPOCH_S + when) * 1e9)),
                         bytes(store.serialize_cdr(msg, types[topic])))
            counts[topic] = counts.get(topic, 0) + 1
    return counts
