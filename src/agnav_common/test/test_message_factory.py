"""new_message: the value of cls(), built from inlined slot copies, with no mutable part shared between messages."""
import pytest

pytest.importorskip("rclpy")

from builtin_interfaces.msg import Time  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from sensor_msgs.msg import Imu, NavSatFix  # noqa: E402
from tf2_msgs.msg import TFMessage  # noqa: E402

from agnav_common.message_factory import new_message  # noqa: E402


@pytest.mark.parametrize("cls", [Odometry, Imu, NavSatFix, TFMessage, DiagnosticArray, Time], ids=lambda c: c.__name__)
def test_new_message_is_a_fresh_default_message(cls):
    a, b = new_message(cls), new_message(cls)
    assert a == cls() and type(a) is cls
    assert a is not b


def test_nested_messages_and_arrays_are_not_shared():
    a, b = new_message(Odometry), new_message(Odometry)
    a.header.stamp.sec, a.pose.covariance[3] = 7, 1.5
    assert b.header.stamp.sec == 0 and b.pose.covariance[3] == 0.0 and new_message(Odometry) == Odometry()
    t = new_message(TFMessage)
    t.transforms.append(1)
    assert new_message(TFMessage).transforms == []
