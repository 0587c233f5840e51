"""What no filter can know in a campaign run: body-fixed errors that a route without turns does not separate.

- Roll: a MEMS accelerometer's bias across the vehicle tilts its gravity reference as a roll does (b_y / g rad);
  both are fixed in the body, so nothing on a straight tells them apart (the pitch twin is observed while driving:
  the GNSS climb and the non-holonomic constraint). A turn does (a roll error tips the centripetal specific force
  into the vertical, a bias does not), and so does a two-way level calibration (park, turn round, park).
- Heading: on a cross slope the course over ground is the heading plus the crab (side slip); on a straight only the
  crab model's prior tells them apart (a U-turn flips the crab against the gyro's heading change).
"""
import math

import numpy as np

GRAVITY = 9.80665


def run_limits(sim, params):
    """The unobservable quantities of one simulated run: route with turns or not, the accelerometer bias's roll
    equivalent (deg, MEMS runs), the steady crab on its cross slope (deg)."""
    out = {"turns": not params["route"].startswith("straight"),
           "crab_deg": math.degrees(params["crab_gain"] * math.radians(params.get("slope_deg", 0.0)))}
    if sim.accel is not None:
        bias = sim.mounts["imu_link"].rot @ sim.accel.bias  # base_link FLU
        out["accel_roll_deg"] = math.degrees(bias[1] / GRAVITY)
    return out


def _explained(rows, key, bound, cause):
    over = [r for r in rows if r.get(key) is not None and r[key] > bound]
    alone = [r for r in over if cause(r.get("limits") or {})]
    rest = [r[key] for r in rows if r.get(key) is not None and r not in alone]
    return len(over), len(alone), (float(np.percentile(rest, 95)) if rest else None)


def markdown_lines(rows):
    """Observability lines for campaign.md: how many runs over the roll and heading bounds an unobservable error
    alone puts there, and the p95 of the others."""
    lines = []
    n, k, p95 = _explained(rows, "roll_rms_deg", 0.3,
                           lambda lim: not lim.get("turns", True) and abs(lim.get("accel_roll_deg", 0.0)) > 0.3)
    lines.append(f"- roll: {n} runs over 0.3°; in {k} of them (MEMS IMU, no turn) the accelerometer's bias across the "
                 "vehicle alone tilts the gravity reference by more than 0.3°"
                 + (f"; the other runs' p95 is {p95:.3f}°." if p95 is not None else "."))
    for receiver, bound in (("DGPS", 0.5), ("RTK", 0.2)):
        n, k, p95 = _explained(rows, f"heading_rms_deg_{receiver}", bound,
                               lambda lim, b=bound: not lim.get("turns", True) and abs(lim.get("crab_deg", 0.0)) > b)
        lines.append(f"- heading ({receiver}): {n} runs over {bound}°; {k} of them drive a cross slope without a turn "
                     f"with a crab above {bound}°"
                     + (f"; the other runs' p95 is {p95:.3f}°." if p95 is not None else "."))
    return lines
