"""Scalar fast paths of the per-sample output code give the same bits as the numpy/scipy code they replaced."""
import math

import numpy as np
from scipy.spatial.transform import Rotation

from agnav_common.frames import heading_from_yaw, matrix_from_quaternion, wrap_angle, yaw_from_heading
from agnav_fusion.odom_frame import OdomFrame


def _numpy_wrap(a):
    w = np.mod(np.asarray(a, dtype=float) + math.pi, 2.0 * math.pi) - math.pi
    return float(np.where(w == -math.pi, math.pi, w))


def test_scalar_wrap_equals_the_array_wrap_bit_for_bit():
    rng = np.random.default_rng(3)
    values = list(rng.uniform(-50, 50, 2000)) + list(rng.normal(0, 1e-9, 200)) + [
        k * math.pi for k in range(-9, 10)] + [math.nextafter(math.pi, 0), -math.nextafter(math.pi, 0), 0.0, -0.0,
                                               1e300, -1e300, math.inf, -math.inf, math.nan]
    with np.errstate(invalid="ignore"):
        for v in values:
            for x in (float(v), np.float64(v)):
                got, want = wrap_angle(x), _numpy_wrap(x)
                assert type(got) is float and (got == want or math.isnan(got) and math.isnan(want)), v
                assert math.copysign(1, got) == math.copysign(1, want)
            assert heading_from_yaw(float(v)) == _numpy_wrap(math.pi / 2 - np.asarray(v)) or math.isnan(v) \
                or math.isinf(v)
    arr = np.array(values[:100])
    assert np.array_equal(wrap_angle(yaw_from_heading(arr)), yaw_from_heading(arr))


def test_odom_frame_matches_scipy_composition():
    """map->odom o odom->base_link equals the map pose (scipy rotations, 1e-12) on random poses and motions."""
    rng = np.random.default_rng(7)
    odom, t = OdomFrame(), 0.0
    for _ in range(500):
        t += rng.uniform(0.0, 0.05)
        position = rng.uniform(-1e3, 1e3, 3)
        rpy = rng.uniform([-0.5, -0.5, -math.pi], [0.5, 0.5, math.pi])
        xyz, quat, map_xyz, map_quat = odom.update(t, position, rpy, rng.uniform(-5, 5), rng.uniform(-1, 1))
        r_map, r_odom = Rotation.from_quat(map_quat), Rotation.from_quat(quat)
        assert np.allclose(r_map.apply(xyz) + map_xyz, position, rtol=0, atol=1e-12 * 1e3)
        assert np.allclose((r_map * r_odom).as_matrix(), Rotation.from_euler("ZYX", rpy[::-1]).as_matrix(),
                           rtol=0, atol=1e-12)
        assert np.allclose(r_odom.as_matrix(), Rotation.from_euler("ZYX", [odom.yaw, rpy[1], rpy[0]]).as_matrix(),
                           rtol=0, atol=1e-12)


def test_matrix_from_quaternion_is_scipys_bit_for_bit():
    """The mount rotation without scipy: the same bits as Rotation.from_quat(q).as_matrix(), unnormalised too."""
    rng = np.random.default_rng(11)
    quats = [q * s for q, s in zip(rng.normal(size=(3000, 4)), 10.0 ** rng.uniform(-3, 3, 3000))]
    quats += [np.array([0.0, 0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0, 0.0]), np.array([0.0, 0.0, -0.0, -1.0])]
    for q in quats:
        assert np.array_equal(matrix_from_quaternion(q), Rotation.from_quat(q).as_matrix()), q
