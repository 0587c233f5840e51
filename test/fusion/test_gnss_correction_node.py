"""rclpy test of gnss_correction_node: the corrected fix of a known tilted pose is the antenna minus R(rpy) lever."""
import math
import time

import numpy as np
import pytest

pytest.importorskip("rclpy")

from agnav_common.frames import quaternion_from_euler  # noqa: E402
from agnav_common.geodesy import LocalTangentPlane  # noqa: E402
from agnav_common.stamps import to_stamp  # noqa: E402
from agnav_common.tf import StaticTransformPublisher, make_transform  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

DATUM = (43.07, 141.34, 45.0)
LEVER = (0.0, -1.67, 3.23)            # base_link -> gnss_link (R4-7/8 antenna), FLU m
RPY = (math.radians(6.0), math.radians(-4.0), math.radians(120.0))  # REP-103: right side down, nose up, yaw


def spin(ex, n=20):
    for _ in range(n):
        ex.spin_once(timeout_sec=0.01)


def run_node(ros, fixes, odom_stamps, status=None, cov=(1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 4e-4), cov_type=None):
    from nav_msgs.msg import Odometry
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import NavSatFix, NavSatStatus

    from agnav_common.qos import SENSOR_QOS
    from agnav_fusion.gnss_correction_node import GnssCorrectionNode
    from rclpy.parameter import Parameter

    node = GnssCorrectionNode(parameter_overrides=[Parameter("attitude_wait", value=0.5)])
    src = ros.create_node("gnss_correction_test_source")
    got = []
    src.create_subscription(NavSatFix, "/gnss/fix_corrected", got.append, SENSOR_QOS)
    StaticTransformPublisher(src).send(
        [make_transform("base_link", "gnss_link", to_stamp(1.0), LEVER, (0.0, 0.0, 0.0, 1.0))])
    odom_pub = src.create_publisher(Odometry, "/odometry/filtered", SENSOR_QOS)
    fix_pub = src.create_publisher(NavSatFix, "/gnss/fix", SENSOR_QOS)
    ex = SingleThreadedExecutor()
    ex.add_node(src)
    ex.add_node(node)
    spin(ex)
    for t in odom_stamps:
        odom = Odometry()
        odom.header.stamp = to_stamp(t)
        q = odom.pose.pose.orientation
        q.x, q.y, q.z, q.w = quaternion_from_euler(*RPY)
        odom.pose.covariance = list(np.diag([0.01, 0.01, 0.01, 1e-6, 1e-6, 1e-4]).ravel())
        odom_pub.publish(odom)
        spin(ex, 2)
    for t, lat, lon, alt in fixes:
        fix = NavSatFix(latitude=lat, longitude=lon, altitude=alt)
        fix.header.stamp = to_stamp(t)
        fix.status.status = NavSatStatus.STATUS_GBAS_FIX if status is None else status
        fix.position_covariance = [float(v) for v in cov]
        fix.position_covariance_type = NavSatFix.COVARIANCE_TYPE_KNOWN if cov_type is None else cov_type
        fix_pub.publish(fix)
        spin(ex, 5)
    deadline = time.monotonic() + 0.8  # a fix waits up to attitude_wait (0.5 s) for the attitude of its epoch
    while time.monotonic() < deadline:
        spin(ex, 1)
    counts = dict(node.counts)
    ex.shutdown()
    node.destroy_node()
    src.destroy_node()
    return got, counts


def test_corrected_fix_of_a_known_pose(ros):
    plane = LocalTangentPlane(*DATUM)
    base = np.array([10.0, -5.0, 1.0])
    antenna = base + Rotation.from_euler("ZYX", RPY[::-1]).apply(LEVER)  # body FLU -> ENU, independent of the core
    lat, lon, alt = (float(v) for v in plane.to_geodetic(*antenna))
    bad = (200.4, math.nan, lon, alt)
    got, counts = run_node(ros, [(200.0, lat, lon, alt), bad, (199.0, lat, lon, alt)],
                           odom_stamps=[199.9, 200.05])
    assert len(got) == 1, counts
    out = got[0]
    corrected = np.array(plane.to_enu(out.latitude, out.longitude, out.altitude), dtype=float)
    assert np.allclose(corrected, base, atol=1e-3)
    assert np.linalg.norm(antenna[:2] - base[:2]) > 1.0  # the correction is not trivially small
    assert out.header.frame_id == "base_link" and out.header.stamp.sec == 200
    cov = np.array(out.position_covariance).reshape(3, 3)
    assert np.all(np.isfinite(cov)) and cov[0, 0] > 1e-4  # attitude variance through the lever arm is added
    assert counts["bad_value"] == 1 and counts["backwards_stamp"] == 1


def test_fix_without_recent_attitude_is_not_corrected(ros):
    plane = LocalTangentPlane(*DATUM)
    lat, lon, alt = (float(v) for v in plane.to_geodetic(0.0, 0.0, 3.0))
    got, counts = run_node(ros, [(300.0, lat, lon, alt)], odom_stamps=[200.0])
    assert got == [] and counts["no_attitude"] == 1


def test_no_fix_and_unbelievable_covariances_are_not_republished(ros):
    """NO_FIX (lat/lon 0) and NaN or negative covariances never become a corrected position."""
    fixes = [(200.0, 0.0, 0.0, 0.0)]
    got, counts = run_node(ros, fixes, odom_stamps=[199.95], status=-1)
    assert got == [] and counts["no_fix"] == 1
    lat, lon, alt = (float(v) for v in LocalTangentPlane(*DATUM).to_geodetic(0.0, 0.0, 3.0))
    for cov, problem in (((math.nan,) * 9, "nan_covariance"), ((-1e-4, 0, 0, 0, -1e-4, 0, 0, 0, 4e-4),
                                                             "negative_covariance")):
        got, counts = run_node(ros, [(200.0, lat, lon, alt)], odom_stamps=[199.95], cov=cov)
        assert got == [] and counts[problem] == 1


def test_an_unknown_covariance_stays_unknown(ros):
    from sensor_msgs.msg import NavSatFix
    lat, lon, alt = (float(v) for v in LocalTangentPlane(*DATUM).to_geodetic(0.0, 0.0, 3.0))
    got, _ = run_node(ros, [(200.0, lat, lon, alt)], odom_stamps=[199.95], cov=(0.0,) * 9,
                      cov_type=NavSatFix.COVARIANCE_TYPE_UNKNOWN)
    assert len(got) == 1 and got[0].position_covariance_type == NavSatFix.COVARIANCE_TYPE_UNKNOWN


def test_fix_correction_waits_for_the_attitude_of_the_epoch_and_leaves_the_input_alone():
    """FixCorrection (shared by this node and the navigation node, which feeds it its own states): a fix waits until
    the attitude stream passes its epoch, the published fix is a new message in base_link (the input, which other
    subscribers share in one process, keeps its gnss_link header), and a fix whose attitude never comes is counted
    once attitude_wait s of node time have passed."""
    from sensor_msgs.msg import NavSatFix, NavSatStatus

    from agnav_fusion.fix_correction import FixCorrection, FixCorrectionSettings

    plane = LocalTangentPlane(*DATUM)
    base = np.array([3.0, 4.0, 1.0])
    antenna = base + Rotation.from_euler("ZYX", RPY[::-1]).apply(LEVER)
    fix = NavSatFix(latitude=0.0, longitude=0.0, altitude=0.0)
    fix.latitude, fix.longitude, fix.altitude = (float(v) for v in plane.to_geodetic(*antenna))
    fix.header.stamp, fix.header.frame_id = to_stamp(200.0), "gnss_link"
    fix.status.status = NavSatStatus.STATUS_FIX
    fix.position_covariance = [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 4e-4]
    fix.position_covariance_type = NavSatFix.COVARIANCE_TYPE_KNOWN
    out, events, now = [], [], [0.0]
    corr = FixCorrection(FixCorrectionSettings(), "base_link", lambda: LEVER, out.append, events.append,
                         lambda: now[0])
    quat = quaternion_from_euler(*RPY)
    corr.add_attitude(199.99, quat, (1e-6, 1e-6, 1e-4))
    corr.add_fix(fix)
    assert out == [] and len(corr.pending) == 1  # the stream has not reached the epoch yet
    corr.add_attitude(200.01, quat, (1e-6, 1e-6, 1e-4))
    assert len(out) == 1 and events == ["corrected"]
    assert np.allclose(plane.to_enu(out[0].latitude, out[0].longitude, out[0].altitude), base, atol=1e-3)
    assert out[0].header.frame_id == "base_link" and fix.header.frame_id == "gnss_link"
    fix.header.stamp = to_stamp(200.005)  # an epoch the stream has passed: corrected at the next attitude or
    corr.add_fix(fix)                     # process(), never inside add_fix (the state being published goes first)
    assert len(out) == 1 and len(corr.pending) == 1
    corr.process()
    assert len(out) == 2 and events == ["corrected", "corrected"]
    fix.header.stamp = to_stamp(203.0)
    corr.add_fix(fix)
    now[0] = 2.5  # attitude_wait (2 s) of node time without an attitude near 203 s
    corr.process()
    assert events == ["corrected", "corrected", "no_attitude"] and len(out) == 2
