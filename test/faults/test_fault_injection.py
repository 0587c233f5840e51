"""Bag mutator (agnav_sim_eval.fault_injection) on small bags, the fault bench's diagnostics rule, and one short
graph run of the bench (gds, magnetometer NaN)."""
import math

import numpy as np
import pytest
from geometry_msgs.msg import TwistWithCovarianceStamped
from rosbags.rosbag2 import Reader
from sensor_msgs.msg import Imu, MagneticField, NavSatFix

from agnav_sim_eval.fault_injection import FaultCase, mutate_bag
from agnav_common.bagio import typestore
from agnav_common.geodesy import LocalTangentPlane
from agnav_common.stamps import to_stamp
from test.foundation.bagmaker import write_bag

T0 = 1_700_000_000.0
IMU, FIX, VEL, MAG = "/imu/data_raw", "/gnss/fix", "/gnss/vel", "/imu/mag"


def _messages():
    """5 s: IMU and magnetometer at 10 Hz, fix and velocity at 1 Hz; header stamp = log time."""
    rng = np.random.default_rng(7)
    out = []
    for k in range(50):
        t = T0 + 0.1 * k
        imu = Imu()
        imu.header.stamp = to_stamp(t)
        imu.angular_velocity.x, imu.angular_velocity.y, imu.angular_velocity.z = (float(v) for v in rng.normal(0, 0.01, 3))
        out.append((IMU, "sensor_msgs/msg/Imu", int(round(t * 1e9)), imu))
        mag = MagneticField()
        mag.header.stamp = to_stamp(t)
        mag.magnetic_field.x, mag.magnetic_field.y, mag.magnetic_field.z = 20e-6, 5e-6, -40e-6
        out.append((MAG, "sensor_msgs/msg/MagneticField", int(round(t * 1e9)), mag))
        if k % 10 == 0:
            fix = NavSatFix()
            fix.header.stamp = to_stamp(t)
            fix.status.status = 0  # STATUS_FIX
            fix.latitude, fix.longitude, fix.altitude = 43.07 + k * 1e-6, 141.34, 45.0
            fix.position_covariance = [0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.04]
            out.append((FIX, "sensor_msgs/msg/NavSatFix", int(round(t * 1e9)), fix))
            vel = TwistWithCovarianceStamped()
            vel.header.stamp = to_stamp(t)
            vel.twist.twist.linear.x = 1.0
            vel.twist.covariance[0] = vel.twist.covariance[7] = vel.twist.covariance[14] = 0.01
            out.append((VEL, "geometry_msgs/msg/TwistWithCovarianceStamped", int(round(t * 1e9)), vel))
    return out


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    return write_bag(tmp_path_factory.mktemp("faults") / "src", _messages())


def _read(path):
    """[(topic, log time ns, message)] in log order."""
    store = typestore()
    with Reader(path) as reader:
        return [(c.topic, t, store.deserialize_cdr(raw, c.msgtype)) for c, t, raw in reader.messages()]


def _stamp(m):
    return m.header.stamp.sec + m.header.stamp.nanosec * 1e-9


def _apply(source, tmp_path, case, crop=None):
    out = tmp_path / f"out_{case.name if case else 'clean'}"
    info = mutate_bag(source, out, case, crop)
    return info, _read(source), _read(out)


def _topic(rows, topic):
    return [(t, m) for name, t, m in rows if name == topic]


def _in(t, a, b):
    return T0 + a - 1e-6 <= t * 1e-9 < T0 + b - 1e-6


def test_nan_gyro_window_only_and_other_topics_untouched(source, tmp_path):
    info, before, after = _apply(source, tmp_path, FaultCase("n", "nan", IMU, t0=1.0, duration=1.0))
    assert info["hit"] == 10 and info["start"] == pytest.approx(T0)
    for (t, a), (_, b) in zip(_topic(before, IMU), _topic(after, IMU)):
        w = b.angular_velocity
        if _in(t, 1.0, 2.0):
            assert all(math.isnan(v) for v in (w.x, w.y, w.z)) and _stamp(a) == _stamp(b)
        else:
            assert (w.x, w.y, w.z) == (a.angular_velocity.x, a.angular_velocity.y, a.angular_velocity.z)
    for topic in (MAG, FIX, VEL):
        assert [(t, _stamp(m)) for t, m in _topic(before, topic)] == [(t, _stamp(m)) for t, m in _topic(after, topic)]
    times = [t for _, t, _ in after]
    assert times == sorted(times) and len(after) == len(before)


@pytest.mark.parametrize("kind,topic", [("inf", FIX), ("nan", VEL)])
def test_value_faults_on_gnss(source, tmp_path, kind, topic):
    _, _, after = _apply(source, tmp_path, FaultCase("v", kind, topic, t0=2.0, duration=2.0))
    for t, m in _topic(after, topic):
        values = (m.latitude, m.longitude) if topic == FIX else (m.twist.twist.linear.x, m.twist.twist.linear.y)
        assert all(not math.isfinite(v) for v in values) == _in(t, 2.0, 4.0)


@pytest.mark.parametrize("kind,topic", [("zero_cov", FIX), ("negative_cov", FIX), ("zero_cov", VEL),
                                        ("negative_cov", VEL)])
def test_covariance_faults(source, tmp_path, kind, topic):
    _, _, after = _apply(source, tmp_path, FaultCase("c", kind, topic, t0=1.0, duration=2.0))
    for t, m in _topic(after, topic):
        cov, diag = (m.position_covariance, (0, 4, 8)) if topic == FIX else (m.twist.covariance, (0, 7, 14))
        if not _in(t, 1.0, 3.0):
            assert all(cov[i] > 0 for i in diag)
        elif kind == "zero_cov":
            assert not np.any(cov)
        else:
            assert all(cov[i] < 0 for i in diag)


@pytest.mark.parametrize("kind,amount,expect", [("future_stamp", 1000.0, 1000.0), ("backwards_stamp", 1.5, -1.5)])
def test_single_message_stamp_shift(source, tmp_path, kind, amount, expect):
    info, before, after = _apply(source, tmp_path, FaultCase("s", kind, FIX, t0=1.5, amount=amount))
    assert info["hit"] == 1
    shifts = [_stamp(b) - _stamp(a) for (_, a), (_, b) in zip(_topic(before, FIX), _topic(after, FIX))]
    assert shifts[2] == pytest.approx(expect, abs=1e-6)   # the fix at 2.0 s: the first at or after 1.5 s
    assert shifts[:2] + shifts[3:] == [0.0] * (len(shifts) - 1)
    assert [t for t, _ in _topic(after, FIX)] == [t for t, _ in _topic(before, FIX)]  # log time kept


def test_zero_stamps_and_duplicates(source, tmp_path):
    _, _, after = _apply(source, tmp_path, FaultCase("z", "zero_stamp", IMU, t0=1.0, duration=0.5))
    zero = [t for t, m in _topic(after, IMU) if _stamp(m) == 0.0]
    assert len(zero) == 5 and all(_in(t, 1.0, 1.5) for t in zero)
    info, before, after = _apply(source, tmp_path, FaultCase("d", "duplicate", IMU, t0=1.0, duration=1.0))
    imu = _topic(after, IMU)
    assert len(imu) == len(_topic(before, IMU)) + 10 == len(_topic(before, IMU)) + info["hit"]
    stamps = [_stamp(m) for _, m in imu]
    assert len(set(stamps)) == 50 and [t for _, t, _ in after] == sorted(t for _, t, _ in after)


def test_gap_and_outage(source, tmp_path):
    _, before, after = _apply(source, tmp_path, FaultCase("g", "drop", IMU, t0=1.0, duration=0.6))
    t = np.array([t for t, _ in _topic(after, IMU)]) * 1e-9
    assert len(t) == 44 and np.diff(t).max() == pytest.approx(0.7, abs=1e-6)
    _, _, after = _apply(source, tmp_path, FaultCase("o", "drop", FIX, t0=1.0, duration=3.0, also=(VEL,)))
    for topic in (FIX, VEL):
        assert [round(t * 1e-9 - T0, 3) for t, _ in _topic(after, topic)] == [0.0, 4.0]
    assert len(_topic(after, IMU)) == len(_topic(before, IMU))


def test_stuck_repeats_last_sample_with_current_stamps(source, tmp_path):
    _, before, after = _apply(source, tmp_path, FaultCase("k", "stuck", IMU, t0=2.0, duration=1.0))
    last = next(m for t, m in reversed(_topic(before, IMU)) if t * 1e-9 < T0 + 2.0 - 1e-6)
    for (t, a), (_, b) in zip(_topic(before, IMU), _topic(after, IMU)):
        assert _stamp(a) == _stamp(b)
        if _in(t, 2.0, 3.0):
            assert b.angular_velocity.z == last.angular_velocity.z != a.angular_velocity.z


def test_step_and_no_fix(source, tmp_path):
    _, before, after = _apply(source, tmp_path, FaultCase("s", "step", FIX, t0=1.0, duration=2.0, amount=5.0))
    for (t, a), (_, b) in zip(_topic(before, FIX), _topic(after, FIX)):
        e, n, _ = LocalTangentPlane(a.latitude, a.longitude, a.altitude).to_enu(b.latitude, b.longitude, b.altitude)
        assert (float(e), float(n)) == pytest.approx((0.0, 5.0 if _in(t, 1.0, 3.0) else 0.0), abs=1e-6)
    _, _, after = _apply(source, tmp_path, FaultCase("x", "no_fix", FIX, t0=1.0, duration=2.0))
    bad = [(m.status.status, m.latitude, m.longitude) for t, m in _topic(after, FIX) if _in(t, 1.0, 3.0)]
    assert bad == [(-1, 0.0, 0.0)] * 2
    assert all(m.status.status == 0 for t, m in _topic(after, FIX) if not _in(t, 1.0, 3.0))


def test_magnetic_offset_and_rotation(source, tmp_path):
    _, _, after = _apply(source, tmp_path, FaultCase("m", "mag_offset", MAG, t0=1.0, duration=1.0, amount=20e-6))
    xs = {_in(t, 1.0, 2.0): m.magnetic_field.x for t, m in _topic(after, MAG)}
    assert xs[True] - xs[False] == pytest.approx(20e-6)
    _, _, after = _apply(source, tmp_path, FaultCase("r", "mag_rotate", MAG, t0=1.0, duration=1.0, amount=10.0))
    for t, m in _topic(after, MAG):
        f = m.magnetic_field
        assert math.hypot(f.x, f.y) == pytest.approx(math.hypot(20e-6, 5e-6)) and f.z == -40e-6
        turn = math.degrees(math.atan2(f.y, f.x) - math.atan2(5e-6, 20e-6))
        assert turn == pytest.approx(10.0 if _in(t, 1.0, 2.0) else 0.0, abs=1e-9)


def test_crop_and_clean_copy(source, tmp_path):
    info, before, after = _apply(source, tmp_path, None, crop=2.0)
    assert info["hit"] == 0 and max(t for _, t, _ in after) * 1e-9 <= T0 + 2.0 + 1e-9
    assert len(after) == sum(1 for _, t, _ in before if t * 1e-9 <= T0 + 2.0 + 1e-9)


def test_unknown_kind_is_an_error():
    with pytest.raises(ValueError, match="unknown fault kind"):
        FaultCase("bad", "melt", IMU)


def test_diagnostics_rule():
    """Visible: a level above the clean run's, or a value that never changes in the clean run changes."""
    from agnav_sim_eval.bench.faults import detected
    clean = [(100.0 + k, {"n: inputs": (0, {"bad": "0", "received": str(k)}), "c: x": (1, {})}) for k in range(5)]
    same = [(t, {n: (lvl, dict(v)) for n, (lvl, v) in st.items()}) for t, st in clean]
    assert detected(same, clean, 100.5) is None  # counters that always move and a WARN the clean run has too
    counter = [(t, {**st, "n: inputs": (0, {"bad": "3" if t >= 102 else "0", "received": "9"})}) for t, st in clean]
    assert detected(counter, clean, 101.5) == pytest.approx(0.5)
    warn = [(t, {**st, "n: inputs": (1 if t >= 103 else 0, st["n: inputs"][1])}) for t, st in clean]
    assert detected(warn, clean, 102.2) == pytest.approx(0.8)


def test_repeat_bag_shifts_log_times_and_stamps(source, tmp_path):
    from agnav_sim_eval.fault_injection import repeat_bag
    before = _read(source)
    seconds = repeat_bag(source, tmp_path / "long", 3, once=(VEL,))
    after = _read(tmp_path / "long")
    period = 4.9 + 0.01
    assert seconds == pytest.approx(3 * period)
    assert len(_topic(after, VEL)) == len(_topic(before, VEL)) and len(_topic(after, IMU)) == 3 * 50
    for topic in (IMU, FIX):
        t = np.array([t * 1e-9 for t, _ in _topic(after, topic)])
        stamps = np.array([_stamp(m) for _, m in _topic(after, topic)])
        assert np.allclose(stamps, t, atol=1e-6) and np.all(np.diff(t) > 0)  # header stamps follow the log time
        assert t[-1] - T0 == pytest.approx(2 * period + 4.9 if topic == IMU else 2 * period + 4.0, abs=1e-6)
    last = _topic(after, IMU)[-1][1]
    assert last.angular_velocity.z == _topic(before, IMU)[-1][1].angular_velocity.z


def test_gds_graph_magnetometer_nan_case():
    """One case through the shipped gds graph as the bench runs it: the runner survives a second of NaN fields,
    publishes no NaN, keeps its output going and counts the rejected samples on /diagnostics within 1 s."""
    import os

    from agnav_sim_eval.bench.faults import run
    results, cleans = run(["gds"], {"mag_nan"}, int(os.environ["ROS_DOMAIN_ID"]))
    (clean,), (r,) = cleans, results
    assert clean["rc"] == 0 and clean["outputs"] > 500
    assert r["case"] == "mag_nan" and r["hit"] == 15 and r["rc"] == 0
    assert r["nan_outputs"] == 0 and r["gap_ok"] and r["stamps_ok"]
    assert r["detected_ok"] and r["detected_after_s"] <= 1.0
