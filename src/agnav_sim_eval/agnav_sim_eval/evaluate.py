"""`agnav eval OUTPUT_BAG --truth INPUT_BAG [--json] [--plots DIR]`: score /odometry/filtered (and /imu/data
attitude) against /ground_truth/odometry; RMS and max of roll, pitch, yaw, horizontal and cross-track error.

Truth is interpolated at the output's stamps (overlap only). Positions are compared in the output's `map` frame:
when the bags' /map_datum differ, truth is moved through geodetic coordinates into the output datum.
Cross-track error = lateral component of the position error, perpendicular to the true heading (+ = left).
"""
import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from agnav_common.mcap_recording import unfinished
from agnav_common.frames import euler_from_quaternion, wrap_angle
from agnav_common.geodesy import LocalTangentPlane

DEG = 180.0 / math.pi
KEYS = ("roll_deg", "pitch_deg", "yaw_deg", "horizontal_cm", "cross_track_cm")


def _stats(err):
    err = np.abs(np.asarray(err, dtype=float))
    if err.size == 0:
        return {"rms": None, "max": None}
    return {"rms": float(np.sqrt(np.mean(err ** 2))), "max": float(err.max())}


def _interp_angle(t, tq, a):
    return wrap_angle(np.interp(tq, t, np.unwrap(a)))


def error_series(est, truth, skip_s=0.0):
    """Per-sample errors at the estimate's stamps inside the truth's span (after `skip_s` seconds):
    t, roll/pitch/yaw (deg) and east/north/cross-track (cm) for the quantities both sides have."""
    t_true, t = np.asarray(truth["t"], dtype=float), np.asarray(est["t"], dtype=float)
    keep = (t >= t_true[0] + skip_s) & (t <= t_true[-1])
    tq = t[keep]
    series = {"t": tq}
    for key in ("roll", "pitch", "yaw"):
        if key in est and key in truth:
            series[key] = wrap_angle(np.asarray(est[key])[keep] - _interp_angle(t_true, tq, truth[key])) * DEG
    if "x" in est and "x" in truth:
        dx = np.asarray(est["x"])[keep] - np.interp(tq, t_true, truth["x"])
        dy = np.asarray(est["y"])[keep] - np.interp(tq, t_true, truth["y"])
        yaw = _interp_angle(t_true, tq, truth["yaw"])
        series.update(east=dx * 100, north=dy * 100, cross_track=(-np.sin(yaw) * dx + np.cos(yaw) * dy) * 100)
    return series


def evaluate_arrays(est, truth, skip_s=0.0):
    """Error statistics of an estimate against truth; both dicts of arrays with key t (s) and any of
    x, y (m, same map frame), roll, pitch, yaw (rad). Truth needs t, yaw and the keys being scored.

    Returns {roll_deg, pitch_deg, yaw_deg, horizontal_cm, cross_track_cm: {rms, max}, samples, duration_s};
    quantities the estimate lacks get {rms: None, max: None}. skip_s drops the first seconds (convergence).
    """
    series = error_series(est, truth, skip_s)
    out = {k: {"rms": None, "max": None} for k in KEYS}
    for key in ("roll", "pitch", "yaw"):
        if key in series:
            out[f"{key}_deg"] = _stats(np.atleast_1d(series[key]))
    if "east" in series:
        out["horizontal_cm"] = _stats(np.hypot(series["east"], series["north"]))
        out["cross_track_cm"] = _stats(series["cross_track"])
    tq = series["t"]
    out["samples"] = int(tq.size)
    out["duration_s"] = float(tq[-1] - tq[0]) if tq.size else 0.0
    return out


def read_bag(path, topics):
    """{topic: [(stamp s, msg)]} for the wanted topics of a rosbag2/ROS 1 bag (header stamps)."""
    from rosbags.highlevel import AnyReader

    from agnav_common.bagio import typestore
    found = {topic: [] for topic in topics}
    with AnyReader([Path(path)], default_typestore=typestore()) as reader:
        conns = [c for c in reader.connections if c.topic in found]
        for conn, _, raw in reader.messages(connections=conns):
            msg = reader.deserialize(raw, conn.msgtype)
            found[conn.topic].append((msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, msg))
    return found


def odometry_arrays(samples):
    """Arrays t, x, y, z, roll, pitch, yaw from [(stamp, nav_msgs/Odometry)]."""
    rows = []
    for t, m in samples:
        p, q = m.pose.pose.position, m.pose.pose.orientation
        rows.append((t, p.x, p.y, p.z, *euler_from_quaternion(q.x, q.y, q.z, q.w)))
    a = np.array(rows, dtype=float).reshape(-1, 7)
    order = np.argsort(a[:, 0], kind="stable")
    return dict(zip(("t", "x", "y", "z", "roll", "pitch", "yaw"), a[order].T))


UNKNOWN_VARIANCE = 1e4  # rad^2: a yaw published with this variance or more is relative / unknown (REP-145 style)


def imu_attitude_arrays(samples):
    """Arrays t, roll, pitch (and yaw unless every sample marks it unknown) from [(stamp, sensor_msgs/Imu)]
    with a valid orientation."""
    valid = [(t, m) for t, m in samples
             if m.orientation_covariance[0] >= 0 and m.orientation.w ** 2 + m.orientation.z ** 2 > 0]
    rows = [(t, *euler_from_quaternion(m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w))
            for t, m in valid]
    a = np.array(rows, dtype=float).reshape(-1, 4)
    arrays = dict(zip(("t", "roll", "pitch", "yaw"), a[np.argsort(a[:, 0], kind="stable")].T))
    if valid and all(m.orientation_covariance[8] >= UNKNOWN_VARIANCE for _, m in valid):
        del arrays["yaw"]
    return arrays


def _datum(samples):
    if not samples:
        return None
    m = samples[-1][1]
    return (m.latitude, m.longitude, m.altitude)


def move_datum(truth, truth_datum, out_datum):
    """Truth x, y, z re-expressed in the ENU plane of out_datum (through geodetic coordinates)."""
    if truth_datum is None or out_datum is None or np.allclose(truth_datum, out_datum, rtol=0, atol=1e-9):
        return truth
    lat, lon, alt = LocalTangentPlane(*truth_datum).to_geodetic(truth["x"], truth["y"], truth["z"])
    x, y, z = LocalTangentPlane(*out_datum).to_enu(lat, lon, alt)
    return dict(truth, x=x, y=y, z=z)


def evaluate_bags(output_bag, truth_bag, skip_s=0.0):
    """(metrics, est, truth, imu): metrics of evaluate_arrays for /odometry/filtered plus `imu_data` for /imu/data."""
    out = read_bag(output_bag, ["/odometry/filtered", "/imu/data", "/map_datum"])
    ref = read_bag(truth_bag, ["/ground_truth/odometry", "/map_datum"])
    if not ref["/ground_truth/odometry"]:
        raise ValueError(f"{truth_bag} has no /ground_truth/odometry")
    if not out["/odometry/filtered"] and not out["/imu/data"]:
        raise ValueError(f"{output_bag} has neither /odometry/filtered nor /imu/data")
    truth_datum = _datum(ref["/map_datum"])
    out_datum = _datum(out["/map_datum"]) or truth_datum
    truth = move_datum(odometry_arrays(ref["/ground_truth/odometry"]), truth_datum, out_datum)
    est = odometry_arrays(out["/odometry/filtered"]) if out["/odometry/filtered"] else None
    metrics = evaluate_arrays(est, truth, skip_s) if est is not None else {k: {"rms": None, "max": None} for k in KEYS}
    imu = imu_attitude_arrays(out["/imu/data"]) if out["/imu/data"] else None
    if imu is not None and imu["t"].size:
        m = evaluate_arrays(imu, truth, skip_s)
        metrics["imu_data"] = {k: m[k] for k in ("roll_deg", "pitch_deg", "yaw_deg")}
    metrics["datum"] = {"output": out_datum, "truth": truth_datum,
                        "output_has_map_datum": bool(out["/map_datum"])}
    return metrics, est, truth, imu


def _fmt(v):
    return "    -" if v is None else f"{v:8.3f}"


def table(metrics):
    """Human-readable table of the metrics."""
    lines = [f"{'quantity':18s} {'rms':>8s} {'max':>8s}"]
    for key in KEYS:
        lines.append(f"{key:18s} {_fmt(metrics[key]['rms'])} {_fmt(metrics[key]['max'])}")
    for key, val in metrics.get("imu_data", {}).items():
        lines.append(f"{'imu/data ' + key:18s} {_fmt(val['rms'])} {_fmt(val['max'])}")
    return "\n".join(lines)


def plot(est, truth, imu, out_dir):
    """Write track.png and errors.png (matplotlib Agg); returns the paths."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(7, 6))
    ax.plot(truth["x"], truth["y"], "k-", lw=1, label="ground truth")
    if est is not None:
        ax.plot(est["x"], est["y"], "r-", lw=0.8, label="/odometry/filtered")
    ax.set(xlabel="east (m)", ylabel="north (m)", title="track in map", aspect="equal")
    ax.legend()
    fig.savefig(out_dir / "track.png", dpi=100)
    plt.close(fig)
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    t0 = truth["t"][0]
    for source, style in ((est, "-"), (imu, ":")):
        if source is None:
            continue
        s = error_series(source, truth)
        for key in (k for k in ("roll", "pitch", "yaw") if k in s):
            a1.plot(s["t"] - t0, s[key], style, lw=0.8, label=key + (" (imu/data)" if source is imu else ""))
        if "east" in s and source is est:
            for key in ("east", "north", "cross_track"):
                a2.plot(s["t"] - t0, s[key], lw=0.8, label=key)
    a1.set(ylabel="attitude error (deg)")
    a2.set(ylabel="position error (cm)", xlabel="time (s)")
    a1.legend(fontsize=8)
    a2.legend(fontsize=8)
    fig.savefig(out_dir / "errors.png", dpi=100)
    plt.close(fig)
    return [out_dir / "track.png", out_dir / "errors.png"]


def main(argv=None):
    parser = argparse.ArgumentParser(prog="agnav eval", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("output_bag", help="bag with /odometry/filtered (and /imu/data, /map_datum)")
    parser.add_argument("--truth", required=True, help="bag with /ground_truth/odometry and /map_datum")
    parser.add_argument("--skip", type=float, default=0.0, help="ignore the first SKIP seconds of truth")
    parser.add_argument("--plots", help="directory for track.png and errors.png")
    parser.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    args = parser.parse_args(argv)
    for path in (args.output_bag, args.truth):
        if unfinished(path):
            print(f"agnav eval: {path} is an unfinished recording (its writer was killed): run `agnav recover "
                  f"{path}` first", file=sys.stderr)
            return 1
    try:
        metrics, est, truth, imu = evaluate_bags(args.output_bag, args.truth, args.skip)
    except (ValueError, FileNotFoundError) as exc:
        print(f"agnav eval: {exc}", file=sys.stderr)
        return 1
    print(table(metrics))
    if not metrics["datum"]["output_has_map_datum"]:
        print("note: output bag has no /map_datum; assumed the truth bag's datum")
    if args.plots:
        for p in plot(est, truth, imu, args.plots):
            print(f"plot: {p}")
    if args.json:
        print(json.dumps(metrics))
    return 0
