"""Two-way tilt zero calibration: closed-form synthetic drive, its error messages, and the module applying the zeros."""
import math

import numpy as np
import pytest

from agnav_fusion.nav_sensor_module import NavSensorModule, NavSensorModuleSettings
from agnav_fusion.tilt_calibration import TiltCalibration

ZERO = np.radians([0.3, -0.2])     # sensor zeros to recover
GROUND = np.radians([1.0, 2.0])    # slope under the first parking (roll, pitch)
GYRO_OFFSET = math.radians(0.5)    # yaw-gyro offset: measured while parked


def drive(turn_deg=180.0, parked=30.0, seed=4):
    """Parked, 30 s out and turning by turn_deg, parked again; 100 Hz IMU/tilt, 1 Hz speed."""
    rng = np.random.default_rng(seed)
    cal = TiltCalibration()
    moving = (parked, parked + 30.0)
    end = moving[1] + parked
    for t in np.arange(0.0, end, 0.01):
        turning = moving[0] <= t < moving[1]
        cal.yaw_rate(t, GYRO_OFFSET + (math.radians(turn_deg) / 30.0 if turning else 0.0))
        sign = 1.0 if t < moving[0] else math.cos(math.radians(turn_deg))
        r, p = ZERO + sign * GROUND + rng.normal(0.0, math.radians(0.15), 2)
        cal.tilt(t, r, p)
        if abs(t - round(t)) < 1e-6:
            cal.speed(t, (1.0 if turning else 0.0) + abs(rng.normal(0.0, 0.02)))
    return cal


def test_zeros_and_ground_slope_recovered():
    res = drive().solve()
    assert math.degrees(res.roll_zero) == pytest.approx(0.3, abs=0.01)
    assert math.degrees(res.pitch_zero) == pytest.approx(-0.2, abs=0.01)
    assert math.degrees(res.ground_roll) == pytest.approx(1.0, abs=0.01)
    assert math.degrees(res.ground_pitch) == pytest.approx(2.0, abs=0.01)
    assert math.degrees(res.turn) == pytest.approx(180.0, abs=1.0)  # the gyro offset was removed
    assert res.first.end <= 30.0 and res.second.start >= 60.0 + 5.0  # settling time dropped after stopping


def test_no_reversal_is_a_clear_error():
    with pytest.raises(ValueError, match="turn round"):
        drive(turn_deg=90.0).solve()


def test_short_parking_is_a_clear_error():
    with pytest.raises(ValueError, match="park for longer"):
        drive(parked=12.0).solve()


def test_missing_stream_is_a_clear_error():
    cal = TiltCalibration()
    cal.speed(1.0, 0.0)
    with pytest.raises(ValueError, match="missing"):
        cal.solve()


def test_module_subtracts_the_zeros():
    """A level, still vehicle whose inclinometers read their zeros is estimated level."""
    zero_deg = (0.4, -0.3)
    nsm = NavSensorModule(NavSensorModuleSettings(incl_zero_deg=zero_deg))
    rng = np.random.default_rng(3)
    for k in range(1, 2001):
        t = 10.0 + k * 0.01
        nsm.inclinometer(t, *np.radians(zero_deg))
        s = nsm.imu(t, rng.normal(0.0, 1e-5, 3))  # a still gyro's noise (identical readings: a stuck IMU)
    assert abs(math.degrees(s.rpy[0])) < 0.01 and abs(math.degrees(s.rpy[1])) < 0.01
