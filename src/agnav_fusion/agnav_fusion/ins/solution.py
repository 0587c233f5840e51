"""The IMU-point NavSolution of an InsEkf (`InsEkf.solution`), formed once per IMU sample: the attitude, velocity and
covariance-block rotations are written out on Python floats (3x3 numpy products cost more than the arithmetic);
test/ins/test_scalar_paths.py checks them against the matrix form."""
import math

import numpy as np

from . import earth, error_model as em
from .constraints import CRAB
from .mechanization import mat3
from .settings import NavSolution

TWO_PI = 2.0 * math.pi


def congruence3(m, c):
    """m @ c @ m.T of 3x3 row tuples."""
    (m0, m1, m2), (m3, m4, m5), (m6, m7, m8) = m
    (b0, b1, b2), (b3, b4, b5), (b6, b7, b8) = mat3(m, c)
    return ((b0 * m0 + b1 * m1 + b2 * m2, b0 * m3 + b1 * m4 + b2 * m5, b0 * m6 + b1 * m7 + b2 * m8),
            (b3 * m0 + b4 * m1 + b5 * m2, b3 * m3 + b4 * m4 + b5 * m5, b3 * m6 + b4 * m7 + b5 * m8),
            (b6 * m0 + b7 * m1 + b8 * m2, b6 * m3 + b7 * m4 + b8 * m5, b6 * m6 + b7 * m7 + b8 * m8))


def solution_parts(ekf):
    """The NavSolution fields of the filter's current state (see InsEkf.solution) as Python floats, 3-tuples and
    3x3 row tuples."""
    st, p = ekf.mech.state, ekf.p
    lat, alpha, h = st.lat, st.alpha, st.h
    r0, r1, r2 = st.dcm_rows()           # C_B^Cbar
    (c0, c1, c2), (c3, _, _), (c6, c7, c8) = r0, r1, r2
    ca, sa = math.cos(alpha), math.sin(alpha)
    v0, v1, v2 = st.v.tolist()
    # C-bar -> NED is [[ca, sa, 0], [-sa, ca, 0], [0, 0, 1]]; C -> ENU is [[-sa, -ca, 0], [ca, -sa, 0], [0, 0, 1]]
    c_b_ned = ((ca * r0[0] + sa * r1[0], ca * r0[1] + sa * r1[1], ca * r0[2] + sa * r1[2]),
               (-sa * r0[0] + ca * r1[0], -sa * r0[1] + ca * r1[1], -sa * r0[2] + ca * r1[2]), r2)
    # horizontal position: A P[:2, :2] A^T with A = c_axes(alpha) (R + h) (ENU from the C-axis angles)
    big_r = earth.mean_radius(lat) + h
    a00, a01, a10, a11 = ca * big_r, -sa * big_r, sa * big_r, ca * big_r
    (p00, p01), (p10, p11) = p[:2, :2].tolist()
    b00, b01, b10, b11 = a00 * p00 + a01 * p10, a00 * p01 + a01 * p11, a10 * p00 + a11 * p10, a10 * p01 + a11 * p11
    pos = ((b00 * a00 + b01 * a01, b00 * a10 + b01 * a11, 0.0),
           (b10 * a00 + b11 * a01, b10 * a10 + b11 * a11, 0.0), (0.0, 0.0, p.item(em.H, em.H)))
    rx, ry, *_, rz = p[em.VX:em.VZ + 1, em.VX:em.VZ + 1].tolist()      # rows VX, VY, .., VZ
    vel = congruence3(((-sa, -ca, 0.0), (ca, -sa, 0.0), (0.0, 0.0, 1.0)),
                      ((rx[0], rx[1], rx[-1]), (ry[0], ry[1], ry[-1]), (rz[0], rz[1], rz[-1])))
    tx, ty, c = p[em.TX, em.TX], p[em.TY, em.TY], p[em.TX, em.TY]
    tilt = 0.5 * (tx + ty) + math.hypot(0.5 * (tx - ty), c)   # largest: roll and pitch are rotated C-axis tilts
    bg = em.BG.start
    return (ekf.t, lat, st.lon, h, (ca * v0 - sa * v1, -sa * v0 - ca * v1, -v2), math.atan2(c7, c8),
            -math.asin(max(-1.0, min(1.0, c6))), math.remainder(math.atan2(c3, c0) - alpha, TWO_PI),
            ekf.omega_b.tolist(), c_b_ned, pos, vel, (tilt, tilt, em.vehicle_heading_var(p)),
            (p[bg, bg], p[bg + 1, bg + 1], p[bg + 2, bg + 2]), ekf.crab,
            p[CRAB, CRAB] if ekf.nhc is not None else math.inf)


def nav_solution(ekf):
    """NavSolution of the filter's current state (see InsEkf.solution)."""
    t, lat, lon, h, v, roll, pitch, heading, w, c, pos, vel, att, gbv, crab, crab_var = solution_parts(ekf)
    return NavSolution(t, lat, lon, h, np.array(v), roll, pitch, heading, np.array(w), np.array(c), np.array(pos),
                       np.array(vel), np.array(att), np.array(gbv), crab, crab_var)


def filter_health(ekf):
    """InsEkf health for diagnostics: alignment, NIS means, counts, GNSS age, 1-sigma errors."""
    out = {"alignment": ekf.alignment, "imu_samples": ekf.stats["imu"], "gnss_epochs": ekf.stats["gnss"]}
    for name, (n, total) in ekf.stats["nis"].items():
        out[f"nis_mean_{name}"] = total / n
    out.update({f"{k}_{name}": c for k in ("accepted", "rejected", "bridged") for name, c in ekf.stats[k].items()})
    if ekf.p is not None:
        out["heading_sigma_deg"] = math.degrees(ekf.heading_sigma())
        out["gnss_age_s"] = ekf.gnss_age()
    return out
