"""The generated CDR coders (nested messages inlined, scalar runs merged) against rclpy and rosbags on every kind of
field: scalars of growing and shrinking sizes, strings (empty, non-ASCII), fixed arrays, sequences of numbers and of
messages (empty too)."""
import pytest

pytest.importorskip("rclpy")

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue  # noqa: E402
from geometry_msgs.msg import TransformStamped  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.serialization import deserialize_message  # noqa: E402
from sensor_msgs.msg import Imu, NavSatFix  # noqa: E402
from std_msgs.msg import Float64MultiArray, MultiArrayDimension  # noqa: E402
from tf2_msgs.msg import TFMessage  # noqa: E402

from agnav_common import bagio  # noqa: E402


def _messages():
    odom = Odometry(child_frame_id="base_link")
    odom.header.frame_id, odom.header.stamp.sec, odom.header.stamp.nanosec = "map", 1_700_000_000, 5
    odom.pose.pose.position.x, odom.pose.pose.orientation.w = 3.25, 1.0
    odom.pose.covariance[7], odom.twist.covariance[35], odom.twist.twist.angular.z = 0.5, 1e-9, -0.125
    imu = Imu()
    imu.header.frame_id, imu.orientation.z, imu.orientation_covariance[4] = "", 0.7, 2.0
    fix = NavSatFix(latitude=52.1, longitude=-1.5, altitude=80.0, position_covariance_type=2)
    fix.status.status, fix.status.service = -1, 7  # int8 then uint16: a new run
    tf = TFMessage(transforms=[TransformStamped(child_frame_id=f"c{k}") for k in range(3)])
    tf.transforms[1].transform.translation.y = 2.0
    diag = DiagnosticArray(status=[DiagnosticStatus(level=b"\x01", name="größe", values=[KeyValue(key="k", value="v")]),
                                   DiagnosticStatus(name="empty")])
    arr = Float64MultiArray(data=[1.0, -2.5, 3e300], data_offset=4)
    arr.layout.dim = [MultiArrayDimension(label="x", size=3, stride=3)]
    return [odom, imu, fix, tf, diag, arr, TFMessage()]


@pytest.mark.parametrize("msg", _messages(), ids=lambda m: type(m).__name__)
def test_generated_coders_match_rclpy_and_rosbags(msg):
    data = bagio.cdr(msg)
    assert bagio._WRITERS[type(msg)][1] is not None  # the generated writer passed its first-message check
    assert data == bagio._round_trip(msg, bagio.type_name(type(msg)))  # rosbags' bytes, zero padding
    assert deserialize_message(data, type(msg)) == msg
    assert bagio.from_cdr(data, type(msg)) == msg
    assert bagio._READERS[type(msg)] is not None


def test_definitions_as_the_store_derives_them_and_cached(tmp_path, monkeypatch):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    monkeypatch.setattr(bagio, "_definitions", {})
    store, types = bagio.typestore(), ["nav_msgs/msg/Odometry", "agnav_msgs/msg/Inclination", "no_msgs/msg/Nothing"]
    expected = [[store.generate_msgdef(t, ros_version=2)[0], store.hash_rihs01(t)] if t in store.types else None
                for t in types]
    assert [bagio.definition(t) for t in types] == expected
    monkeypatch.setattr(bagio, "_definitions", {})  # a new process: from the file alone
    monkeypatch.setattr(bagio, "typestore", None)
    assert [bagio.definition(t) for t in types] == expected


def test_bytes_that_are_no_message_raise_and_leave_the_reader_unchecked():
    from sensor_msgs.msg import Temperature    # a type no other test here decodes first
    with pytest.raises(Exception):
        bagio.from_cdr(b"\x00\x01\x00\x00\x07", Temperature)
    assert Temperature not in bagio._READERS
    msg = Temperature(temperature=21.5, variance=0.25)
    msg.header.frame_id = "t"
    assert bagio.from_cdr(bagio.cdr(msg), Temperature) == msg and bagio._READERS[Temperature] is not None
    assert bagio.from_cdr(bagio.cdr(msg), Temperature) == msg           # the generated reader


def test_definitions_from_two_threads_at_once(tmp_path, monkeypatch):
    import threading
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    monkeypatch.setattr(bagio, "_definitions", {})
    types = ["nav_msgs/msg/Odometry", "sensor_msgs/msg/Imu", "tf2_msgs/msg/TFMessage", "agnav_msgs/msg/Inclination"]
    errors, results = [], {}

    def worker(k):
        try:
            results[k] = [bagio.definition(t) for t in types[k:] + types[:k]]
        except Exception as exc:  # noqa: BLE001  (collected, the assertion below reports it)
            errors.append(exc)

    threads = [threading.Thread(target=worker, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == [] and all(r[(4 - k) % 4] == results[0][0] for k, r in results.items())
