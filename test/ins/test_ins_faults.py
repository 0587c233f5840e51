"""ins_node through input faults at t = 100 s of bags/mems_field (agnav_bringup.fault_injection cases, replayed in
one process on the bag's clock by ins_replay): every output within 3 sigma of the truth through and after the
fault, back within 10 cm of the clean run at most 10 s after it, the output stream never lost, the fault on the
diagnostics within 1 s and gone again some seconds after it, published covariances symmetric positive-definite."""
import math

import numpy as np
import pytest

pytest.importorskip("rclpy")

from agnav_bringup.fault_injection import FaultCase  # noqa: E402
from agnav_common.diagnostics import OK  # noqa: E402
from ins_replay import bag_messages, replay, with_fault, yaw_errors  # noqa: E402

T0, END = 100.0, 116.0            # fault start, replay end [s after the bag start]
FROM = T0 - 5.0                   # outputs checked from here
IMU, FIX, VEL = "/imu/data_raw", "/gnss/fix", "/gnss/vel"


def case(name, kind, topic, duration=0.0, amount=0.0):
    return FaultCase(name, kind, topic, T0, duration, amount)


CASES = [
    case("imu_zero_stamp_x10", "zero_stamp", IMU, 0.095),      # ten samples
    case("imu_gyro_nan_1.5s", "nan", IMU, 1.5),
    case("imu_gap_2s", "drop", IMU, 2.0),
    case("imu_stale_2s", "backwards_stamp", IMU, 2.0, 2.0),  # 2 s old stamps: all rejected
    case("imu_future_stamp_1000s", "future_stamp", IMU, 0.0, 1000.0),
    case("fix_future_stamp_1000s", "future_stamp", FIX, 0.0, 1000.0),
    case("fix_cov_negative", "negative_cov", FIX, 3.0),
    case("fix_cov_zero", "zero_cov", FIX, 3.0),
    case("vel_cov_negative", "negative_cov", VEL, 3.0),
    case("vel_cov_zero", "zero_cov", VEL, 3.0),
    case("fix_no_fix_3s", "no_fix", FIX, 3.0),
]


@pytest.fixture(scope="module")
def messages():
    return bag_messages(END)


@pytest.fixture(scope="module")
def rclpy_module():
    """One rclpy context for the module's replays (nodes are only created, never spun)."""
    import rclpy
    rclpy.init()
    try:
        yield rclpy
    finally:
        rclpy.try_shutdown()


@pytest.fixture(scope="module")
def clean(rclpy_module, messages):
    run = replay(messages, publish_from=FROM)
    run.node.destroy_node()
    return run


def positive_definite(values, n=6):
    c = np.array(values).reshape(n, n)
    return np.array_equal(c, c.T) and np.all(np.linalg.eigvalsh(c) > 0)


def test_clean_replay_is_consistent_and_quiet(clean):
    """The reference: within 3 sigma, every diagnostic OK around the fault time."""
    assert all(abs(e[0]) <= 3 * math.sqrt(c[0, 0]) and abs(e[1]) <= 3 * math.sqrt(c[1, 1])
               for _, e, c in clean.series(FROM))
    assert all(d[name][0] == OK for t, d in clean.diagnostics if t >= FROM for name in d)


@pytest.mark.parametrize("fault", CASES, ids=[c.name for c in CASES])
def test_ins_node_rides_through_the_fault(rclpy_module, messages, clean, fault):
    run = replay(with_fault(messages, fault), publish_from=FROM)
    run.node.destroy_node()
    # the output stream goes on: no gap beyond the IMU's own, up to the end
    rows = run.series(FROM)
    t = np.array([r[0] for r in rows])
    input_gap = fault.duration if fault.topic == IMU else 0.0
    assert t[-1] > END - 0.1 and np.diff(t).max() <= input_gap + 0.1
    # honest: every output within 3 sigma (east, north, yaw), covariances symmetric positive-definite
    for _, e, c in rows:
        assert abs(e[0]) <= 3 * math.sqrt(c[0, 0]) and abs(e[1]) <= 3 * math.sqrt(c[1, 1]), (fault.name, _, e)
    assert all(abs(e) <= 3 * s for _, e, s in yaw_errors(run, FROM))
    assert all(positive_definite(o.pose.covariance) and positive_definite(o.twist.covariance) for o in run.odom)
    # back on the clean run at most 10 s after the fault ends
    ref, got = clean.positions(), run.positions()
    late = [k for k in got if k >= fault.end + 10.0 and k in ref]
    assert late and max(np.linalg.norm(got[k] - ref[k]) for k in late) <= 0.10
    # visible within 1 s (a diagnostic not OK), OK again some seconds after the fault
    seen = [t for t, d in run.diagnostics if T0 < t <= T0 + 1.0 and any(s[0] != OK for s in d.values())]
    assert seen, f"{fault.name} not on the diagnostics within 1 s"
    final = run.diagnostics[-1]
    assert final[0] >= fault.end + 8.0 and final[1]["inputs"][0] == OK, final
