"""Offline closed loop in the simulator (sensor samples -> agnav_fusion NavSensorModule / VWA -> controller), never fed truth."""
import numpy as np
import pytest
from agnav_sim_eval.closed_loop import ClosedLoopSettings, run


# the thesis' operator: 3 m manual from standstill, then the engage request (granted once the fusion has converged)
RTK = dict(scenario="rtk_straight_fast", manual_distance=3.0)


def test_rtk_fast_run_stays_on_line():
    tilt = run(ClosedLoopSettings(seed=3, controller="pid", auto_distance=80.0, **RTK))
    assert tilt.along[-1] >= 80.0 and tilt.disengaged is None
    assert tilt.max_abs < 0.15       # within the thesis' ±10 cm practical band plus margin at 4.3 m/s
    assert np.all(np.isfinite(tilt.steering))
    # the controller acts on estimates, not on truth
    assert not np.allclose(tilt.cross_track, tilt.estimated)


def test_the_routes_final_stop_ends_the_run_without_a_disengage():
    """An auto distance longer than the route: the run ends where the driver brakes for the route's end (the
    watchdog's low-speed disengage there is the stop, not a fault)."""
    r = run(ClosedLoopSettings(seed=3, controller="pid", auto_distance=1000.0, **RTK))
    assert r.disengaged is None and 80.0 <= r.along[-1] < 1000.0


def test_converges_from_offset_line():
    r = run(ClosedLoopSettings(seed=4, controller="stanley", line_offset=0.5, auto_distance=60.0, **RTK))
    assert abs(r.cross_track[0]) == pytest.approx(0.5, abs=0.1)
    assert r.settling_distance(0.1) < 40.0
    assert np.max(np.abs(r.cross_track[r.along > 40.0])) < 0.1


def test_gds_vwa_run_with_thesis_law():
    r = run(ClosedLoopSettings(scenario="gds_straight_slow", seed=1, controller="thesis_pi",
                               manual_distance=5.0, auto_distance=35.0))
    assert r.along[-1] > 30.0
    assert r.max_abs < 0.2


DGPS_SLOPE = dict(scenario="dgps_slope_crab", manual_distance=3.0, auto_distance=60.0)


def test_perfect_state_crab_feed_forward_leaves_no_mean_offset():
    ff = run(ClosedLoopSettings(seed=1, estimator="truth", **DGPS_SLOPE))
    blind = run(ClosedLoopSettings(seed=1, estimator="truth", crab_feed_forward=False, **DGPS_SLOPE))
    assert abs(ff.mean) < 0.01 and ff.disengaged is None
    assert blind.mean < -0.02  # the unseen 1.5 deg crab: downhill (right) until the integral holds it


def test_dgps_tractor_engages_on_default_gates():
    r = run(ClosedLoopSettings(seed=1, **DGPS_SLOPE))
    assert r.disengaged is None and r.engaged_at < 20.0 and r.along[-1] >= 60.0
    assert r.rms < 0.12
