"""Scalar-first unit quaternions q = [q0, q1, q2, q3] of the body B relative to C-bar (SPEC §7.2)."""
import math

import numpy as np


def from_roll_pitch_yaw(roll, pitch, yaw=0.0):
    """Z-Y-X quaternion; with yaw = 0 this is (5-3-1..4)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])


def to_dcm(q):
    """Body -> C-bar direction cosine matrix (5-3-5)."""
    return np.array(dcm_rows(np.asarray(q, dtype=float).tolist()))


def dcm_rows(q):
    """to_dcm of q = (q0, q1, q2, q3) Python floats, as three row tuples (cheaper scalar arithmetic than numpy's)."""
    q0, q1, q2, q3 = q
    return ((q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3, 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)),
            (2 * (q1 * q2 + q0 * q3), q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3, 2 * (q2 * q3 - q0 * q1)),
            (2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3))


def from_dcm(c):
    """Unit quaternion of a rotation matrix (Shepperd's method); c: array or 3x3 row tuples."""
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = c.tolist() if isinstance(c, np.ndarray) else c
    tr = c00 + c11 + c22
    cand = [tr, c00, c11, c22]
    i = cand.index(max(cand))
    if i == 0:
        s = 2.0 * math.sqrt(1.0 + tr)
        q = (s / 4, (c21 - c12) / s, (c02 - c20) / s, (c10 - c01) / s)
    elif i == 1:
        s = 2.0 * math.sqrt(1.0 + c00 - c11 - c22)
        q = ((c21 - c12) / s, s / 4, (c01 + c10) / s, (c02 + c20) / s)
    elif i == 2:
        s = 2.0 * math.sqrt(1.0 - c00 + c11 - c22)
        q = ((c02 - c20) / s, (c01 + c10) / s, s / 4, (c12 + c21) / s)
    else:
        s = 2.0 * math.sqrt(1.0 - c00 - c11 + c22)
        q = ((c10 - c01) / s, (c02 + c20) / s, (c12 + c21) / s, s / 4)
    q0, q1, q2, q3 = q
    n, sign = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3), (1.0 if q0 >= 0 else -1.0)
    return np.array((q0 / n * sign, q1 / n * sign, q2 / n * sign, q3 / n * sign))


def rotate_increment(q, dtheta):
    """q <- q (x) [cos(|dθ|/2), sin(|dθ|/2) dθ/|dθ|]: exact form of (5-3-10), normalised."""
    d0, d1, d2 = np.asarray(dtheta, dtype=float).tolist()
    return np.array(increment(d0, d1, d2, *np.asarray(q, dtype=float).tolist()))


def increment(d0, d1, d2, q0, q1, q2, q3):
    """rotate_increment on Python floats: the rotation vector (d0, d1, d2), q = (q0..q3); a tuple."""
    a = math.sqrt(d0 ** 2 + d1 ** 2 + d2 ** 2)
    if a < 1e-12:
        r0, r1, r2, r3 = 1.0, 0.5 * d0, 0.5 * d1, 0.5 * d2
    else:
        s = math.sin(a / 2) / a
        r0, r1, r2, r3 = math.cos(a / 2), s * d0, s * d1, s * d2
    o0 = q0 * r0 - q1 * r1 - q2 * r2 - q3 * r3
    o1 = q0 * r1 + q1 * r0 + q2 * r3 - q3 * r2
    o2 = q0 * r2 - q1 * r3 + q2 * r0 + q3 * r1
    o3 = q0 * r3 + q1 * r2 - q2 * r1 + q3 * r0
    n = math.sqrt(o0 * o0 + o1 * o1 + o2 * o2 + o3 * o3)
    return o0 / n, o1 / n, o2 / n, o3 / n


def euler(c):
    """(roll, pitch, yaw) of a body -> C-bar DCM (5-3-11..13)."""
    return (math.atan2(c[2, 1], c[2, 2]), -math.asin(max(-1.0, min(1.0, c[2, 0]))),
            math.atan2(c[1, 0], c[0, 0]))


def roll(q):
    """Roll of quaternion (q0..q3) (Python floats): euler(to_dcm(q))[0] without the matrix."""
    q0, q1, q2, q3 = q
    return math.atan2(2 * (q2 * q3 + q0 * q1), q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3)
