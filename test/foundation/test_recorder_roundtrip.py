"""rosbag2 write -> read round trip through the recorder node for every contract message type."""
from rclpy.experimental import EventsExecutor
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message
from rosbags.highlevel import AnyReader

from agnav_common.frames import quaternion_from_euler
from agnav_common.qos import SENSOR_QOS
from agnav_common.stamps import to_stamp
from agnav_common.tf import make_transform
from agnav_drivers.bag_recorder_node import BagRecorderNode
from agnav_drivers.ros_types import message_class


def contract_messages():
    """One message with distinctive values per contract topic of INTERFACES.md."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from geometry_msgs.msg import TwistWithCovarianceStamped
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import Imu, MagneticField, NavSatFix
    from tf2_msgs.msg import TFMessage

    from agnav_msgs.msg import GnssStatus, GuidanceState, Inclination, SteeringCommand
    stamp = to_stamp(1_700_000_123.25)
    imu = Imu()
    imu.header.stamp, imu.header.frame_id = stamp, "imu_link"
    imu.angular_velocity.x, imu.orientation_covariance[0] = 0.125, -1.0
    mag = MagneticField(magnetic_field_covariance=[1e-12] * 9)
    mag.header.stamp, mag.magnetic_field.z = stamp, -4.5e-5
    fix = NavSatFix(latitude=43.07, longitude=141.34, altitude=80.5, position_covariance_type=2)
    fix.header.stamp, fix.status.status = stamp, 2
    vel = TwistWithCovarianceStamped()
    vel.header.stamp, vel.twist.twist.linear.x = stamp, 0.8
    odom = Odometry(child_frame_id="base_link")
    odom.header.frame_id, odom.pose.pose.position.x, odom.pose.covariance[35] = "map", 12.5, 0.01
    return {
        "/imu/data_raw": imu, "/imu/mag": mag, "/gnss/fix": fix, "/gnss/vel": vel, "/odometry/filtered": odom,
        "/inclinometer": Inclination(header=imu.header, roll=0.1, pitch=-0.2, roll_variance=1e-4,
                                     pitch_variance=-1.0),
        "/gnss/status": GnssStatus(header=fix.header, fix_type=GnssStatus.FIX_RTK_FLOAT, satellites_used=11,
                                   hdop=0.75, correction_age=1.5),
        "/guidance/state": GuidanceState(engaged=True, cross_track_error=0.031, heading_error=-0.01,
                                         line_yaw=1.2, speed=4.3),
        "/steering/command": SteeringCommand(engaged=True, steering_angle=0.05, steering_rate_limit=0.35),
        "/diagnostics": DiagnosticArray(status=[DiagnosticStatus(level=DiagnosticStatus.WARN, name="x",
                                                                 values=[KeyValue(key="k", value="v")])]),
        "/tf_static": TFMessage(transforms=[make_transform("base_link", "gnss_link", stamp, (0.0, -1.67, 3.23),
                                                           quaternion_from_euler(0.0, 0.0, 0.1))]),
    }


def test_every_contract_type_round_trips(ros, tmp_path):
    messages = contract_messages()
    source = ros.create_node("source")
    publishers = {topic: source.create_publisher(type(msg), topic, SENSOR_QOS) for topic, msg in messages.items()}
    recorder = BagRecorderNode(parameter_overrides=[
        Parameter("output", value=str(tmp_path / "out")), Parameter("topics", value=list(messages)),
        Parameter("exclude", value=[""])])
    executor = EventsExecutor()
    executor.add_node(source)
    executor.add_node(recorder)
    for _ in range(500):  # wait for discovery and matching of every topic
        executor.spin_once(timeout_sec=0.01)
        if len(recorder.connections) == len(messages) and all(
                p.get_subscription_count() > 0 for p in publishers.values()):
            break
    for topic, msg in messages.items():
        publishers[topic].publish(msg)
    for _ in range(300):
        executor.spin_once(timeout_sec=0.01)
        if all(recorder.counts.get(topic) for topic in messages):
            break
    recorder.destroy_node()
    source.destroy_node()
    with AnyReader([tmp_path / "out"]) as reader:
        back = {}
        for c, _, raw in reader.messages():
            back.setdefault(c.topic, []).append(deserialize_message(raw, message_class(c.msgtype)))
        types = {c.topic: c.msgtype for c in reader.connections}
    assert set(back) == set(messages)
    for topic, msg in messages.items():
        assert msg in back[topic], topic  # /diagnostics also holds the recorder's own status
        assert types[topic] == f"{type(msg).__module__.split('.')[0]}/msg/{type(msg).__name__}"


INFINITE = {"sec": 9223372036, "nsec": 854775807}  # RMW_DURATION_INFINITE, as Fast DDS reports unset durations


def rosbag2_profile(history, depth, reliability, durability, duration=INFINITE):
    """One offered_qos_profiles entry as rosbag2 (Kilted, metadata version 9) writes it."""
    return {"history": history, "depth": depth, "reliability": reliability, "durability": durability,
            "deadline": duration, "lifespan": duration, "liveliness": "automatic",
            "liveliness_lease_duration": duration, "avoid_ros_namespace_conventions": False}


def mcap_channel_qos(mcap_file):
    """{topic: offered_qos_profiles} from the channel records' metadata of an mcap file."""
    import yaml

    from agnav_common.mcap_recording import _flat_records, _string
    out = {}
    with open(mcap_file, "rb") as f:
        f.read(8)
        for op, b in _flat_records(f):
            if op == 0x04:  # channel: id, schema id, topic, encoding, metadata map (byte length, string pairs)
                topic, at = _string(b, 4)
                at = _string(b, at)[1] + 4
                while at < len(b):
                    key, at = _string(b, at)
                    value, at = _string(b, at)
                    if key == "offered_qos_profiles":
                        out[topic] = yaml.safe_load(value)
    return out


def test_recording_carries_offered_qos(ros, tmp_path):
    """metadata.yaml and the mcap channels hold each publisher's QoS as rosbag2 writes it: `ros2 bag play`
    republishes /tf_static and /map_datum latched and the sensor stream best effort."""
    import yaml
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import NavSatFix

    from agnav_common.qos import LATCHED_QOS, PUBLISHER_QOS
    messages = contract_messages()
    source = ros.create_node("source")
    profiles = {"/tf_static": LATCHED_QOS, "/map_datum": LATCHED_QOS, "/imu/data_raw": qos_profile_sensor_data,
                "/odometry/filtered": PUBLISHER_QOS}
    messages["/map_datum"] = NavSatFix(latitude=43.07, longitude=141.34, altitude=80.5)
    publishers = {t: source.create_publisher(type(messages[t]), t, q) for t, q in profiles.items()}
    recorder = BagRecorderNode(parameter_overrides=[
        Parameter("output", value=str(tmp_path / "out")), Parameter("topics", value=list(profiles))])
    executor = EventsExecutor()
    executor.add_node(source)
    executor.add_node(recorder)
    for _ in range(500):
        executor.spin_once(timeout_sec=0.01)
        if len(recorder.connections) == len(profiles) and all(
                p.get_subscription_count() > 0 for p in publishers.values()):
            break
    for topic, pub in publishers.items():
        pub.publish(messages[topic])
    for _ in range(300):
        executor.spin_once(timeout_sec=0.01)
        if all(recorder.counts.get(topic) for topic in profiles):
            break
    recorder.destroy_node()
    source.destroy_node()
    latched = rosbag2_profile("keep_last", 1, "reliable", "transient_local")
    expected = {"/tf_static": [latched], "/map_datum": [latched],
                "/imu/data_raw": [rosbag2_profile("unknown", 0, "best_effort", "volatile")],  # Fast DDS: no history
                "/odometry/filtered": [rosbag2_profile("unknown", 0, "reliable", "volatile")]}
    meta = yaml.safe_load((tmp_path / "out" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["version"] == 9
    topics = {t["topic_metadata"]["name"]: t["topic_metadata"]["offered_qos_profiles"]
              for t in meta["topics_with_message_count"]}
    assert topics == expected
    assert mcap_channel_qos(next((tmp_path / "out").glob("*.mcap"))) == expected
    with AnyReader([tmp_path / "out"]) as reader:  # and a rosbag2 reader parses them back
        assert {c.topic: c.ext.offered_qos_profiles[0].durability.name for c in reader.connections} == {
            "/tf_static": "TRANSIENT_LOCAL", "/map_datum": "TRANSIENT_LOCAL", "/imu/data_raw": "VOLATILE",
            "/odometry/filtered": "VOLATILE"}
