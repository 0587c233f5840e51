"""Attitude and angle conventions (REP-103, and the thesis' conventions at the edges; SPEC §2.3)."""
import math

import numpy as np


def wrap_angle(a):
    """Wrap an angle (rad, scalar or array) to (-pi, pi]."""
    if isinstance(a, float):  # per-sample paths: float % is np.mod, the same bits without numpy's overhead
        w = (a + math.pi) % (2.0 * math.pi) - math.pi
        return math.pi if w == -math.pi else float(w)
    w = np.mod(np.asarray(a, dtype=float) + math.pi, 2.0 * math.pi) - math.pi
    w = np.where(w == -math.pi, math.pi, w)
    return float(w) if np.ndim(w) == 0 else w


def quaternion_from_euler(roll, pitch, yaw):
    """(x, y, z, w) of R_z(yaw) R_y(pitch) R_x(roll), REP-103 intrinsic Z-Y-X."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy)


def euler_from_quaternion(x, y, z, w):
    """(roll, pitch, yaw) of a unit quaternion, inverse of quaternion_from_euler."""
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def matrix_from_quaternion(q):
    """3x3 rotation matrix of a quaternion (x, y, z, w), normalised first: scipy's Rotation.from_quat(q).as_matrix(),
    the same operations (bit for bit, tested), without importing scipy (start-up of every graph)."""
    x, y, z, w = (float(v) for v in q)
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    x2, y2, z2, w2 = x * x, y * y, z * z, w * w
    xy, zw, xz, yw, yz, xw = x * y, z * w, x * z, y * w, y * z, x * w
    return np.array([[x2 - y2 - z2 + w2, 2 * (xy - zw), 2 * (xz + yw)],
                     [2 * (xy + zw), -x2 + y2 - z2 + w2, 2 * (yz - xw)],
                     [2 * (xz - yw), 2 * (yz + xw), -x2 - y2 + z2 + w2]])


def rotation_matrix(roll, pitch, yaw):
    """3x3 body(FLU)->ENU matrix R_z(yaw) R_y(pitch) R_x(roll)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def _as_float(x):
    """x itself if a float, else a float array."""
    return x if isinstance(x, float) else np.asarray(x, dtype=float)


def yaw_from_heading(heading):
    """ENU yaw (CCW from east) from a heading clockwise from north (thesis φ); rad."""
    return wrap_angle(math.pi / 2 - _as_float(heading))


def heading_from_yaw(yaw):
    """Heading clockwise from north (thesis φ) from ENU yaw; rad, wrapped to (-pi, pi]."""
    return wrap_angle(math.pi / 2 - _as_float(yaw))


def cross_floats(a, b):
    """a x b of 3-sequences as a tuple (per-sample paths on Python floats)."""
    return a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]


def cross(a, b):
    """a x b of 3-vectors as an array (np.cross costs ~20x more for one pair, on per-sample paths)."""
    return np.array(cross_floats(a, b))
