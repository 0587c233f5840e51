import math

from agnav_control.watchdog import OdometrySample, Watchdog, WatchdogSettings, odometry_sample

GOOD = OdometrySample(x=0.0, y=0.0, yaw=0.0, speed=2.0, position_var=0.01**2, yaw_var=0.01**2)


def fed(wd, t0=0.0, n=20, dt=0.01, sample=GOOD):
    for k in range(n):
        wd.odometry(t0 + k * dt, sample)
    return t0 + (n - 1) * dt


def test_engage_requires_request_and_healthy_odometry():
    wd = Watchdog()
    ok, why = wd.request_engage(0.0)
    assert not ok and "no odometry" in why and not wd.engaged
    t = fed(wd)
    assert not wd.engaged  # healthy odometry alone never engages
    ok, _ = wd.request_engage(t)
    assert ok and wd.engaged
    assert [tr.engaged for tr in wd.transitions] == [True]


def test_stale_odometry_disengages_on_timer_and_never_reengages():
    seen = []
    wd = Watchdog(WatchdogSettings(stale_timeout=0.2), on_transition=seen.append)
    t = fed(wd)
    wd.request_engage(t)
    wd.check(t + 0.15)
    assert wd.engaged
    wd.check(t + 0.25)
    assert not wd.engaged and "stale" in seen[-1].reason
    t2 = fed(wd, t0=t + 0.3)
    wd.check(t2 + 0.01)
    assert not wd.engaged and wd.fault is None  # healthy again but stays disengaged
    assert [tr.engaged for tr in seen] == [True, False]


def test_nan_disengages_and_does_not_refresh():
    wd = Watchdog()
    t = fed(wd)
    wd.request_engage(t)
    bad = OdometrySample(float("nan"), 0.0, 0.0, 2.0, 1e-4, 1e-4)
    assert "non-finite" in wd.odometry(t + 0.01, bad)
    assert not wd.engaged
    for k in range(30):  # a stream of NaN is as good as no odometry
        wd.odometry(t + 0.02 + 0.01 * k, bad)
    assert "stale" in wd.check(t + 0.35)


def test_covariance_speed_and_panic_faults():
    s = WatchdogSettings(max_position_std=0.3, min_speed=0.2, panic_deceleration=3.0)
    cases = [
        (OdometrySample(0, 0, 0, 2.0, 0.5**2, 1e-4), "position std"),
        (OdometrySample(0, 0, 0, 2.0, 1e-4, 0.5**2), "yaw std"),
        (OdometrySample(0, 0, 0, 0.1, 1e-4, 1e-4), "speed"),
    ]
    for sample, word in cases:
        wd = Watchdog(s)
        t = fed(wd, sample=OdometrySample(0, 0, 0, 0.3, 1e-4, 1e-4))  # slow enough to stop without panic
        wd.request_engage(t)
        assert word in wd.odometry(t + 0.01, sample) and not wd.engaged
    wd = Watchdog(s)
    t = fed(wd)
    wd.request_engage(t)
    assert wd.engaged
    for k in range(1, 30):  # 5 m/s^2 braking
        wd.odometry(t + 0.01 * k, OdometrySample(0, 0, 0, 2.0 - 0.05 * k, 1e-4, 1e-4))
        if not wd.engaged:
            break
    assert "panic" in wd.transitions[-1].reason
    assert math.isclose(wd.transitions[-1].time, t + 0.01 * k)


def test_refused_when_unhealthy_and_manual_disengage():
    wd = Watchdog()
    t = fed(wd, sample=OdometrySample(0, 0, 0, 0.0, 1e-4, 1e-4))
    ok, why = wd.request_engage(t)
    assert not ok and "speed" in why
    t = fed(wd, t0=t + 0.01)
    assert wd.request_engage(t)[0]
    wd.disengage(t, "operator")
    assert not wd.engaged and wd.transitions[-1].reason == "operator"


def test_engage_waits_for_converged_odometry_but_that_gate_never_disengages():
    wd = Watchdog()
    loose = OdometrySample(x=0.0, y=0.0, yaw=0.0, speed=2.0, position_var=0.1**2, yaw_var=0.05**2)
    t = fed(wd, sample=loose)
    ok, why = wd.request_engage(t)
    assert not ok and "not converged" in why and wd.fault is None
    t = fed(wd, t0=t + 0.01)
    assert wd.request_engage(t)[0]
    t = fed(wd, t0=t + 0.01, sample=loose)  # within the disengage thresholds
    assert wd.engaged


def stamped(stamp, sample=GOOD):
    return OdometrySample(sample.x, sample.y, sample.yaw, sample.speed, sample.position_var, sample.yaw_var, stamp)


def test_old_stamp_refuses_engage_and_trips_on_message_tick_and_request():
    wd = Watchdog(WatchdogSettings(max_stamp_age=0.3, stale_timeout=1.0))
    for k in range(20):  # received in time, measured 2 s earlier
        fault = wd.odometry(0.01 * k, stamped(100.0 + 0.01 * k - 2.0), ref=100.0 + 0.01 * k)
    assert "stamp 2.000 s old" in fault
    ok, why = wd.request_engage(0.2, ref=100.2)
    assert not ok and "old" in why
    for k in range(20, 40):  # fresh stamps (0.1 s latency): engage
        assert wd.odometry(0.01 * k, stamped(100.0 + 0.01 * k - 0.1), ref=100.0 + 0.01 * k) is None
    assert wd.request_engage(0.4, ref=100.4)[0]
    assert "old" in wd.check(0.45, ref=100.75) and not wd.engaged  # timer: the reference ran on, no new stamp
    assert "stamp 0.460 s old" in wd.transitions[-1].reason  # last stamp 100.39 - 0.1
    wd.odometry(0.46, stamped(100.75), ref=100.76)
    assert wd.fault is None and wd.request_engage(0.47, ref=100.8)[0]
    assert "old" in wd.odometry(0.48, stamped(100.4), ref=100.8) and not wd.engaged  # a delayed message
    assert "no clock" in wd.check(0.49, ref=None)  # stamps but no reference: the age is unknown, not healthy


def test_invalid_message_is_a_fault_that_does_not_refresh_the_stream():
    wd = Watchdog(WatchdogSettings(stale_timeout=0.15))
    t = fed(wd)
    wd.request_engage(t)
    assert wd.reject(t + 0.01, "invalid odometry: pose nan covariance") and not wd.engaged
    assert wd.transitions[-1].reason == "invalid odometry: pose nan covariance"
    for k in range(20):
        wd.reject(t + 0.02 + 0.01 * k, "invalid odometry: pose nan covariance")
    assert "stale" in wd.check(t + 0.25)


def covs(pose=None, twist=0.0):
    pose_cov = [0.0] * 36
    pose_cov[0], pose_cov[7], pose_cov[35] = 0.02**2, 0.03**2, 0.01**2
    for i, v in (pose or {}).items():
        pose_cov[i] = v
    return pose_cov, [twist] + [0.0] * 35


def test_odometry_sample_rejects_nan_inf_negative_and_indefinite_covariance():
    sample, problem = odometry_sample(1.0, 2.0, 0.5, 2.0, *covs(), stamp=3.0)
    assert problem is None and sample == OdometrySample(1.0, 2.0, 0.5, 2.0, 0.03**2, 0.01**2, 3.0)
    cases = [({7: math.nan}, 0.0, "pose nan covariance"), ({35: math.inf}, 0.0, "pose nan covariance"),
             ({0: -1e-4}, 0.0, "pose negative covariance"), ({1: 1.0, 6: 1.0}, 0.0, "pose indefinite covariance"),
             (None, math.nan, "twist nan covariance"), (None, -1.0, "twist negative covariance")]
    for pose, twist, reason in cases:
        assert odometry_sample(1.0, 2.0, 0.5, 2.0, *covs(pose, twist)) == (None, reason)
    # unused entries (z, roll, pitch; twist other than vx) are not judged
    assert odometry_sample(1.0, 2.0, 0.5, 2.0, *covs({14: -1.0, 21: math.nan}))[1] is None
