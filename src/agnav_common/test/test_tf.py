"""TfBuffer composes transforms along the TF tree: base_link -> mast -> gnss_link (a URDF chain), both ways."""
import math
import time

import numpy as np
from builtin_interfaces.msg import Time
from tf2_msgs.msg import TFMessage

from agnav_common.frames import quaternion_from_euler, rotation_matrix
from agnav_common.tf import StaticTransformPublisher, TfBuffer, make_transform

MAST = ([0.4, -0.1, 1.5], (0.0, 0.0, math.pi / 2))      # base_link -> mast: 1.5 m up, turned 90 deg left
ANTENNA = ([0.2, 0.0, 0.6], (math.radians(10), 0.0, 0.0))  # mast -> gnss_link: tilted 10 deg about x
IMU = ([1.0, 0.0, 0.8], (0.0, math.radians(-5), 0.0))     # base_link -> imu_link


def tf(parent, child, mount):
    return make_transform(parent, child, Time(), mount[0], quaternion_from_euler(*mount[1]))


def homogeneous(mount):
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = rotation_matrix(*mount[1]), mount[0]
    return m


def as_matrix(found):
    xyz, q = found
    x, y, z, w = q
    m = np.eye(4)
    m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    m[:3, 3] = xyz
    return m


def chain_buffer():
    buf = TfBuffer()
    buf.add(TFMessage(transforms=[tf("mast", "gnss_link", ANTENNA), tf("base_link", "imu_link", IMU)]))
    buf.add(TFMessage(transforms=[tf("base_link", "mast", MAST)]))
    return buf


def test_rotation_matrix_convention_matches_quaternions():
    assert np.allclose(as_matrix((np.zeros(3), quaternion_from_euler(*ANTENNA[1])))[:3, :3],
                       rotation_matrix(*ANTENNA[1]))


def test_base_link_to_gnss_link_through_the_mast():
    found = chain_buffer().lookup("base_link", "gnss_link")
    expected = homogeneous(MAST) @ homogeneous(ANTENNA)
    assert np.allclose(as_matrix(found), expected, atol=1e-12)
    # by hand: the mast turned 90 deg left puts the antenna's 0.2 m forward offset 0.2 m to the left
    assert np.allclose(found[0], [0.4, 0.1, 2.1])
    assert np.isclose(np.linalg.norm(found[1]), 1.0)


def test_inverse_direction_gnss_link_to_base_link():
    buf = chain_buffer()
    back = buf.lookup("gnss_link", "base_link")
    assert np.allclose(as_matrix(back), np.linalg.inv(homogeneous(MAST) @ homogeneous(ANTENNA)), atol=1e-12)
    assert np.allclose(as_matrix(back) @ as_matrix(buf.lookup("base_link", "gnss_link")), np.eye(4), atol=1e-12)
    assert np.allclose(as_matrix(buf.lookup("mast", "base_link")), np.linalg.inv(homogeneous(MAST)), atol=1e-12)


def test_between_siblings_through_the_common_parent():
    found = chain_buffer().lookup("imu_link", "gnss_link")
    expected = np.linalg.inv(homogeneous(IMU)) @ homogeneous(MAST) @ homogeneous(ANTENNA)
    assert np.allclose(as_matrix(found), expected, atol=1e-12)


def test_direct_edge_is_returned_exactly_and_mounts_wait_for_every_frame():
    buf = TfBuffer()
    assert buf.lookup_mounts("base_link", "imu_link", "gnss_link") is None
    buf.add(TFMessage(transforms=[tf("base_link", "imu_link", IMU)]))
    xyz, q = buf.lookup("base_link", "imu_link")
    assert xyz.tolist() == IMU[0] and q.tolist() == list(quaternion_from_euler(*IMU[1]))
    assert buf.lookup_mounts("base_link", "imu_link", "gnss_link") is None
    assert buf.lookup("base_link", "gnss_link") is None and buf.lookup("gnss_link", "base_link") is None
    buf.add(TFMessage(transforms=[tf("base_link", "mast", MAST), tf("mast", "gnss_link", ANTENNA)]))
    imu, gnss = buf.lookup_mounts("base_link", "imu_link", "gnss_link")
    assert np.allclose(gnss[0], [0.4, 0.1, 2.1])
    same = buf.lookup("gnss_link", "gnss_link")
    assert same[0].tolist() == [0, 0, 0] and same[1].tolist() == [0, 0, 0, 1]


def test_a_moved_edge_replaces_the_old_one_and_a_cycle_does_not_hang():
    buf = chain_buffer()
    buf.add(TFMessage(transforms=[tf("base_link", "mast", ([0.0, 0.0, 3.0], (0.0, 0.0, 0.0)))]))
    assert np.allclose(buf.lookup("base_link", "gnss_link")[0], [0.2, 0.0, 3.6])
    buf.add(TFMessage(transforms=[tf("gnss_link", "base_link", IMU)]))  # bad data: base_link under gnss_link
    assert buf.lookup("base_link", "unknown_link") is None


def test_a_node_resolves_the_chain_published_on_tf_static(ros):
    pub_node, sub_node = ros.create_node("urdf_publisher"), ros.create_node("tf_reader")
    StaticTransformPublisher(pub_node).send([tf("base_link", "mast", MAST), tf("mast", "gnss_link", ANTENNA)])
    buf = TfBuffer(sub_node)
    executor = ros.executors.SingleThreadedExecutor()
    executor.add_node(pub_node)
    executor.add_node(sub_node)
    deadline = time.monotonic() + 10.0
    while buf.lookup("base_link", "gnss_link") is None and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.1)
    assert np.allclose(buf.lookup("base_link", "gnss_link")[0], [0.4, 0.1, 2.1])
