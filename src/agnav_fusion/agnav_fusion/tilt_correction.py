"""GNSS antenna tilt correction with Euler angles (SPEC §5.3, eq 4.18-4.24).

Thesis conventions: ground (X, Y, Z) = (east, north, up); vehicle (x, y, z) = (right, forward, up);
heading phi clockwise from north, pitch theta_p nose up, roll theta_r right side down; radians.
"""
import math

import numpy as np


def f1(roll):
    """Roll matrix F1(theta_r) (4.18)."""
    c, s = math.cos(roll), math.sin(roll)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def f2(pitch):
    """Pitch matrix F2(theta_p) (4.19)."""
    c, s = math.cos(pitch), math.sin(pitch)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])


def f3(heading):
    """Heading matrix F3(phi) (4.20)."""
    c, s = math.cos(heading), math.sin(heading)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def vehicle_to_ground(heading, pitch, roll):
    """E = F3(-phi) F2(-theta_p) F1(-theta_r): vehicle -> ground rotation (4.21)-(4.22), SPEC-corrected."""
    return f3(-heading) @ f2(-pitch) @ f1(-roll)


def antenna_offset(lever, heading, pitch, roll):
    """Ground-frame antenna displacement (dx, dy, dz) = E (a, b, h) (4.23)."""
    return vehicle_to_ground(heading, pitch, roll) @ np.asarray(lever, dtype=float)


def offset_heading_jacobian(lever, heading, pitch, roll):
    """d(dx, dy)/d(heading) of the antenna displacement (4.23): how a heading error moves a corrected fix."""
    x, y, _ = f2(-pitch) @ f1(-roll) @ np.asarray(lever, dtype=float)
    c, s = math.cos(heading), math.sin(heading)
    return np.array([-s * x + c * y, -c * x - s * y])


def correct(antenna_xyz, lever, heading, pitch, roll):
    """Reference-point position (X', Y', Z') = antenna - E (a, b, h) (4.24)."""
    return np.asarray(antenna_xyz, dtype=float) - antenna_offset(lever, heading, pitch, roll)


def lever_from_flu(xyz_flu):
    """Thesis lever (a, b, h) = (right, forward, up) from a base_link->gnss_link FLU translation (SPEC §2.3)."""
    x, y, z = (float(v) for v in xyz_flu)
    return np.array([-y, x, z])


def tilt_variance(lever, var_roll, var_pitch, var_heading, max_tilt_var=0.1, max_heading_var=1.0):
    """Horizontal variance (m^2 per axis) that attitude variances (rad^2) add to a tilt-corrected position through
    the lever arm (right, forward, up): height x tilt, horizontal arm x heading. Each variance is capped (a
    non-finite or negative one counts as the cap): beyond it the small-angle projection means nothing."""
    a, b, h = np.asarray(lever, dtype=float).tolist()
    return (h * h * (_capped(var_roll, max_tilt_var) + _capped(var_pitch, max_tilt_var)) / 2
            + (a * a + b * b) * _capped(var_heading, max_heading_var))


def _capped(var, cap):
    return var if 0.0 <= var <= cap else cap  # NaN, negative, above the cap (inf): the cap
