"""NavigationPipeline's fix/velocity pairing and accelerometer routing, with a backend that records what reaches it
(no ROS)."""
import numpy as np
from agnav_fusion.front_end import InputGuard, InputGuardSettings
from agnav_fusion.pipeline import FrontEndSettings, NavigationPipeline
from geometry_msgs.msg import TwistWithCovarianceStamped
from sensor_msgs.msg import Imu, NavSatFix, NavSatStatus

LAT, LON = 35.0, 139.0


class Recorder:
    def __init__(self):
        self.guard = InputGuard(InputGuardSettings())
        self.fixes, self.specific_force, self.tilts = [], [], []

    def imu(self, t, gyro, specific_force=None):
        self.specific_force.append(specific_force)

    def inclinometer(self, t, roll, pitch):
        self.tilts.append((roll, pitch))

    def set_mounts(self, *args):
        pass

    def gnss(self, t, enu, cov, vel=None, var=None):
        self.fixes.append((t, enu, vel))


def stamp(msg, t):
    msg.header.stamp.sec, msg.header.stamp.nanosec = int(t), int(round((t % 1) * 1e9))
    return msg


def fix(t, north_m):
    msg = stamp(NavSatFix(), t)
    msg.status.status = NavSatStatus.STATUS_FIX
    msg.latitude, msg.longitude, msg.altitude = LAT + north_m / 111_000.0, LON, 10.0
    msg.position_covariance_type = NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
    msg.position_covariance = [1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e-4]
    return msg


def velocity(t, north):
    msg = stamp(TwistWithCovarianceStamped(), t)
    msg.twist.twist.linear.y = north
    msg.twist.covariance[0] = msg.twist.covariance[7] = 1e-4
    return msg


def pipeline(tilt_source="inclinometer"):
    backend = Recorder()
    p = NavigationPipeline(backend, FrontEndSettings(datum=(LAT, LON, 10.0), velocity_wait=0.0,
                                                     tilt_source=tilt_source))
    p.set_mounts(np.eye(3), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    return p, backend


def test_a_10_hz_fix_never_takes_the_previous_epochs_velocity():
    p, backend = pipeline()
    for k in range(5):  # the velocity of epoch k arrives after its fix, as receivers publish them
        p.on_fix(fix(100.0 + 0.1 * k, 0.1 * k))
        p.on_velocity(velocity(100.0 + 0.1 * k, float(k)))
    paired = [(round(t, 1), None if vel is None else vel[1]) for t, _, vel in backend.fixes]
    assert all(v is None for _, v in paired[1:]), paired  # epoch k would otherwise fuse epoch k-1's velocity


def test_slow_10_hz_fixes_reach_the_fix_difference_baseline():
    p, backend = pipeline()
    for k in range(60):  # 0.5 m/s: the 2 m baseline lies 40 fixes back
        p.on_fix(fix(100.0 + 0.1 * k, 0.05 * k))
    vel = backend.fixes[-1][2]
    assert vel is not None and abs(vel[1] - 0.5) < 0.01


def imu(t, accelerating):
    msg = stamp(Imu(), t)
    msg.angular_velocity.z = 0.01 * t
    msg.linear_acceleration.x, msg.linear_acceleration.z = (0.5 if accelerating else 0.0), 9.81
    return msg


def test_the_accelerometer_reaches_the_backend_once():
    """As specific force with an inclinometer; as tilt alone when it is the tilt source (its tilt already holds the
    acceleration: a second use would count it twice)."""
    p, backend = pipeline()
    p.on_imu(imu(1.0, True))
    assert backend.specific_force[-1][0] == 0.5 and not backend.tilts
    p, backend = pipeline("accelerometer")
    p.on_imu(imu(1.0, True))
    assert backend.specific_force[-1] is None and backend.tilts[-1][1] < 0  # acceleration reads as nose up
