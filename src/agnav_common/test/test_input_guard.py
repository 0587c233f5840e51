"""Input guard rules: stream time, covariances, windowed counters."""
import math

import numpy as np

from agnav_common.input_guard import EventWindow, StreamClock, StreamClockSettings, covariance


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


def test_event_window_describes_the_present():
    w = EventWindow(window=10.0)
    w.add("bad_stamp", 100.0)
    assert w.recent(105.0) == {"bad_stamp": 1}
    assert w.recent(111.0) == {}
    assert w.totals == {"bad_stamp": 1}
