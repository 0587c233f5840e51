"""Issue 15 item 5: the crab (side slip) handled by feed-forward or integral, and engage gates per receiver class."""
import math

import numpy as np
import pytest
from agnav_control.controllers import CONTROLLERS, make_controller
from agnav_control.guidance_line import GuidanceLine, crab_angle
from agnav_control.watchdog import FIX_DGPS, FIX_RTK_FLOAT, OdometrySample, Watchdog

from bicycle import Bicycle, drive

CRAB = math.radians(-1.5)  # sliding right, down a slope
LINE = GuidanceLine(0.0, 0.0, 0.0)


@pytest.mark.parametrize("name", sorted(CONTROLLERS))
def test_crab_feed_forward_leaves_no_offset(name):
    vehicle = Bicycle(y=0.1, speed=1.5, crab=CRAB)
    history = np.array(drive(make_controller(name), LINE, vehicle, 100.0, crab_known=True))
    assert abs(np.mean(history[-1000:])) < 0.01  # last 50 s (75 m)
    assert abs(vehicle.yaw + CRAB) < math.radians(0.1)  # the body turned into the slope: course along the line


def test_unseen_crab_offsets_pid_until_the_integral_holds_it():
    vehicle = Bicycle(speed=1.5, crab=CRAB)
    pid = make_controller("pid")
    history = np.array(drive(pid, LINE, vehicle, 200.0))
    assert np.min(history) < -0.05  # kh * crab / kp: several cm before the integral builds up
    assert abs(np.mean(history[-1000:])) < 0.01
    assert abs(pid.integral.value) < pid.settings.integral_limit  # held without reaching the clamp


def test_crab_angle_from_twist():
    assert crab_angle(2.0, -2.0 * math.tan(0.03)) == pytest.approx(-0.03)  # sliding right
    assert crab_angle(0.1, 0.05) == 0.0  # too slow to tell
    assert crab_angle(2.0, 2.0, max_crab=0.2) == 0.2


def sample(position_std, yaw_std, lateral=0.0):
    return OdometrySample(0.0, 0.0, 0.0, 1.5, position_std**2, yaw_std**2, lateral_speed=lateral)


def fed(wd, s, t0=0.0, n=20):
    for k in range(n):
        wd.odometry(t0 + 0.01 * k, s)
    return t0 + 0.01 * (n - 1)


HONEST_DGPS = sample(0.8, math.radians(1.6))  # NMEA without GST: HDOP 0.8 x 1 m; heading σ ~ an unseen crab


@pytest.mark.parametrize("fix_type", [FIX_DGPS, FIX_RTK_FLOAT])
def test_decimetre_receiver_engages_on_honest_covariance(fix_type):
    wd = Watchdog()
    t = fed(wd, HONEST_DGPS)
    ok, why = wd.request_engage(t)
    assert not ok and "above 0.3 m" in why  # no /gnss/status: the RTK-class gates
    wd.fix_type = fix_type
    t = fed(wd, HONEST_DGPS, t + 0.01)
    assert wd.request_engage(t)[0]
    fed(wd, HONEST_DGPS, t + 0.01, 200)
    assert wd.engaged and wd.fault is None  # and the fail-safe holds it


def test_rtk_fixed_keeps_the_strict_gates():
    wd = Watchdog()
    wd.fix_type = 4
    ok, why = wd.request_engage(fed(wd, sample(0.03, math.radians(1.6))))
    assert not ok and "not converged" in why
    assert "position std" in wd.odometry(1.0, sample(0.8, 0.005))


def test_decimetre_gates_still_fail_safe():
    cases = [(sample(2.0, 0.01), "position std 2.000 m above 1.5 m"),  # divergent: dead reckoning
             (sample(0.5, 0.2), "yaw std"),
             (sample(0.5, 0.01, lateral=math.nan), "non-finite")]
    for bad, reason in cases:
        wd = Watchdog()
        wd.fix_type = FIX_DGPS
        assert wd.request_engage(fed(wd, HONEST_DGPS))[0]
        assert reason in wd.odometry(1.0, bad) and not wd.engaged
    wd = Watchdog()
    wd.fix_type = FIX_DGPS
    assert wd.request_engage(fed(wd, HONEST_DGPS))[0]
    wd.fix_type = 1  # the receiver lost its corrections: RTK-class limits again
    assert "position std" in wd.odometry(1.0, HONEST_DGPS) and not wd.engaged
