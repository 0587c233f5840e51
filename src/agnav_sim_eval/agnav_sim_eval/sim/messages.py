"""Simulator samples -> ROS messages (rosbags type store; CDR bytes for bags and for the live node)."""
import numpy as np

from agnav_common.bagio import typestore
from agnav_common.frames import quaternion_from_euler, rotation_matrix

# Fixed start of the simulated timeline (2023-11-14T22:13:20Z) so that bags are byte-for-byte reproducible.
START_EPOCH_S = 1_700_000_000
STATUS_FIX, STATUS_SBAS_FIX, STATUS_GBAS_FIX = 0, 1, 2
SERVICE_GPS = 1
COVARIANCE_TYPE_KNOWN = 3
UNKNOWN_VARIANCE = 99999.0

TOPIC_TYPES = {
    "/imu/data_raw": "sensor_msgs/msg/Imu",
    "/imu/mag": "sensor_msgs/msg/MagneticField",
    "/inclinometer": "agnav_msgs/msg/Inclination",
    "/gnss/fix": "sensor_msgs/msg/NavSatFix",
    "/gnss/vel": "geometry_msgs/msg/TwistWithCovarianceStamped",
    "/gnss/status": "agnav_msgs/msg/GnssStatus",
    "/ground_truth/odometry": "nav_msgs/msg/Odometry",
    "/tf_static": "tf2_msgs/msg/TFMessage",
    "/map_datum": "sensor_msgs/msg/NavSatFix",
}
# topics of optional simulator sensors (scenario.wheel), not published by the live sim node
MESSAGE_TYPES = {**TOPIC_TYPES, "/wheel/odometry": "nav_msgs/msg/Odometry"}
LATCHED_TOPICS = ("/tf_static", "/map_datum")


class MessageFactory:
    """Builds the INTERFACES.md messages of one TractorSimulator; stamps = START_EPOCH_S + simulation time."""

    def __init__(self, sim, start_epoch_s=START_EPOCH_S):
        self.sim = sim
        self.t0 = start_epoch_s
        self.ts = typestore()
        self.T = self.ts.types

    def stamp(self, t):
        """builtin_interfaces/Time at simulation time t (s)."""
        ns = int(round((self.t0 + t) * 1e9))
        return self.T["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def header(self, t, frame):
        return self.T["std_msgs/msg/Header"](stamp=self.stamp(t), frame_id=frame)

    def _vec(self, v):
        return self.T["geometry_msgs/msg/Vector3"](x=float(v[0]), y=float(v[1]), z=float(v[2]))

    def _quat(self, rpy):
        x, y, z, w = quaternion_from_euler(*rpy)
        return self.T["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)

    def static(self):
        """[(topic, msg)] of the latched messages: /tf_static with every mount, /map_datum at the datum."""
        T = self.T
        transforms = [T["geometry_msgs/msg/TransformStamped"](
            header=self.header(0.0, "base_link"), child_frame_id=frame,
            transform=T["geometry_msgs/msg/Transform"](translation=self._vec(xyz), rotation=self._quat(rpy)))
            for frame, (xyz, rpy) in sorted(self.sim.scenario.mounts.items())]
        lat, lon, alt = self.sim.scenario.datum
        datum = T["sensor_msgs/msg/NavSatFix"](
            header=self.header(0.0, "map"),
            status=T["sensor_msgs/msg/NavSatStatus"](status=STATUS_FIX, service=SERVICE_GPS),
            latitude=lat, longitude=lon, altitude=alt, position_covariance=np.zeros(9),
            position_covariance_type=COVARIANCE_TYPE_KNOWN)
        return [("/tf_static", T["tf2_msgs/msg/TFMessage"](transforms=transforms)), ("/map_datum", datum)]

    def convert(self, kind, stamp, data):
        """[(topic, publish time s, msg)] for one simulator sample."""
        return getattr(self, "_" + kind)(stamp, data)

    def _truth(self, t, d):
        T = self.T
        rot = rotation_matrix(d["roll"], d["pitch"], d["yaw"])
        v_body = rot.T @ np.array([d["vx"], d["vy"], d["vz"]])
        pose = T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=d["x"], y=d["y"], z=d["z"]),
            orientation=self._quat((d["roll"], d["pitch"], d["yaw"])))
        twist = T["geometry_msgs/msg/Twist"](linear=self._vec(v_body), angular=self._vec((d["wx"], d["wy"], d["wz"])))
        msg = T["nav_msgs/msg/Odometry"](
            header=self.header(t, "map"), child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=np.zeros(36)))
        return [("/ground_truth/odometry", t, msg)]

    def _imu(self, t, d):
        T, sim = self.T, self.sim
        gyro_cov = np.diag(np.full(3, sim.gyro.variance(sim.dt))).ravel()
        accel_cov = np.zeros(9)
        if d["accel"] is None:
            accel, accel_cov[0] = (0.0, 0.0, 0.0), -1.0
        else:
            accel, accel_cov = d["accel"], np.diag(np.full(3, sim.accel.variance)).ravel()
        orient_cov = np.zeros(9)
        orient_cov[0] = -1.0
        msg = T["sensor_msgs/msg/Imu"](
            header=self.header(t, "imu_link"),
            orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=0.0),
            orientation_covariance=orient_cov, angular_velocity=self._vec(d["gyro"]),
            angular_velocity_covariance=gyro_cov, linear_acceleration=self._vec(accel),
            linear_acceleration_covariance=accel_cov)
        return [("/imu/data_raw", t, msg)]

    def _incl(self, t, d):
        var = self.sim.incl.variance
        msg = self.T["agnav_msgs/msg/Inclination"](header=self.header(t, "inclinometer_link"), roll=float(d["roll"]),
                                                  pitch=float(d["pitch"]), roll_variance=var, pitch_variance=var)
        return [("/inclinometer", t, msg)]

    def _mag(self, t, d):
        cov = np.diag(np.full(3, self.sim.fluxgate.variance)).ravel()
        msg = self.T["sensor_msgs/msg/MagneticField"](header=self.header(t, "mag_link"),
                                                     magnetic_field=self._vec(d["field"]),
                                                     magnetic_field_covariance=cov)
        return [("/imu/mag", t, msg)]

    def _gnss(self, t, d):
        T = self.T
        rtk = d["fix_type"] >= 3
        status = STATUS_GBAS_FIX if rtk else STATUS_SBAS_FIX
        arrive = d["t_arrival"]
        fix = T["sensor_msgs/msg/NavSatFix"](
            header=self.header(t, "gnss_link"),
            status=T["sensor_msgs/msg/NavSatStatus"](status=status, service=SERVICE_GPS),
            latitude=d["lat"], longitude=d["lon"], altitude=d["alt"],
            position_covariance=np.asarray(d["cov"], dtype=float).ravel(),
            position_covariance_type=COVARIANCE_TYPE_KNOWN)
        cov6 = np.zeros((6, 6))
        cov6[:3, :3] = d["vel_cov"]
        cov6[3:, 3:] = np.eye(3) * UNKNOWN_VARIANCE
        vel = T["geometry_msgs/msg/TwistWithCovarianceStamped"](
            header=self.header(t, "gnss_link"),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](linear=self._vec(d["vel"]), angular=self._vec((0, 0, 0))),
                covariance=cov6.ravel()))
        st = T["agnav_msgs/msg/GnssStatus"](header=self.header(t, "gnss_link"), fix_type=int(d["fix_type"]),
                                            satellites_used=int(d["satellites"]), hdop=float(d["hdop"]),
                                            correction_age=float(d["correction_age"]))
        if not self.sim.scenario.gnss_vel:
            return [("/gnss/fix", arrive, fix), ("/gnss/status", arrive, st)]
        return [("/gnss/fix", arrive, fix), ("/gnss/vel", arrive, vel), ("/gnss/status", arrive, st)]

    def _wheel(self, t, d):
        T = self.T
        cov = np.zeros(36)
        cov[0] = self.sim.wheel.variance
        cov[7] = cov[14] = cov[21] = cov[28] = cov[35] = UNKNOWN_VARIANCE
        msg = T["nav_msgs/msg/Odometry"](
            header=self.header(t, "odom"), child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](
                pose=T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
                                                 orientation=self._quat((0.0, 0.0, 0.0))),
                covariance=np.eye(6).ravel() * UNKNOWN_VARIANCE),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](linear=self._vec((d["speed"], 0.0, 0.0)),
                                                   angular=self._vec((0.0, 0.0, 0.0))), covariance=cov))
        return [("/wheel/odometry", t, msg)]

    def serialize(self, topic, msg):
        """CDR bytes of msg for topic."""
        return bytes(self.ts.serialize_cdr(msg, MESSAGE_TYPES[topic]))



def run_rows(sim, on_sample=None):
    """(factory, [(publish time s, topic, msg)]) of running `sim` to its end with its built-in driver, in the order a
    bag holds them (latched messages first; sensors at their stamp, GNSS at its arrival); on_sample(kind, stamp,
    data) sees every simulator sample."""
    factory = MessageFactory(sim)
    rows = [(0.0, topic, msg) for topic, msg in factory.static()]
    while not sim.done:
        for sample in sim.step():
            if on_sample:
                on_sample(*sample)
            rows.extend((when, topic, msg) for topic, when, msg in factory.convert(*sample))
    rows.sort(key=lambda r: r[0])
    return factory, rows
