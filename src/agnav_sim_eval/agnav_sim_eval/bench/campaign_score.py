"""Scoring of one campaign run (helpers of `agnav bench campaign`, no command of its own): the recorded
/odometry/filtered against the input bag's truth, against the run's receiver floor, and against its own covariance."""
import math

import numpy as np

from agnav_common.frames import rotation_matrix
from agnav_common.geodesy import LocalTangentPlane
from agnav_sim_eval.evaluate import error_series, evaluate_arrays, evaluate_bags, odometry_arrays, read_bag

OUTAGE_PERIODS, OUTAGE_MIN_S = 5.0, 2.0  # a pause of the fixes longer than both is an outage
RECOVERY_S = 10.0  # s after the fixes return: the outage's error must be gone (issue 15: back within 10 cm)
RECOVERY_CM = 10.0  # ... or back to the receiver's own error there, where that is worse (a perfect filter's floor)
AXES = {"x": 0, "y": 7, "roll": 21, "pitch": 28, "yaw": 35}  # Odometry pose covariance diagonal
SERIES_KEY = {"x": ("east", 0.01), "y": ("north", 0.01), "roll": ("roll", math.pi / 180), "pitch": ("pitch", math.pi / 180),
              "yaw": ("yaw", math.pi / 180)}  # error_series key and its unit in m / rad


def receiver_floor(bag, lever):
    """Horizontal error (m) of every fix moved to base_link with the TRUE attitude and the /tf_static lever arm:
    what a perfect filter fed those fixes reaches. -> (rms, max, n, fix stamps, per-fix errors)."""
    data = read_bag(bag, ["/gnss/fix", "/ground_truth/odometry", "/map_datum"])
    truth = odometry_arrays(data["/ground_truth/odometry"])
    datum = data["/map_datum"][-1][1]
    plane = LocalTangentPlane(datum.latitude, datum.longitude, datum.altitude)
    fixes = [(t, m) for t, m in data["/gnss/fix"] if truth["t"][0] <= t <= truth["t"][-1]]
    if not fixes:
        return None, None, 0, np.zeros(0), np.zeros(0)
    t = np.array([f[0] for f in fixes])
    e, n, u = plane.to_enu(*np.array([(m.latitude, m.longitude, m.altitude) for _, m in fixes]).T)
    at = {k: np.interp(t, truth["t"], np.unwrap(truth[k]) if k in ("roll", "pitch", "yaw") else truth[k])
          for k in ("x", "y", "roll", "pitch", "yaw")}
    arm = np.array([rotation_matrix(r, p, y) @ lever for r, p, y in zip(at["roll"], at["pitch"], at["yaw"])])
    err = np.hypot(np.asarray(e) - arm[:, 0] - at["x"], np.asarray(n) - arm[:, 1] - at["y"])
    return float(np.sqrt(np.mean(err ** 2))), float(err.max()), int(err.size), t, err


def outages(fix_t, start, end):
    """[(first s without fixes, s the fixes return)] where the fixes pause for more than OUTAGE_PERIODS median
    intervals (and OUTAGE_MIN_S), including a pause at the end of the run."""
    if fix_t.size < 2:
        return []
    gap = max(OUTAGE_MIN_S, OUTAGE_PERIODS * float(np.median(np.diff(fix_t))))
    edges = np.concatenate([fix_t, [end]])
    return [(float(a), float(b)) for a, b in zip(edges[:-1], edges[1:]) if b - a > gap and a >= start]


def outage_rows(series, truth, windows, fixes):
    """Per outage: duration, distance travelled (truth), its drift (the largest horizontal move of the error away
    from the error when the fixes stopped, m: the receiver's own error then is not the outage's) and the largest
    error inside it (m), the drift as a share of the distance, the error RECOVERY_S after the fixes return (cm; None when the run ends first), the
    receiver's own error then (RMS of the fixes' floor errors within 2 s, cm) and their ratio to the bound:
    after / max(RECOVERY_CM, that). fixes: (stamps, floor errors m) of receiver_floor."""
    t, east, north = series["t"], series["east"] / 100, series["north"] / 100
    h = np.hypot(east, north)
    path = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(truth["x"]), np.diff(truth["y"])))])
    rows = []
    for a, b in windows:
        inside = (t >= a) & (t <= b)
        if not inside.any():
            continue
        travelled = float(np.interp(b, truth["t"], path) - np.interp(a, truth["t"], path))
        after = np.abs(t - (b + RECOVERY_S)) <= 0.5
        near = np.abs(fixes[0] - (b + RECOVERY_S)) <= 2.0
        k = int(np.argmax(inside))  # the first sample inside
        drift = float(np.hypot(east[inside] - east[k], north[inside] - north[k]).max())
        row = {"duration_s": b - a, "travelled_m": travelled, "drift_m": drift, "max_error_m": float(h[inside].max()),
               "drift_share": drift / max(travelled, 1.0),
               "after_cm": float(np.median(h[after])) * 100 if after.any() else None,
               "after_floor_cm": float(np.sqrt(np.mean(fixes[1][near] ** 2))) * 100 if near.any() else None}
        if row["after_cm"] is not None:
            row["after_over_bound"] = row["after_cm"] / max(RECOVERY_CM, row["after_floor_cm"] or 0.0)
        rows.append(row)
    return rows


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
    floor_rms, floor_max, fixes, fix_t, fix_err = receiver_floor(truth_bag, np.asarray(lever, float))
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
    # the floor exists while fixes arrive: outages and the RECOVERY_S after them are scored on their own
    series = error_series(est, truth)
    windows = outages(fix_t, float(est["t"][0]), float(truth["t"][-1]))
    served = np.ones(series["t"].size, bool)
    for a, b in windows:
        served &= (series["t"] < a) | (series["t"] > b + RECOVERY_S)
    h = np.hypot(series["east"], series["north"])[served]
    row["outages"] = outage_rows(series, truth, windows, (fix_t, fix_err))
    if row["outages"]:
        row["outage_drift_share"] = max(o["drift_share"] for o in row["outages"])
        for key, out in (("after_cm", "outage_after_cm"), ("after_over_bound", "outage_after_over_bound")):
            values = [o[key] for o in row["outages"] if o.get(key) is not None]
            row[out] = max(values) if values else None
    if floor_rms and h.size:
        row["horizontal_rms_fixes_cm"] = float(np.sqrt(np.mean(h ** 2)))
        row["horizontal_rms_over_floor"] = row["horizontal_rms_fixes_cm"] / row["floor_rms_cm"]
        row["max_over_floor_max"] = float(h.max()) / row["floor_max_cm"]
    shares = within_3sigma(est, truth)
    row["within_3sigma_axes"] = shares
    row["within_3sigma"] = min(shares.values()) if shares else None
    return row
