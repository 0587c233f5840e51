import math

import numpy as np
import pytest
from agnav_control.controllers import CONTROLLERS, make_controller, scalar_fields
from agnav_control.guidance_line import GuidanceLine, TrackingError
from agnav_control.limits import Integrator, SpeedSchedule, SteeringLimiter, SteeringLimits
from agnav_control.pid import PID, PIDSettings
from agnav_control.pure_pursuit import PurePursuit
from agnav_control.thesis_pi import ThesisPI, ThesisPISettings

from bicycle import Bicycle, drive

NO_RATE = SteeringLimits(max_rate=0.0)


def err(cross_track=0.0, heading_error=0.0, speed=1.0):
    return TrackingError(cross_track, heading_error, 0.0, speed, 0.0)


@pytest.mark.parametrize("name", sorted(CONTROLLERS))
def test_steers_back_toward_line(name):
    c = make_controller(name, limits=NO_RATE)
    assert c.update(err(cross_track=0.5), 0.1) < 0.0   # left of the line -> steer right
    c.reset()
    assert c.update(err(cross_track=-0.5), 0.1) > 0.0
    c.reset()
    assert c.update(err(heading_error=0.1), 0.1) < 0.0  # yawed left -> steer right
    c.reset()
    assert c.update(err(), 0.1) == pytest.approx(0.0)


def test_thesis_law_values_and_sign_conversion():
    c = ThesisPI(ThesisPISettings(alpha=2.0, beta=0.5, limits=NO_RATE))
    # thesis dphi = -heading_error = 0.1, eps = -cross_track = 0.2: psi = 2*0.1 + 0.5*0.2
    assert c.update(err(cross_track=-0.2, heading_error=-0.1), 0.1) == pytest.approx(0.3)


def test_thesis_dead_reckoned_eps_integrates_heading_deviation():
    c = ThesisPI(ThesisPISettings(alpha=0.0, beta=1.0, cross_track="dead_reckoning", fixed_speed=0.5, limits=NO_RATE))
    for _ in range(10):
        out = c.update(err(cross_track=99.0, heading_error=-0.1, speed=3.0), 1.0 / 3.0)  # measured e ignored
    assert c.eps == pytest.approx(10 * 0.5 / 3.0 * math.sin(0.1))  # (2.7) with v fixed at 0.5
    assert out == pytest.approx(c.eps)


def test_limiter_angle_and_rate():
    lim = SteeringLimiter(SteeringLimits(max_angle=0.5, max_rate=1.0))
    assert lim(2.0, 0.1) == pytest.approx(0.1) and lim.saturated
    for _ in range(10):
        lim(2.0, 0.1)
    assert lim.angle == pytest.approx(0.5)
    assert lim(0.45, 0.1) == pytest.approx(0.45) and not lim.saturated


def test_speed_schedule_clamps_low_speed():
    sched = SpeedSchedule(ref_speed=2.0, min_speed=0.5, exponent=1.0)
    assert sched.scale(4.0) == pytest.approx(0.5)
    assert sched.scale(0.0) == pytest.approx(4.0)


def test_integrator_clamp_and_unwind():
    integ = Integrator(limit=1.0)
    for _ in range(30):
        integ.step(1.0, 0.1)
    assert integ.value == pytest.approx(1.0)
    integ.reset()
    integ.step(1.0, 0.1)
    integ.unwind_if(True, True)
    assert integ.value == 0.0


def test_pid_anti_windup_holds_integral_while_saturated():
    pid = PID(PIDSettings(kp=1.0, ki=1.0, kh=0.0, integral_limit=100.0, integral_band=100.0, limits=SteeringLimits(max_angle=0.2, max_rate=0.0)))
    for _ in range(100):
        out = pid.update(err(cross_track=5.0), 0.1)
    assert out == pytest.approx(-0.2)
    assert pid.integral.value < 0.6  # would be 50 m s without anti-windup


def test_pure_pursuit_lookahead_schedule_and_geometry():
    pp = PurePursuit()
    assert pp.lookahead(0.0) == pytest.approx(2.0)
    assert pp.lookahead(4.0) == pytest.approx(8.0)
    assert pp.lookahead(50.0) == pytest.approx(15.0)
    pp2 = make_controller("pure_pursuit", limits=NO_RATE, lookahead_base=5.0, lookahead_per_speed=0.0, lookahead_min=5.0)
    # 3 m right of the line, aligned: goal at (4, 3) in vehicle frame -> sin(a) = 3/5
    expected = math.atan(2 * 2.9 * 0.6 / 5.0)
    assert pp2.update(err(cross_track=-3.0), 0.1) == pytest.approx(expected)


def test_scalar_fields_and_unknown_name():
    assert scalar_fields("thesis_pi")["alpha"] == ThesisPISettings().alpha
    with pytest.raises(ValueError):
        make_controller("bang_bang")


@pytest.mark.parametrize("name", sorted(CONTROLLERS))
@pytest.mark.parametrize("speed", [0.5, 4.3])
def test_converges_on_bicycle_from_offset_both_directions(name, speed):
    line = GuidanceLine.from_points((0, 0), (100, 30))
    for yaw0, side in ((line.yaw + 0.1, 1.0), (line.yaw + math.pi - 0.1, -1.0)):
        start = line.offset(side * 1.5)  # 1.5 m off, both travel directions
        car = Bicycle(start.x, start.y, yaw0, speed=speed)
        e = np.array(drive(make_controller(name), line, car, duration=120.0 / speed))
        tail = e[int(0.75 * len(e)):]
        assert abs(e[0]) == pytest.approx(1.5, abs=1e-6)
        assert np.max(np.abs(tail)) < 0.02, name
        assert np.max(np.abs(e)) < 3.0  # no wild overshoot
