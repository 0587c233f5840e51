"""Scoring of one campaign run (helpers of `agnav bench campaign`, no command of its own): the recorded
/odometry/filtered against the input bag's truth, against the run's receiver floor, and against its own covariance."""
import math
from pathlib import Path

import numpy as np
from rosbags.highlevel import AnyReader

from agnav_common.bagio import typestore
from agnav_common.frames import euler_from_quaternion, rotation_matrix
from agnav_common.geodesy import LocalTangentPlane
from agnav_sim_eval.evaluate import error_series, evaluate_arrays, evaluate_bags, odometry_arrays, read_bag

AXES = {"x": 0, "y": 7, "roll": 21, "pitch": 28, "yaw": 35}  # Odometry pose covariance diagonal
SERIES_KEY = {"x": ("east", 0.01), "y": ("north", 0.01), "roll": ("roll", math.pi / 180), "pitch": ("pitch", math.pi / 180),
              "yaw": ("yaw", math.pi / 180)}  # error_series key and its unit in m / rad


def static_transforms(bag):
    """[{parent, child, xyz, rpy}] of the bag's /tf_static (the mounts the graph is given)."""
    out = []
    with AnyReader([Path(bag)], default_typestore=typestore()) as reader:
        conns = [c for c in reader.connections if c.topic == "/tf_static"]
        for conn, _, raw in reader.messages(connections=conns):
            for t in reader.deserialize(raw, conn.msgtype).transforms:
                tr, q = t.transform.translation, t.transform.rotation
                out.append({"parent": t.header.frame_id, "child": t.child_frame_id, "xyz": [tr.x, tr.y, tr.z],
                            "rpy": [float(a) for a in euler_from_quaternion(q.x, q.y, q.z, q.w)]})
    return out


def receiver_floor(bag, lever):
    """Horizontal error (m) of every fix moved to base_link with the TRUE attitude and the /tf_static lever arm:
    what a perfect filter fed those fixes reaches. -> (rms, max, n)."""
    data = read_bag(bag, ["/gnss/fix", "/ground_truth/odometry", "/map_datum"])
    truth = odometry_arrays(data["/ground_truth/odometry"])
    datum = data["/map_datum"][-1][1]
    plane = LocalTangentPlane(datum.latitude, datum.longitude, datum.altitude)
    fixes = [(t, m) for t, m in data["/gnss/fix"] if truth["t"][0] <= t <= truth["t"][-1]]
    if not fixes:
        return None, None, 0
    t = np.array([f[0] for f in fixes])
    e, n, u = plane.to_enu(*np.array([(m.latitude, m.longitude, m.altitude) for _, m in fixes]).T)
    at = {k: np.interp(t, truth["t"], np.unwrap(truth[k]) if k in ("roll", "pitch", "yaw") else truth[k])
          for k in ("x", "y", "roll", "pitch", "yaw")}
    arm = np.array([rotation_matrix(r, p, y) @ lever for r, p, y in zip(at["roll"], at["pitch"], at["yaw"])])
    err = np.hypot(np.asarray(e) - arm[:, 0] - at["x"], np.asarray(n) - arm[:, 1] - at["y"])
    return float(np.sqrt(np.mean(err ** 2))), float(err.max()), int(err.size)


def _odometry_with_covariance(out_bag):
    """Arrays of odometry_arrays plus the pose covariance diagonal (AXES), sorted the same way; NaN sample count."""
    samples = read_bag(out_bag, ["/odometry/filtered"])["/odometry/filtered"]
    est = odometry_arrays(samples)
    cov = np.array([[m.pose.covariance[i] for i in AXES.values()] for _, m in samples], float).reshape(-1, len(AXES))
    cov = cov[np.argsort([t for t, _ in samples], kind="stable")]
    for k, name in enumerate(AXES):
        est["var_" + name] = cov[:, k]
    values = np.column_stack([est[k] for k in est])
    finite = np.all(np.isfinite(values), axis=1)
    return {k: v[finite] for k, v in est.items()}, int((~finite).sum())


def within_3sigma(est, truth):
    """Share of samples per axis whose error is within 3 reported σ (NEES-style, one axis at a time)."""
    series = error_series(est, truth)
    keep = (est["t"] >= truth["t"][0]) & (est["t"] <= truth["t"][-1])
    shares = {}
    for name, (key, unit) in SERIES_KEY.items():
        if key in series and series[key].size:
            sigma = np.sqrt(np.maximum(est["var_" + name][keep], 0.0))
            shares[name] = float(np.mean(np.abs(series[key] * unit) <= 3 * sigma))
    return shares


def score_run(out_bag, truth_bag, lever):
    """Metrics of one run: horizontal RMS/max (cm) and their ratios to the receiver floor, roll/pitch/heading RMS
    (deg), share of samples within 3σ (worst axis and per axis), NaN samples, output count and start delay."""
    est, nans = _odometry_with_covariance(out_bag)
    floor_rms, floor_max, fixes = receiver_floor(truth_bag, np.asarray(lever, float))
    row = {"nan_samples": nans, "samples": int(est["t"].size), "fixes": fixes,
           "floor_rms_cm": None if floor_rms is None else floor_rms * 100,
           "floor_max_cm": None if floor_max is None else floor_max * 100}
    if not est["t"].size:  # the graph never published a finite pose
        return row
    _, _, truth, _ = evaluate_bags(out_bag, truth_bag)  # truth moved into the output's map datum
    m = evaluate_arrays(est, truth)
    row.update(horizontal_rms_cm=m["horizontal_cm"]["rms"], horizontal_max_cm=m["horizontal_cm"]["max"],
               roll_rms_deg=m["roll_deg"]["rms"], pitch_rms_deg=m["pitch_deg"]["rms"],
               heading_rms_deg=m["yaw_deg"]["rms"], first_output_s=float(est["t"][0] - truth["t"][0]))
    if floor_rms:
        row["horizontal_rms_over_floor"] = row["horizontal_rms_cm"] / row["floor_rms_cm"]
        row["max_over_floor_max"] = row["horizontal_max_cm"] / row["floor_max_cm"]
    shares = within_3sigma(est, truth)
    row["within_3sigma_axes"] = shares
    row["within_3sigma"] = min(shares.values()) if shares else None
    return row
