"""Input guard rules: stream time, covariances, windowed counters."""
import math

import numpy as np

from agnav_common.input_guard import EventWindow, StreamClock, StreamClockSettings, covariance, _clearly_fine3


def test_lone_future_stamp_is_rejected_and_never_moves_the_clock():
    clock = StreamClock()
    stamps = [1.0 + 0.01 * i for i in range(100)]
    assert all(clock.check(t) is None for t in stamps[:50])
    assert clock.check(1000.0) == "future_stamp"
    assert all(clock.check(t) is None for t in stamps[50:])
    assert clock.last == stamps[-1]


def test_a_real_jump_is_accepted_once_confirmed():
    clock = StreamClock(StreamClockSettings(max_jump=1.0, confirm=2))
    assert clock.check(10.0) is None
    assert [clock.check(t) for t in (20.0, 20.1, 20.2)] == ["future_stamp", "future_stamp", None]
    assert clock.last == 20.2


def test_a_jump_the_reference_clock_vouches_for_is_taken_at_once():
    """A receiver back after a 20 s outage, its stamps on the IMU clock: no fix is held back for confirmation. Without
    a lead bound the reference does not vouch for the future, and a jump waits for its confirmation as before (as
    without `vouch`)."""
    clock = StreamClock(StreamClockSettings(max_jump=1.0, max_lead=0.5, vouch=True))
    assert clock.check(10.0, ref=10.1) is None
    assert clock.check(30.0, ref=30.1) is None and clock.last == 30.0
    assert clock.check(1000.0, ref=30.2) == "stamp_off_reference"
    unbounded = StreamClock(StreamClockSettings(max_jump=1.0, confirm=2, vouch=True))
    assert unbounded.check(10.0, ref=10.1) is None
    assert [unbounded.check(t, ref=t) for t in (30.0, 30.1, 30.2)] == ["future_stamp", "future_stamp", None]


def test_bad_backwards_and_off_reference_stamps():
    clock = StreamClock(StreamClockSettings(max_lag=2.0, max_lead=0.5))
    assert clock.check(0.0) == "bad_stamp"
    assert clock.check(math.nan) == "bad_stamp"
    assert clock.check(5.0, ref=5.2) is None
    assert clock.check(4.0, ref=5.2) == "backwards_stamp"
    assert clock.check(6.0, ref=5.2) == "stamp_off_reference"
    assert clock.check(5.1, ref=8.0) == "stamp_off_reference"


def test_covariance_rules():
    assert covariance(np.diag([1.0, -1.0]))[1] == "negative_covariance"
    assert covariance(np.diag([1.0, math.nan]))[1] == "nan_covariance"
    assert covariance([[1.0, 2.0], [2.0, 1.0]])[1] == "indefinite_covariance"
    c, problem = covariance(np.zeros((2, 2)), floor_var=1e-4)
    assert problem == "floored_covariance" and np.allclose(c, 1e-4 * np.eye(2))
    c, problem = covariance([[1.0, 0.2], [0.0, 1.0]])
    assert problem is None and np.allclose(c, c.T)


def test_the_3x3_float_path_gives_the_general_paths_result():
    """covariance() of a 3x3 that _clearly_fine3 passes equals the array path's (bit for bit), on random, nearly
    singular, indefinite, non-finite and badly scaled matrices."""
    rng, fast = np.random.default_rng(7), 0
    for i in range(6000):
        a = rng.normal(size=(3, 3)) * 10.0 ** rng.uniform(-4, 3, size=(1, 3))
        m = [a @ a.T, a @ a.T + rng.normal(size=(3, 3)) * 10.0 ** rng.uniform(-9, -3), np.diag(rng.uniform(-1e-3, 1, 3)),
             np.outer(a[0], a[0]) + np.diag(rng.uniform(0, 1e-9, 3)), np.diag(10.0 ** rng.uniform(-8, 8, 3))][i % 5]
        if i % 7 == 0:
            m[rng.integers(0, 3), rng.integers(0, 3)] = (math.nan, math.inf, 0.0)[i % 3]
        floor = (0.0, 1e-4, 1e-2)[i % 3]
        fast += _clearly_fine3(m.tolist(), floor) is not None
        c, problem = covariance(m, floor)
        c0 = np.array(m, dtype=float)  # the array path, as covariance() runs it for other shapes
        c0 = (c0 + c0.T) / 2
        d = np.diag(c0)
        if not np.all(np.isfinite(c0)) or np.any(d < 0):
            assert c is None
            continue
        floored = bool(np.any(d < floor))
        if floored:
            c0[np.diag_indices_from(c0)] = np.maximum(d, floor)
        if np.linalg.eigvalsh(c0)[0] < -1e-9 * max(float(np.max(np.diag(c0))), 1e-12):
            assert c is None
            continue
        assert problem == ("floored_covariance" if floored else None)
        assert c.tobytes() == c0.tobytes() and c.shape == (3, 3)
    assert fast > 1500


def test_event_window_describes_the_present():
    w = EventWindow(window=10.0)
    w.add("bad_stamp", 100.0)
    assert w.recent(105.0) == {"bad_stamp": 1}
    assert w.recent(111.0) == {}
    assert w.totals == {"bad_stamp": 1}
