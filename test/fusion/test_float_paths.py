"""The navigation module's per-sample paths on Python floats (issue 14) against the numpy form they replaced, on
random inputs (fixed seed): IMU rotation into base_link, dead reckoning step, tilt variance."""
import math
import types

import numpy as np
import pytest

from agnav_fusion.dead_reckoning import DeadReckoning
from agnav_fusion.pipeline import rotate
from agnav_fusion.tilt_correction import tilt_variance
from scipy.spatial.transform import Rotation

RNG = np.random.default_rng(20261201)


def test_rotate_is_the_matrix_product():
    for _ in range(50):
        r = Rotation.random(random_state=RNG.integers(1 << 31)).as_matrix()
        v = RNG.normal(0.0, 5.0, 3)
        out = rotate(tuple(map(tuple, r.tolist())), types.SimpleNamespace(x=v[0], y=v[1], z=v[2]))
        np.testing.assert_allclose(out, r @ v, rtol=1e-14, atol=1e-14)


def dead_reckoning_ref(settings, xy, cov0, steps):
    """(5.12)-(5.13) and the covariance with arrays, as before the float rewrite."""
    xy, time, distance = np.array(xy, dtype=float), 0.0, 0.0
    out = []
    for heading, speed, dt in steps:
        s, c = math.sin(heading), math.cos(heading)
        xy[0] += s * speed * dt
        xy[1] += c * speed * dt
        time += dt
        distance += abs(speed) * dt
        va, vc = (settings.speed_sigma * time) ** 2, (settings.heading_sigma * distance) ** 2
        sc = (va - vc) * s * c
        out.append((xy.copy(), cov0 + np.array([[va * s * s + vc * c * c, sc], [sc, va * c * c + vc * s * s]])))
    return out


def test_dead_reckoning_is_the_array_form():
    dr = DeadReckoning()
    a = RNG.normal(size=(2, 2))
    xy, cov0 = RNG.normal(0.0, 100.0, 2), a @ a.T
    steps = [(h, v, dt) for h, v, dt in zip(RNG.uniform(-4, 4, 300), RNG.normal(1.0, 2.0, 300),
                                           RNG.uniform(0.005, 0.02, 300))]
    dr.reset(xy, cov0)
    for (p, c), (p_ref, c_ref) in zip((dr.step(*s) for s in steps), dead_reckoning_ref(dr.settings, xy, cov0, steps)):
        assert np.array_equal(p, p_ref) and np.array_equal(c, c_ref)
    p, _ = dr.step(0.3, 1.0, 0.01)
    assert dr.step(0.3, 1.0, 0.01)[0] is not p  # fresh arrays: the history keeps them as they are


def tilt_variance_ref(lever, var_roll, var_pitch, var_heading, max_tilt_var=0.1, max_heading_var=1.0):
    vr, vp, vh = (min(v, cap) if math.isfinite(v) and v >= 0 else cap for v, cap in
                  ((var_roll, max_tilt_var), (var_pitch, max_tilt_var), (var_heading, max_heading_var)))
    a, b, h = lever
    return h * h * (vr + vp) / 2 + (a * a + b * b) * vh


@pytest.mark.parametrize("lever", [np.array([0.3, -1.2, 2.5]), (0.3, -1.2, 2.5), [0.0, 0.0, 0.0]])
def test_tilt_variance_is_the_numpy_form(lever):
    values = [0.0, 1e-6, 0.05, 0.2, 3.0, -1e-3, math.inf, math.nan]
    for vr, vp, vh in RNG.choice(values, size=(100, 3)).tolist():
        assert tilt_variance(lever, vr, vp, vh) == tilt_variance_ref(np.asarray(lever, float), vr, vp, vh)
