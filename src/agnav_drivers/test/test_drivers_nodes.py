"""Driver nodes end to end: real rclpy, bytes through pseudo-terminals, messages on the contract topics."""
import math
import threading
import time

import pytest
from rclpy.parameter import Parameter

from agnav_drivers.adc import encode_frame
from agnav_drivers.pty_device import PtyDevice
from agnav_drivers.serial_link import OPEN

CORPUS = "/work/shared/data/real/gpsd_nmea/"
UBX = "/work/shared/data/real/ubx/"


class Harness:
    """Runs a driver node and a listener node; streams bytes into the driver's pty."""

    def __init__(self, rclpy, node_class, device, **params):
        from rclpy.executors import SingleThreadedExecutor
        self.rclpy = rclpy
        overrides = [Parameter("port", value=device.path)] + [Parameter(k, value=v) for k, v in params.items()]
        self.driver = node_class(parameter_overrides=overrides)
        self.listener = rclpy.create_node("driver_test_listener")
        self.got = {}
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.driver)
        self.executor.add_node(self.listener)
        self.device = device
        self.wait(lambda: self.driver.link.state == OPEN)

    def listen(self, msg_type, topic):
        from agnav_common.qos import SENSOR_QOS
        self.got[topic] = []
        self.listener.create_subscription(msg_type, topic, self.got[topic].append,
                                          10 if topic == "/diagnostics" else SENSOR_QOS)

    def wait(self, done, timeout=20.0):
        end = time.monotonic() + timeout
        while not done() and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.05)
        return done()

    def stream(self, data, baud=460800):
        stop = threading.Event()
        thread = threading.Thread(target=self.device.stream, args=(data, baud, 256, stop), daemon=True)
        thread.start()
        return stop, thread

    def close(self):
        self.driver.destroy_node()
        self.listener.destroy_node()


@pytest.fixture
def device(tmp_path):
    dev = PtyDevice(str(tmp_path / "tty0"))
    yield dev
    dev.close()


def diag_values(msgs, name):
    for array in reversed(msgs):
        for status in array.status:
            if status.name.endswith(name):
                return status, {kv.key: kv.value for kv in status.values}
    return None, {}


def test_nmea_node_streams_gpsd_capture_to_navsatfix(ros, device):
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import TwistWithCovarianceStamped
    from sensor_msgs.msg import NavSatFix, NavSatStatus

    from agnav_drivers.nmea_gnss_node import NmeaGnssNode
    from agnav_msgs.msg import GnssStatus
    h = Harness(ros, NmeaGnssNode, device)
    for t, topic in [(NavSatFix, "/gnss/fix"), (GnssStatus, "/gnss/status"),
                     (TwistWithCovarianceStamped, "/gnss/vel"), (DiagnosticArray, "/diagnostics")]:
        h.listen(t, topic)
    data = open(CORPUS + "ublox-zed-f9p-nmea.log", "rb").read()
    stop, _ = h.stream(data)
    assert h.wait(lambda: len(h.got["/gnss/fix"]) >= 20 and len(h.got["/diagnostics"]) >= 2)
    stop.set()
    fix = h.got["/gnss/fix"][0]
    assert fix.status.status == NavSatStatus.STATUS_FIX and fix.header.frame_id == "gnss_link"
    assert fix.latitude == pytest.approx(-45.8775, abs=1e-3) and math.isfinite(fix.altitude)
    assert fix.position_covariance_type in (NavSatFix.COVARIANCE_TYPE_APPROXIMATED,
                                            NavSatFix.COVARIANCE_TYPE_KNOWN, NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN)
    assert h.got["/gnss/status"][0].fix_type == GnssStatus.FIX_SINGLE
    assert h.got["/gnss/vel"] and h.got["/gnss/vel"][0].twist.covariance[35] == 99999.0
    status, values = diag_values(h.got["/diagnostics"], "nmea")
    assert status is not None and int(values["accepted"]) > 0 and values["fix_type"] == "single"
    assert device.path in status.hardware_id  # the device, not the class (diagnostic_updater convention)
    h.close()


def test_nmea_node_survives_unplug_and_reports_it(ros, device):
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from sensor_msgs.msg import NavSatFix

    from agnav_drivers.nmea_gnss_node import NmeaGnssNode
    h = Harness(ros, NmeaGnssNode, device, backoff_initial=0.05, backoff_max=0.2)
    h.listen(NavSatFix, "/gnss/fix")
    h.listen(DiagnosticArray, "/diagnostics")
    data = open(CORPUS + "bu353s4.log", "rb").read()
    stop, thread = h.stream(data, baud=115200)
    assert h.wait(lambda: len(h.got["/gnss/fix"]) >= 2)
    stop.set()
    thread.join()
    device.unplug()
    h.got["/diagnostics"].clear()
    assert h.wait(lambda: diag_values(h.got["/diagnostics"], "link")[0] is not None
                  and diag_values(h.got["/diagnostics"], "link")[0].level == DiagnosticStatus.ERROR)
    device.plug()
    n = len(h.got["/gnss/fix"])
    stop, _ = h.stream(open(CORPUS + "ublox-zed-f9p-nmea.log", "rb").read())
    assert h.wait(lambda: len(h.got["/gnss/fix"]) > n + 2)
    stop.set()
    assert h.driver.link.opens == 2
    h.close()


def test_ubx_node_publishes_fix_velocity_attitude(ros, device):
    from geometry_msgs.msg import TwistWithCovarianceStamped
    from sensor_msgs.msg import Imu, NavSatFix

    from agnav_drivers.ubx_gnss_node import UbxGnssNode
    from agnav_common.frames import euler_from_quaternion
    h = Harness(ros, UbxGnssNode, device, stamp_source="receiver")
    for t, topic in [(NavSatFix, "/gnss/fix"), (Imu, "/gnss/heading"), (TwistWithCovarianceStamped, "/gnss/vel")]:
        h.listen(t, topic)
    stop, _ = h.stream(open(UBX + "pygpsdata-SF-calibration.log", "rb").read())
    assert h.wait(lambda: len(h.got["/gnss/heading"]) >= 10 and len(h.got["/gnss/fix"]) >= 10)
    stop.set()
    fixes = h.got["/gnss/fix"]
    stamps = [f.header.stamp.sec + f.header.stamp.nanosec * 1e-9 for f in fixes]
    assert all(b - a == pytest.approx(1.0, abs=0.01) for a, b in zip(stamps, stamps[1:]))  # receiver epochs, 1 Hz
    roll, pitch, yaw = euler_from_quaternion(*[getattr(h.got["/gnss/heading"][0].orientation, k) for k in "xyzw"])
    assert abs(math.degrees(roll)) < 5 and abs(math.degrees(pitch)) < 5
    assert math.degrees(yaw) == pytest.approx(90 - 168.82255, abs=0.01)  # NAV-PVAT heading 168.8 deg
    h.close()


def test_ubx_node_publishes_raw_observations(ros, device):
    from agnav_drivers.ubx_gnss_node import UbxGnssNode
    from agnav_msgs.msg import GnssObservations
    h = Harness(ros, UbxGnssNode, device)
    h.listen(GnssObservations, "/gnss/raw_observations")
    stop, _ = h.stream(open(CORPUS + "ublox-neo-m8t.log", "rb").read())
    assert h.wait(lambda: len(h.got["/gnss/raw_observations"]) >= 5)
    stop.set()
    for epoch in h.got["/gnss/raw_observations"]:
        assert epoch.week > 2000 and 0 <= epoch.receiver_tow < 604800 and epoch.observations
        gps = [o for o in epoch.observations if o.gnss_id == 0 and o.pseudorange_valid]
        assert gps and all(1.5e7 < o.pseudorange < 3.0e7 and 0 < o.cno < 70 for o in gps)
    h.close()


@pytest.mark.parametrize("node", ["nmea", "ubx"])
def test_driver_shutdown_while_streaming_is_quiet(ros, device, node, monkeypatch):
    """destroy_node (Ctrl-C / SIGTERM path of main_for) with bytes arriving: the reader thread ends, no traceback."""
    from agnav_drivers.nmea_gnss_node import NmeaGnssNode
    from agnav_drivers.ubx_gnss_node import UbxGnssNode
    escaped = []
    monkeypatch.setattr(threading, "excepthook", escaped.append)
    node_class, capture = {"nmea": (NmeaGnssNode, CORPUS + "ublox-zed-f9p-nmea.log"),
                           "ubx": (UbxGnssNode, UBX + "pygpsdata-SF-calibration.log")}[node]
    for _ in range(3):
        h = Harness(ros, node_class, device)
        stop, thread = h.stream(open(capture, "rb").read(), baud=9600)
        assert h.wait(lambda: h.driver.link.bytes_read > 200)
        reader = h.driver._thread
        h.close()
        stop.set()
        thread.join()
        assert not reader.is_alive()
    assert escaped == []


def test_bad_gnss_input_is_counted_on_the_node_diagnostics(ros):
    from pyubx2 import UBXMessage

    from agnav_drivers.nmea_gnss_node import NmeaGnssNode
    from agnav_drivers.ubx_gnss_node import UbxGnssNode
    from drivers_helpers import real_sentences, with_checksum
    ubx = UbxGnssNode()
    pvt = dict(iTOW=1000, year=2024, month=5, day=1, hour=12, second=1, validDate=1, validTime=1, fullyResolved=1,
               fixType=3, gnssFixOk=1, numSV=20, lat=52.0, lon=13.0, height=100000, hAcc=20, vAcc=30, sAcc=50)
    ubx.handle_bytes(b"\xb5\x62\x01\x07\x40\x1f" + UBXMessage("NAV", "NAV-PVT", 0, velN=2_000_000_000, **pvt)
                     .serialize(), 1.0)
    _, _, values = ubx._check()
    assert values["corrupt_frames"] == 1 and values["implausible"] == 1 and ubx.published == 0
    nmea = NmeaGnssNode()
    gga = real_sentences("ublox-zed-f9p-nmea.log", "GGA")[0].split(",")
    gga[9] = "25000.0"
    nmea.handle_bytes(with_checksum(",".join(gga)), 1.0)
    _, _, values = nmea._check()
    assert values["implausible"] == 1 and nmea.published == 0
    ubx.destroy_node()
    nmea.destroy_node()


def test_adc_node_calibrates_then_publishes_imu_inclinometer_mag(ros, device):
    from sensor_msgs.msg import Imu, MagneticField
    from std_srvs.srv import Trigger

    from agnav_drivers.adc_sensor_node import AdcSensorNode
    from agnav_msgs.msg import Inclination
    h = Harness(ros, AdcSensorNode, device, static_samples=50)
    for t, topic in [(Imu, "/imu/data_raw"), (Inclination, "/inclinometer"), (MagneticField, "/imu/mag")]:
        h.listen(t, topic)
    lsb = 5.0 / 2 ** 16
    still = [round(2.5 / lsb)] * 3 + [round(2.6 / lsb), round(2.45 / lsb)] + [round(2.75 / lsb)] * 3
    turning = [round(2.9 / lsb)] + still[1:]
    frames = b"".join(encode_frame(i, i * 10000, still if i < 60 else turning) for i in range(200))
    stop, _ = h.stream(frames)
    assert h.wait(lambda: len(h.got["/imu/data_raw"]) >= 100)
    stop.set()
    incl = h.got["/inclinometer"][0]
    assert incl.roll == pytest.approx(math.radians(round(2.6 / lsb) * lsb - 2.5) / 0.1, abs=1e-9)
    assert h.got["/imu/mag"][0].magnetic_field.x == pytest.approx((round(2.75 / lsb) * lsb - 2.5) * 250e-7)
    imu = h.got["/imu/data_raw"][-1]
    assert imu.angular_velocity.x == pytest.approx(math.radians(40.0 * (round(2.9 / lsb) - round(2.5 / lsb)) * lsb))
    assert imu.orientation_covariance[0] == -1 and imu.linear_acceleration_covariance[0] == -1
    client = h.listener.create_client(Trigger, "/adc_sensor/calibrate_gyro")
    assert client.wait_for_service(timeout_sec=5)
    future = client.call_async(Trigger.Request())
    assert h.wait(future.done) and future.result().success
    assert h.driver.converter.calibrator.collecting
    h.close()
