"""The INS's per-sample paths on Python floats (issue 14) against the matrix form they replaced, on random inputs
(fixed seed): mechanization step, quaternion and Rodrigues helpers, error dynamics F, IMU-point solution and
base_link state."""
import math
from dataclasses import replace

import numpy as np
import pytest

from agnav_common.frames import cross
from agnav_common.geodesy import LocalTangentPlane
from agnav_fusion.ins import earth, error_model as em, quaternion
from agnav_fusion.ins.ekf import InsEkf, InsEkfSettings, NavSolution
from agnav_fusion.ins.frames import FRD, Mounts, base_link_state, symmetric
from agnav_fusion.ins.measurements import ENU_TO_NED, c_axes, ned_to_c
from agnav_fusion.ins.mechanization import InsState, Mechanization, T, c_cbar_ned, rotation, skew
from agnav_fusion.ins.mechanization import mat3
from agnav_fusion.ins.solution import congruence3

RNG = np.random.default_rng(20261128)
TD = np.array([1.0, -1.0, -1.0])


# ---- the matrix forms (as they were before the scalar rewrite) ---------------------------------------------------
def to_dcm_ref(q):
    q0, q1, q2, q3 = q
    return np.array([
        [q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3, 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)],
        [2 * (q1 * q2 + q0 * q3), q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3, 2 * (q2 * q3 - q0 * q1)],
        [2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3]])


def rotate_increment_ref(q, dtheta):
    a = np.linalg.norm(dtheta)
    r = np.r_[1.0, 0.5 * dtheta] if a < 1e-12 else np.r_[math.cos(a / 2), math.sin(a / 2) / a * dtheta]
    q0, q1, q2, q3 = q
    out = np.array([q0 * r[0] - q1 * r[1] - q2 * r[2] - q3 * r[3], q0 * r[1] + q1 * r[0] + q2 * r[3] - q3 * r[2],
                    q0 * r[2] - q1 * r[3] + q2 * r[0] + q3 * r[1], q0 * r[3] + q1 * r[2] - q2 * r[1] + q3 * r[0]])
    return out / np.linalg.norm(out)


def rotation_ref(phi):
    a = np.linalg.norm(phi)
    k = skew(phi)
    if a < 1e-9:
        return np.eye(3) + k + 0.5 * k @ k
    return np.eye(3) + math.sin(a) / a * k + (1.0 - math.cos(a)) / a ** 2 * k @ k


def step_ref(m, gyro, accel, dt):
    s = m.state
    lat, alpha = s.lat, s.alpha
    rho = earth.transport_rate(s.v, lat, s.h, alpha)
    omega = earth.earth_rate_c(lat, alpha)
    c_bc = to_dcm_ref(s.q)
    theta_b = c_bc.T @ (T @ ((rho + omega) * dt))
    s.q = rotate_increment_ref(s.q, (gyro - m.gyro_bias) * dt - theta_b)
    c_bc = to_dcm_ref(s.q)
    a_c = T @ (c_bc @ (accel - m.accel_bias))
    v_old = s.v
    s.v = v_old + (a_c - np.cross(rho + 2.0 * omega, v_old) + earth.gravity_c(lat, s.h, alpha)) * dt
    v_mid = 0.5 * (v_old + s.v)
    rho_mid = earth.transport_rate(v_mid, lat, s.h, alpha)
    s.c_ec = rotation_ref(-rho_mid * dt) @ s.c_ec
    s.h += v_mid[2] * dt
    return rho_mid, omega, a_c, c_bc


def dynamics_terms(settings, v, f_c, rho, omega, c_b_c, lat, h, alpha):
    """F term by term (5-4-10..46), the form `error_model.dynamics` writes out entry by entry."""
    r = earth.mean_radius(lat) + h
    big_omega = earth.OMEGA
    sl, cl, sa, ca = math.sin(lat), math.cos(lat), math.sin(alpha), math.cos(alpha)
    f = np.zeros((em.N_STATES, em.N_STATES))
    d_rho = np.zeros((3, em.N_STATES))
    d_rho[0, em.VY], d_rho[0, em.H] = -1.0 / r, v[1] / r ** 2
    d_rho[1, em.VX], d_rho[1, em.H] = 1.0 / r, -v[0] / r ** 2
    d_om = np.zeros((3, em.N_STATES))
    cols = [em.GAMMA, em.BETA, em.RX, em.RY]
    d_om[0, cols] = big_omega * np.array([-cl * sa, cl * ca, -sl * ca * sa, -sl * ca * ca])
    d_om[1, cols] = big_omega * np.array([-cl * ca, -cl * sa, sl * sa * sa, sl * sa * ca])
    d_om[2, [em.RX, em.RY]] = big_omega * cl * np.array([sa, ca])
    f[em.RX] = d_rho[0]
    f[em.RX, em.GAMMA] -= rho[1]
    f[em.RX, em.BETA] -= rho[0]
    f[em.RY] = d_rho[1]
    f[em.RY, em.GAMMA] += rho[0]
    f[em.RY, em.BETA] -= rho[1]
    f[em.H, em.VZ] = 1.0
    w = d_rho + 2.0 * d_om
    f[em.VX] += v[1] * w[2] - v[2] * w[1]
    f[em.VY] += v[2] * w[0] - v[0] * w[2]
    f[em.VZ] += v[0] * w[1] - v[1] * w[0]
    f[em.VX, em.TY] += -f_c[2]
    f[em.VY, em.TX] += f_c[2]
    f[em.VZ, em.TX] += -f_c[1]
    f[em.VZ, em.TY] += f_c[0]
    p = rho + 2.0 * omega
    f[em.VX, em.VY] += p[2]
    f[em.VX, em.VZ] += -p[1]
    f[em.VY, em.VZ] += p[0]
    f[em.VY, em.VX] += -p[2]
    f[em.VZ, em.VX] += p[1]
    f[em.VZ, em.VY] += -p[0]
    for i, row in enumerate(em.V3):
        f[row, em.BA] = c_b_c[i]
    f[em.VX, em.BG] += v[1] * c_b_c[2]
    f[em.VY, em.BG] -= v[0] * c_b_c[2]
    f[em.VZ, em.H] += 2.0 * earth.gravity(lat, h) / r
    wr = rho + omega
    f[em.TX] = d_rho[0] + d_om[0]
    f[em.TX, em.TY] += wr[2]
    f[em.TX, em.BG] = -c_b_c[0]
    f[em.TY] = d_rho[1] + d_om[1]
    f[em.TY, em.TX] += -wr[2]
    f[em.TY, em.BG] = -c_b_c[1]
    f[em.GAMMA] = -d_om[2]
    f[em.GAMMA, em.TY] += wr[0]
    f[em.GAMMA, em.TX] += -wr[1]
    f[em.GAMMA, em.BG] = c_b_c[2]
    f[em.BA, em.BA] = -np.eye(3) / settings.accel_bias_tau
    f[em.BG, em.BG] = -np.eye(3) / settings.gyro_bias_tau
    return f


def solution_ref(ekf):
    st, p = ekf.mech.state, ekf.p
    lat, alpha = st.lat, st.alpha
    c_bc, cn = to_dcm_ref(st.q), c_cbar_ned(alpha)
    a = c_axes(alpha) * (earth.mean_radius(lat) + st.h)
    pos = np.zeros((3, 3))
    pos[:2, :2] = a @ p[:2, :2] @ a.T
    pos[2, 2] = p[em.H, em.H]
    m = ENU_TO_NED.T @ ned_to_c(alpha).T
    v3 = np.ix_(list(em.V3), list(em.V3))
    tx, ty, c = p[em.TX, em.TX], p[em.TY, em.TY], p[em.TX, em.TY]
    tilt = 0.5 * (tx + ty) + math.hypot(0.5 * (tx - ty), c)
    roll, pitch, yaw_c = quaternion.euler(c_bc)
    g, m_ = em.GAMMA, em.MOUNT_YAW          # base_link's heading error: -(γ + δm)
    heading_var = p[g, g] + p[m_, m_] + 2.0 * p[g, m_]
    return NavSolution(ekf.t, lat, st.lon, st.h, cn @ (T @ st.v), roll, pitch,
                       math.remainder(yaw_c - alpha, 2.0 * math.pi), ekf.omega_b.copy(), cn @ c_bc, pos,
                       m @ p[v3] @ m.T, np.array([tilt, tilt, heading_var]), np.diag(p)[em.BG].copy(),
                       ekf.crab, p[em.N_STATES, em.N_STATES])


def base_link_ref(sol, mounts, plane, rate_var):
    c, lever = sol.c_b_ned, -mounts.lever_imu_frd
    d = c @ -lever
    rm, rn = earth.radii(sol.lat)
    lat, lon, h = sol.lat - d[0] / (rm + sol.h), sol.lon - d[1] / ((rn + sol.h) * math.cos(sol.lat)), sol.h + d[2]
    position = np.array(plane.to_enu(math.degrees(lat), math.degrees(lon), h), dtype=float)
    ned_to_enu = ENU_TO_NED.T
    r_body_enu = ned_to_enu @ (c * FRD)
    v_ned = sol.v_ned + c @ np.cross(sol.omega_b, lever)
    arm = ned_to_enu @ skew(c @ lever)
    pose_cov = np.zeros((6, 6))
    pose_cov[:3, :3] = sol.pos_cov_enu + (arm * sol.att_var) @ arm.T
    pose_cov[range(3, 6), range(3, 6)] = sol.att_var
    twist_cov = np.zeros((6, 6))
    twist_cov[:3, :3] = r_body_enu.T @ sol.vel_cov_enu @ r_body_enu
    twist_cov[range(3, 6), range(3, 6)] = sol.gyro_bias_var + np.asarray(rate_var, dtype=float)
    return (position, np.array([sol.roll, -sol.pitch, math.remainder(math.pi / 2 - sol.heading, 2 * math.pi)]),
            symmetric(pose_cov), r_body_enu.T @ (ned_to_enu @ v_ned), FRD * sol.omega_b, symmetric(twist_cov))


# ---- helpers -----------------------------------------------------------------------------------------------------
def random_quaternion():
    q = RNG.normal(size=4)
    return q / np.linalg.norm(q)


def random_state():
    lat, lon = RNG.uniform(-1.4, 1.4), RNG.uniform(-3.0, 3.0)
    return InsState.from_geodetic(lat, lon, RNG.uniform(-100, 3000), *RNG.uniform(-0.5, 0.5, 2),
                                  RNG.uniform(-math.pi, math.pi), RNG.normal(0, 10, 3))


def random_spd(n):
    a = RNG.normal(size=(n, n))
    return a @ a.T * 1e-3 + np.eye(n) * 1e-6


# ---- tests -------------------------------------------------------------------------------------------------------
def test_quaternion_helpers_match_the_matrix_form():
    for _ in range(200):
        q = random_quaternion()
        np.testing.assert_allclose(quaternion.to_dcm(q), to_dcm_ref(q), rtol=0, atol=1e-15)
        assert np.array_equal(np.array(quaternion.dcm_rows(q.tolist())), quaternion.to_dcm(q))
        assert quaternion.roll(q.tolist()) == pytest.approx(quaternion.euler(to_dcm_ref(q))[0], abs=1e-14)
        for scale in (1e-14, 1e-6, 1e-2, 2.0):
            d = RNG.normal(size=3) * scale
            np.testing.assert_allclose(quaternion.rotate_increment(q, d), rotate_increment_ref(q, d), atol=2e-16 * 8)
            np.testing.assert_allclose(rotation(d), rotation_ref(d), atol=1e-15 * 4)


def test_small_matrix_helpers():
    for _ in range(50):
        a, b = RNG.normal(size=(3, 3)), RNG.normal(size=(3, 3))
        np.testing.assert_allclose(np.array(mat3(a.tolist(), b.tolist())), a @ b, atol=1e-14)
        np.testing.assert_allclose(np.array(congruence3(a.tolist(), b.tolist())), a @ b @ a.T, atol=1e-13)


@pytest.mark.parametrize("trial", range(20))
def test_mechanization_step_matches_the_matrix_form(trial):
    st = random_state()
    bias_a, bias_g = RNG.normal(0, 0.05, 3), RNG.normal(0, 1e-3, 3)
    fast = Mechanization(replace(st, c_ec=st.c_ec.copy(), v=st.v.copy(), q=st.q.copy()), bias_a.copy(), bias_g.copy())
    ref = Mechanization(replace(st, c_ec=st.c_ec.copy(), v=st.v.copy(), q=st.q.copy()), bias_a.copy(), bias_g.copy())
    for k in range(50):
        gyro, accel, dt = RNG.normal(0, 0.3, 3), RNG.normal(0, 2.0, 3) + [0, 0, -9.8], RNG.uniform(0.001, 0.05)
        out = fast.step(gyro if k % 2 else gyro.tolist(), accel, dt)
        want = step_ref(ref, gyro, accel, dt)
        for got, exp in zip(out, want):
            np.testing.assert_allclose(np.array(got, dtype=float), exp, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(fast.state.c_ec, ref.state.c_ec, rtol=0, atol=1e-14)
    np.testing.assert_allclose(fast.state.q, ref.state.q, rtol=0, atol=1e-14)
    np.testing.assert_allclose(fast.state.v, ref.state.v, rtol=1e-12, atol=1e-12)
    assert fast.state.h == pytest.approx(ref.state.h, rel=1e-12, abs=1e-9)


@pytest.mark.parametrize("trial", range(20))
def test_dynamics_matches_the_term_form(trial):
    settings = em.ErrorModelSettings(accel_bias_tau=RNG.uniform(10, 1000), gyro_bias_tau=RNG.uniform(10, 1000))
    v, f_c, rho, omega = RNG.normal(0, 10, 3), RNG.normal(0, 5, 3), RNG.normal(0, 1e-5, 3), RNG.normal(0, 7e-5, 3)
    c = to_dcm_ref(random_quaternion())
    lat, h, alpha = RNG.uniform(-1.5, 1.5), RNG.uniform(-100, 3000), RNG.uniform(-math.pi, math.pi)
    want = dynamics_terms(settings, v, f_c, rho, omega, T @ c, lat, h, alpha)
    for args in ((v, f_c, rho, omega, T @ c), (v.tolist(), tuple(f_c), tuple(rho), tuple(omega),
                                                em.body_to_c(tuple(map(tuple, c))))):
        np.testing.assert_allclose(em.dynamics(settings, *args, lat, h, alpha), want, rtol=1e-14, atol=1e-20)


def _ekf_with_random_state():
    ekf = InsEkf(InsEkfSettings(lever_gnss_frd=(0.3, -0.1, -1.5), lever_base_frd=(-0.5, 0.0, 1.0)))
    ekf.adopt(Mechanization(random_state()), random_spd(em.N_INS), crab=0.01, t=12.5, omega_b=RNG.normal(0, 0.1, 3))
    return ekf


@pytest.mark.parametrize("trial", range(20))
def test_solution_and_base_link_state_match_the_matrix_form(trial):
    ekf = _ekf_with_random_state()
    got, want = ekf.solution(), solution_ref(ekf)
    for name in NavSolution.__dataclass_fields__:
        np.testing.assert_allclose(getattr(got, name), getattr(want, name), rtol=1e-13, atol=1e-15, err_msg=name)
    mounts = Mounts.from_tf(RNG.normal(0, 1, 3), np.eye(3), RNG.normal(0, 1, 3))
    plane = LocalTangentPlane(math.degrees(want.lat) + 1e-4, math.degrees(want.lon) - 1e-4, want.h - 3.0)
    sol = replace(want, vel_cov_enu=want.vel_cov_enu + RNG.normal(0, 1e-9, (3, 3)))    # not exactly symmetric
    b = base_link_state(sol, mounts, plane, (1e-6, 2e-6, 3e-6))
    ref = base_link_ref(sol, mounts, plane, (1e-6, 2e-6, 3e-6))
    for name, exp in zip(("position", "rpy", "pose_cov", "velocity", "rates", "twist_cov"), ref):
        np.testing.assert_allclose(getattr(b, name), exp, rtol=1e-12, atol=1e-12, err_msg=name)
    assert np.array_equal(b.pose_cov, b.pose_cov.T) and np.array_equal(b.twist_cov, b.twist_cov.T)
    unchecked = replace(b, checks=None)
    assert b.finite() == unchecked.finite() is True
    assert b.positive_definite() == unchecked.positive_definite() is True


def test_base_link_checks_catch_nan_and_indefinite():
    ekf = _ekf_with_random_state()
    sol = ekf.solution()
    mounts = Mounts.from_tf((0.5, 0.0, 1.0), np.eye(3), (0.0, 0.0, 2.0))
    plane = LocalTangentPlane(math.degrees(sol.lat), math.degrees(sol.lon), sol.h)
    bad_nan = replace(sol, vel_cov_enu=np.full((3, 3), np.nan))
    bad_pd = replace(sol, pos_cov_enu=-np.eye(3))
    for s, finite, pd in ((bad_nan, False, False), (bad_pd, True, False)):
        b = base_link_state(s, mounts, plane)
        assert b.finite() == replace(b, checks=None).finite() == finite
        if finite:
            assert b.positive_definite() == replace(b, checks=None).positive_definite() == pd


@pytest.mark.parametrize("trial", range(10))
def test_ekf_base_link_state_equals_the_solution_path(trial):
    from agnav_fusion.ins.frames import ekf_base_link_state
    ekf = _ekf_with_random_state()
    mounts = Mounts.from_tf((0.5, 0.1, 1.0), np.eye(3), (0.0, 0.0, 2.0))
    sol = ekf.solution()
    plane = LocalTangentPlane(math.degrees(sol.lat), math.degrees(sol.lon), sol.h)
    b, crab, crab_var = ekf_base_link_state(ekf, mounts, plane, (1e-6,) * 3)
    want = base_link_state(sol, mounts, plane, (1e-6,) * 3)
    for name in ("position", "rpy", "pose_cov", "velocity", "rates", "twist_cov"):
        np.testing.assert_allclose(getattr(b, name), getattr(want, name), rtol=1e-13, atol=1e-15, err_msg=name)
    assert np.array_equal(b.pose_cov, b.pose_cov.T) and np.array_equal(b.twist_cov, b.twist_cov.T)
    assert (crab, crab_var) == (sol.crab, sol.crab_var) and b.checks == want.checks


def from_dcm_ref(c):
    tr = np.trace(c)
    i = int(np.argmax([tr, c[0, 0], c[1, 1], c[2, 2]]))
    if i == 0:
        s = 2.0 * math.sqrt(1.0 + tr)
        q = [s / 4, (c[2, 1] - c[1, 2]) / s, (c[0, 2] - c[2, 0]) / s, (c[1, 0] - c[0, 1]) / s]
    elif i == 1:
        s = 2.0 * math.sqrt(1.0 + c[0, 0] - c[1, 1] - c[2, 2])
        q = [(c[2, 1] - c[1, 2]) / s, s / 4, (c[0, 1] + c[1, 0]) / s, (c[0, 2] + c[2, 0]) / s]
    elif i == 2:
        s = 2.0 * math.sqrt(1.0 - c[0, 0] + c[1, 1] - c[2, 2])
        q = [(c[0, 2] - c[2, 0]) / s, (c[0, 1] + c[1, 0]) / s, s / 4, (c[1, 2] + c[2, 1]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 - c[0, 0] - c[1, 1] + c[2, 2])
        q = [(c[1, 0] - c[0, 1]) / s, (c[0, 2] + c[2, 0]) / s, (c[1, 2] + c[2, 1]) / s, s / 4]
    q = np.array(q)
    return q / np.linalg.norm(q) * (1.0 if q[0] >= 0 else -1.0)


def apply_ref(mech, x):
    from agnav_fusion.ins.feedback import azimuth_error
    def orthonormalize(c):
        u, _, vt = np.linalg.svd(c)
        return u @ vt
    s = mech.state
    d_alpha = azimuth_error(x[em.GAMMA], x[em.BETA])
    ca, sa = math.cos(d_alpha), math.sin(d_alpha)
    mz_t = np.array([[ca, -sa, 0.0], [sa, ca, 0.0], [0.0, 0.0, 1.0]])
    s.c_ec = orthonormalize((np.eye(3) + skew([x[em.RX], x[em.RY], 0.0])) @ mz_t @ s.c_ec)
    s.h -= x[em.H]
    s.v = s.v - x[list(em.V3)]
    s.q = from_dcm_ref(rotation_ref(np.array([x[em.TX], -x[em.TY], 0.0])) @ to_dcm_ref(s.q))
    mech.accel_bias = mech.accel_bias + x[em.BA]
    mech.gyro_bias = mech.gyro_bias + x[em.BG]
    return d_alpha


def test_from_dcm_matches_the_matrix_form():
    for k in range(400):
        c = to_dcm_ref(random_quaternion())
        if k % 4:       # every Shepperd branch: turn by pi about x, y or z
            c = c @ np.diag([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]][k % 4])
        want = from_dcm_ref(c)
        np.testing.assert_allclose(quaternion.from_dcm(c), want, rtol=0, atol=1e-15)
        np.testing.assert_allclose(quaternion.from_dcm(tuple(map(tuple, c))), want, rtol=0, atol=1e-15)


@pytest.mark.parametrize("trial", range(10))
def test_feedback_and_azimuth_reset_match_the_matrix_form(trial):
    from agnav_fusion.ins import feedback
    st = random_state()
    x = RNG.normal(0, 1e-5, 17)
    x[em.GAMMA], x[em.BETA] = RNG.normal(0, 0.3), RNG.normal(0, 0.05)
    fast, ref = (Mechanization(replace(st, c_ec=st.c_ec.copy(), v=st.v.copy(), q=st.q.copy()),
                               np.full(3, 0.01), np.full(3, 1e-4)) for _ in range(2))
    assert feedback.apply(fast, x) == apply_ref(ref, x)
    for name in ("c_ec", "v", "q"):
        np.testing.assert_allclose(getattr(fast.state, name), getattr(ref.state, name), rtol=0, atol=2e-15)
    assert fast.state.h == ref.state.h
    np.testing.assert_array_equal(fast.accel_bias, ref.accel_bias)
    np.testing.assert_array_equal(fast.gyro_bias, ref.gyro_bias)
    p = random_spd(17)
    j = feedback.azimuth_reset_jacobian(x[em.GAMMA], x[em.BETA], 17)
    np.testing.assert_allclose(feedback.azimuth_reset(p, x[em.GAMMA], x[em.BETA]), j @ p @ j.T, rtol=1e-14,
                               atol=1e-18)


def test_fast_plane_to_geodetic_matches_pymap3d():
    from agnav_fusion.ins.frames import FastPlane
    for lat0, lon0, alt0 in ((43.0, 141.0, 50.0), (-33.9, 18.4, 10.0), (0.0, 0.0, 0.0), (89.9, -120.0, 3000.0)):
        plane = LocalTangentPlane(lat0, lon0, alt0)
        fast = FastPlane(plane)
        for east, north, up in RNG.normal(0, 2000, (30, 3)):
            got, want = fast.to_geodetic(east, north, up), plane.to_geodetic(east, north, up)
            np.testing.assert_allclose(got[:2], [float(want[0]), float(want[1])], rtol=0, atol=1e-12)
            assert got[2] == pytest.approx(float(want[2]), abs=1e-7)
            np.testing.assert_allclose(fast.to_enu(*got), (east, north, up), atol=1e-6)


def test_transition_is_identity_plus_f_dt():
    settings = em.ErrorModelSettings()
    args = (RNG.normal(0, 10, 3), RNG.normal(0, 5, 3), RNG.normal(0, 1e-5, 3), RNG.normal(0, 7e-5, 3),
            T @ to_dcm_ref(random_quaternion()), 0.7, 120.0, 0.3)
    f = em.dynamics(settings, *args)
    for n in (16, 17, 20):
        want = np.eye(n)
        want[:16, :16] += f * 0.05
        assert np.array_equal(em.transition(settings, *args, 0.05, n), want)


def test_state_caches_follow_replaced_arrays():
    st = random_state()
    lat, lon, alpha = st.lat, st.lon, st.alpha
    assert (lat, lon, alpha) == (math.asin(st.c_ec[2, 2]), math.atan2(st.c_ec[2, 1], st.c_ec[2, 0]),
                                 math.atan2(-st.c_ec[1, 2], st.c_ec[0, 2]))
    st.c_ec = rotation_ref(np.array([1e-3, -2e-3, 0.0])) @ st.c_ec
    assert st.lat == math.asin(st.c_ec[2, 2]) and st.alpha == math.atan2(-st.c_ec[1, 2], st.c_ec[0, 2])
    st.q = random_quaternion()
    assert np.array_equal(st.c_b_cbar(), quaternion.to_dcm(st.q))
    m = Mechanization(st)
    m.step((0.1, 0.0, 0.2), (0.0, 0.0, -9.8), 0.01)
    assert st.geo() == (math.asin(st.c_ec[2, 2]), math.atan2(st.c_ec[2, 1], st.c_ec[2, 0]),
                        math.atan2(-st.c_ec[1, 2], st.c_ec[0, 2]))
    assert np.array_equal(st.c_b_cbar(), quaternion.to_dcm(st.q))


def test_local_terms_are_wander_radii_and_gravity():
    for lat, h, alpha in RNG.uniform([-1.5, -100, -3], [1.5, 3000, 3], (50, 3)):
        got = earth.local_terms(lat, h, math.sin(lat), math.sin(alpha), math.cos(alpha))
        assert got == (*earth.wander_radii(lat, h, alpha), earth.gravity(lat, h))


def test_orthonormalize_is_the_polar_factor():
    from agnav_fusion.ins.mechanization import orthonormalize
    for scale in (0.0, 1e-15, 1e-12, 1e-9, 1e-7, 1e-5, 1e-2):
        for _ in range(20):
            c = to_dcm_ref(random_quaternion()) + RNG.normal(0, scale, (3, 3))
            u, _, vt = np.linalg.svd(c)
            got = orthonormalize(c)
            np.testing.assert_allclose(got, u @ vt, rtol=0, atol=5e-15)
            np.testing.assert_allclose(got.T @ got, np.eye(3), rtol=0, atol=2e-15)


def nhc_linearize_ref(nhc, c_b_cbar, v_c, omega_b, crab, n_states):
    v_b = c_b_cbar.T @ (T @ v_c) + np.cross(omega_b, nhc.lever)
    j = np.zeros((3, n_states))
    j[:, list(em.V3)] = c_b_cbar.T @ T
    m = -c_b_cbar.T @ skew(T @ v_c)
    j[:, em.TX], j[:, em.TY] = m[:, 0], -m[:, 1]
    j[:, em.BG] = -skew(nhc.lever)
    h = np.stack([j[1] - crab * j[0], j[2]])
    h[0, em.N_STATES] = -v_b[0]
    if n_states > em.MOUNT_YAW:
        h[0, em.MOUNT_YAW] = v_b[0]
    extra = (nhc.s.speed_sigma_gain * abs(v_b[0])) ** 2
    r = np.diag([nhc.s.lateral_sigma ** 2 + extra, nhc.s.vertical_sigma ** 2 + extra])
    return np.array([v_b[1] - v_b[0] * crab, v_b[2]]), h, r


@pytest.mark.parametrize("trial", range(10))
def test_nhc_rows_match_the_matrix_form(trial):
    from agnav_fusion.ins.constraints import NhcSettings, NonHolonomic
    nhc = NonHolonomic(NhcSettings(), RNG.normal(0, 1, 3))
    c, v, w, crab = to_dcm_ref(random_quaternion()), RNG.normal(0, 5, 3), RNG.normal(0, 0.3, 3), RNG.normal(0, 0.05)
    for n in (17, 21):
        want = nhc_linearize_ref(nhc, c, v, w, crab, n)
        for args in ((c, v, w), (tuple(map(tuple, c.tolist())), v, w)):
            lin = nhc.linearize(*args, crab, n)
            for got, exp in zip((lin.z, lin.h, lin.r), want):
                np.testing.assert_allclose(got, exp, rtol=1e-13, atol=1e-15)


def position_rows_ref(lever, snap, alpha, gnss, n_states, heading_var):
    from agnav_fusion.ins.lever_arm import antenna_to_imu_position
    lat_g, lon_g, h_g = antenna_to_imu_position(gnss.lat, gnss.lon, gnss.alt, lever, snap.c_b_ned)
    a = c_axes(alpha)
    rm, rn = earth.radii(snap.lat)
    r_x, r_y = a.T @ np.array([(snap.lon - lon_g) * math.cos(snap.lat), snap.lat - lat_g])
    h = np.zeros((3, n_states))
    h[0, [em.RX, em.GAMMA, em.BETA]] = 1.0, r_y, r_x
    h[1, [em.RY, em.GAMMA, em.BETA]] = 1.0, -r_x, r_y
    h[2, em.H] = 1.0
    d = snap.c_b_ned @ lever
    cn = c_cbar_ned(alpha)
    dd = np.zeros((3, n_states))
    dd[:2, em.GAMMA] = d[1], -d[0]
    dd[:2, em.BETA] = -d[:2]
    dd[:, em.TX], dd[:, em.TY] = np.cross(d, cn[:, 0]), -np.cross(d, cn[:, 1])
    if n_states > em.MOUNT_YAW:             # the lever on the body axes is R_z(δm) l
        dd[:, em.MOUNT_YAW] = -snap.c_b_ned @ np.cross([0.0, 0.0, 1.0], lever)
    scale = np.diag([1.0 / (rn + snap.h), 1.0 / (rm + snap.h)])
    h[:2] += a.T @ scale @ dd[[1, 0]]
    h[2] -= dd[2]
    r = np.zeros((3, 3))
    r[:2, :2] = a.T @ scale @ (gnss.pos_cov_enu[:2, :2] + heading_var * float(np.sum(d[:2] ** 2)) * np.eye(2)) @ scale @ a
    r[2, 2] = gnss.pos_cov_enu[2, 2]
    return np.array([r_x, r_y, snap.h - h_g]), h, r


@pytest.mark.parametrize("trial", range(10))
def test_position_rows_match_the_matrix_form(trial):
    from agnav_fusion.ins.measurements import GnssPosition, GnssSample, Snapshot
    lat, lon, h = RNG.uniform(-1.4, 1.4), RNG.uniform(-3, 3), RNG.uniform(-100, 3000)
    snap = Snapshot(1.0, lat, lon, h, RNG.normal(0, 5, 3), to_dcm_ref(random_quaternion()), RNG.normal(0, 0.2, 3))
    cov = random_spd(3)
    g = GnssSample(1.0, lat + RNG.normal(0, 1e-6), lon + RNG.normal(0, 1e-6), h + RNG.normal(0, 2), cov)
    model = GnssPosition(RNG.normal(0, 1, 3))
    alpha, hv = RNG.uniform(-3, 3), RNG.choice([0.0, 0.3])
    for n in (17, 20):
        lin = model.linearize(snap, alpha, g, n, hv)
        for got, exp in zip((lin.z, lin.h, lin.r), position_rows_ref(model.lever, snap, alpha, g, n, hv)):
            np.testing.assert_allclose(got, exp, rtol=1e-12, atol=1e-15)


def velocity_rows_ref(lever, snap, alpha, gnss, n_states):
    m = ned_to_c(alpha)
    va = m @ ENU_TO_NED @ gnss.vel_enu
    u = c_cbar_ned(alpha).T @ (snap.c_b_ned @ np.cross(snap.omega_b, lever))
    h = np.zeros((3, n_states))
    h[0, [em.VX, em.GAMMA, em.BETA]] = 1.0, -va[1], -va[0]
    h[1, [em.VY, em.GAMMA, em.BETA]] = 1.0, va[0], -va[1]
    h[2, em.VZ] = 1.0
    h[:, em.TX], h[:, em.TY] = T @ np.cross(u, [1.0, 0.0, 0.0]), -T @ np.cross(u, [0.0, 1.0, 0.0])
    h[:, em.BG] = -T @ c_cbar_ned(alpha).T @ snap.c_b_ned @ skew(lever)
    cov = ENU_TO_NED @ gnss.vel_cov_enu @ ENU_TO_NED.T
    return m @ snap.v_ned - va + T @ u, h, m @ cov @ m.T


@pytest.mark.parametrize("trial", range(10))
def test_velocity_rows_match_the_matrix_form(trial):
    from agnav_fusion.ins.measurements import GnssSample, GnssVelocity, Snapshot
    snap = Snapshot(1.0, 0.7, 2.0, 50.0, RNG.normal(0, 5, 3), to_dcm_ref(random_quaternion()), RNG.normal(0, 0.2, 3))
    g = GnssSample(1.0, 0.7, 2.0, 50.0, random_spd(3), RNG.normal(0, 5, 3), random_spd(3) + RNG.normal(0, 1e-9, (3, 3)))
    model = GnssVelocity(RNG.normal(0, 1, 3))
    alpha = RNG.uniform(-3, 3)
    for n in (17, 20):
        lin = model.linearize(snap, alpha, g, n)
        for got, exp in zip((lin.z, lin.h, lin.r), velocity_rows_ref(model.lever, snap, alpha, g, n)):
            np.testing.assert_allclose(got, exp, rtol=1e-12, atol=1e-14)
