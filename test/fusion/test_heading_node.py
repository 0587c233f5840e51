"""heading_node: the estimator core on synthetic streams, then the rclpy node end to end."""
import math

import numpy as np
import pytest

from agnav_fusion.geomagnetic_model import MagneticModel
from agnav_fusion.heading_estimators import ESTIMATORS, EstimatorSettings, HeadingEstimator
from synthetic_heading import rms_deg, straight_run

SITE = (43.07, 141.34, 45.0)


@pytest.mark.parametrize("name,bias", [("gds_kf", 0.005), ("vwa", 0.005), ("gds_gyro_lsm", 0.1)])
def test_gds_estimators_beat_the_gds(name, bias):
    """Ch. II estimators with a FOG-grade drift, the Ch. III LSM with a vibratory-gyro drift."""
    run = straight_run(seed=21, duration=90.0, dt=0.02, bias_deg_s=bias)
    est = HeadingEstimator(EstimatorSettings(estimator=name, imu_rate_hz=50.0))
    out = []
    for k, t in enumerate(run.t):
        for o in (est.on_gyro(t, run.gyro_rate[k], run.dt), est.on_gds(t, float(run.gds[k]))):
            if o is not None:
                out.append(o)
    t, h, var = (np.array(c) for c in zip(*out))
    late = t > 30.0
    truth = np.interp(t[late], run.t, run.true)
    err = rms_deg(h[late] - truth)
    assert err < 0.6 * rms_deg(run.gds - run.true)
    assert np.all(np.isfinite(var)) and np.all(var > 0)


def test_gnss_estimator_anchors_the_gyro_to_the_track():
    run = straight_run(seed=22, duration=120.0, dt=0.02, bias_deg_s=0.05, offset_deg=0.0)
    rng = np.random.default_rng(0)
    xy = np.cumsum(0.5 * run.dt * np.column_stack([np.sin(run.true), np.cos(run.true)]), axis=0)
    est = HeadingEstimator(EstimatorSettings(estimator="gnss_gyro_lsm"))
    out = []
    for k, t in enumerate(run.t):
        o = est.on_gyro(t, run.gyro_rate[k], run.dt)
        if o is not None:
            out.append(o)
        if k % 50 == 0 and k > 0:
            x, y = xy[k] + rng.normal(0, 0.02, 2)
            est.on_fix(t, x, y, 0.02**2)
    t, h, _ = (np.array(c) for c in zip(*out))
    late = t > 60.0
    assert rms_deg(h[late] - np.interp(t[late], run.t, run.true)) < 1.0
    assert set(ESTIMATORS) == {"gds_kf", "vwa", "gds_gyro_lsm", "gnss_gyro_lsm"}


def _field_flu(heading, declination, expected, scale=1.0):
    """Level body (FLU) field for a true heading (clockwise from north)."""
    mag = heading - declination
    h, z = expected.horizontal * scale, -expected.total * math.sin(expected.inclination) * scale
    return np.array([h * math.cos(mag), h * math.sin(mag), z])    # thesis (−H sin φ, H cos φ) -> FLU (y_f, −x_r)


def test_node_publishes_heading_and_guards_inputs(ros):
    from agnav_common.diagnostics import WARN
    from agnav_common.stamps import to_stamp
    from agnav_fusion.heading_node import HeadingNode
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import Imu, MagneticField

    node = HeadingNode(parameter_overrides=[
        Parameter("estimator", value="vwa"), Parameter("tilt_source", value="none"),
        Parameter("declination_site", value=list(SITE)), Parameter("wmm_fallback_year", value=2025.0),
        Parameter("vwa.window", value=2.0), Parameter("vwa.interval", value=0.5)])
    client = ros.create_node("heading_test_client")
    got = []
    client.create_subscription(Imu, "/heading/imu", got.append, 100)
    pub_gyro = client.create_publisher(Imu, "/imu/data_raw", 100)
    pub_mag = client.create_publisher(MagneticField, "/imu/mag", 100)
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    ex.add_node(client)
    expected = MagneticModel(fallback_year=2025.0).at_year(*SITE, 2025.0)
    heading = math.radians(30.0)
    rng = np.random.default_rng(3)

    def send(t, field=None, rate=0.0):
        g = Imu()
        g.header.stamp, g.header.frame_id = to_stamp(t), "base_link"
        g.angular_velocity.z = rate
        pub_gyro.publish(g)
        m = MagneticField()
        m.header.stamp, m.header.frame_id = to_stamp(t), "base_link"
        f = field if field is not None else _field_flu(heading + rng.normal(0, 0.005), expected.declination,
                                                       expected)
        m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z = (float(v) for v in f)
        pub_mag.publish(m)
        for _ in range(6):
            ex.spin_once(timeout_sec=0.01)

    for k in range(1, 200):
        send(100.0 + 0.05 * k)
    assert got, "no /heading/imu published"
    from agnav_common.frames import euler_from_quaternion
    q = got[-1].orientation
    yaw = euler_from_quaternion(q.x, q.y, q.z, q.w)[2]
    assert math.degrees(yaw) == pytest.approx(90.0 - 30.0, abs=0.5)     # ENU yaw = π/2 − φ
    assert 0.0 < got[-1].orientation_covariance[8] < math.radians(2.0) ** 2
    assert got[-1].header.frame_id == "base_link"

    send(110.0, field=np.array([math.nan, 0.0, 0.0]))                  # NaN input
    send(109.0)                                                         # backwards stamp
    assert node.rejected["non-finite"] >= 1 and node.rejected["stamp"] >= 2
    assert not node.disturbed
    send(110.1, field=_field_flu(heading, expected.declination, expected, scale=1.4))
    assert node.disturbed and node._diagnose()[0] == WARN
    assert all(math.isfinite(m.orientation.z) for m in got)
    ex.shutdown()
    node.destroy_node()
    client.destroy_node()
