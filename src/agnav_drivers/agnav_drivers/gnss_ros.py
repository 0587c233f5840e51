"""ROS publishing of the plain GNSS events (shared by the NMEA and UBX nodes)."""
from __future__ import annotations

import math
from dataclasses import dataclass

from geometry_msgs.msg import TwistWithCovarianceStamped
from sensor_msgs.msg import Imu, NavSatFix, NavSatStatus, TimeReference

from agnav_common.frames import quaternion_from_euler, yaw_from_heading
from agnav_common.qos import PUBLISHER_QOS
from agnav_common.stamps import to_stamp
from agnav_msgs.msg import GnssStatus

from . import gnss_types as g
from .stream_driver import StreamSettings

NAVSAT_STATUS = {g.FIX_SINGLE: NavSatStatus.STATUS_FIX, g.FIX_DGPS: NavSatStatus.STATUS_SBAS_FIX,
                 g.FIX_RTK_FLOAT: NavSatStatus.STATUS_GBAS_FIX, g.FIX_RTK_FIXED: NavSatStatus.STATUS_GBAS_FIX}
UNKNOWN = g.UNKNOWN_VARIANCE  # variance of an axis the receiver does not give (INTERFACES)


@dataclass
class GnssStreamSettings(StreamSettings):
    frame_id: str = "gnss_link"  # antenna frame of the messages (static TF base_link -> gnss_link)
    service: int = NavSatStatus.SERVICE_GPS  # NavSatStatus.service bitmask (1 GPS, 2 GLONASS, 4 COMPASS, 8 GALILEO)
    heading_std: float = 1.0     # deg, heading/attitude sigma on /gnss/heading when the receiver gives none


class GnssPublishers:
    """/gnss/fix, /gnss/vel, /gnss/status, /gnss/heading (Imu, orientation only), /gnss/time_reference."""

    def __init__(self, node, settings: GnssStreamSettings):
        self.node = node
        self.frame_id = settings.frame_id
        self.service = settings.service
        self.heading_std = math.radians(settings.heading_std)
        self.fix = node.create_publisher(NavSatFix, "gnss/fix", PUBLISHER_QOS)
        self.vel = node.create_publisher(TwistWithCovarianceStamped, "gnss/vel", PUBLISHER_QOS)
        self.status = node.create_publisher(GnssStatus, "gnss/status", PUBLISHER_QOS)
        self.heading = node.create_publisher(Imu, "gnss/heading", PUBLISHER_QOS)
        self.time_ref = node.create_publisher(TimeReference, "gnss/time_reference", PUBLISHER_QOS)
        self.last_fix_type = g.FIX_NONE
        self._handlers = {g.GnssFix: self._fix, g.GnssVelocity: self._vel, g.GnssFixStatus: self._status,
                          g.GnssAttitude: self._attitude, g.ReceiverTime: self._time}

    def publish(self, event) -> bool:
        handler = self._handlers.get(type(event))
        if handler is None:
            return False
        handler(event)
        return True

    def _header(self, msg, event):
        msg.header.stamp = self.node.stamp(event.host_time, event.receiver_time)
        msg.header.frame_id = self.frame_id

    def _fix(self, e: g.GnssFix):
        msg = NavSatFix()
        self._header(msg, e)
        msg.status.service = self.service
        status = NAVSAT_STATUS.get(e.fix_type)
        if status is None or not g.finite(e.latitude, e.longitude, e.altitude):
            # no position solution: NavSatFix convention, never a real-looking position or a known covariance
            msg.status.status = NavSatStatus.STATUS_NO_FIX
            msg.latitude = msg.longitude = msg.altitude = math.nan
            msg.position_covariance_type = NavSatFix.COVARIANCE_TYPE_UNKNOWN
        else:
            msg.status.status = status
            msg.latitude, msg.longitude, msg.altitude = e.latitude, e.longitude, e.altitude
            msg.position_covariance = [float(v) for v in e.covariance]
            msg.position_covariance_type = e.covariance_type
        self.fix.publish(msg)

    def _vel(self, e: g.GnssVelocity):
        msg = TwistWithCovarianceStamped()
        self._header(msg, e)
        msg.twist.twist.linear.x, msg.twist.twist.linear.y, msg.twist.twist.linear.z = e.east, e.north, e.up
        cov = [0.0] * 36
        for r in range(3):
            for c in range(3):
                cov[6 * r + c] = float(e.covariance[3 * r + c])
            cov[6 * (r + 3) + r + 3] = UNKNOWN
        msg.twist.covariance = cov
        self.vel.publish(msg)

    def _status(self, e: g.GnssFixStatus):
        msg = GnssStatus()
        self._header(msg, e)
        msg.fix_type = e.fix_type
        msg.satellites_used = min(max(e.satellites_used, 0), 255)
        msg.hdop = float(e.hdop)
        msg.correction_age = float(e.correction_age)
        self.last_fix_type = e.fix_type
        self.status.publish(msg)

    def _attitude(self, e: g.GnssAttitude):
        """Receiver heading (clockwise from north), pitch (nose up), roll -> REP-103 quaternion."""
        msg = Imu()
        self._header(msg, e)
        roll = math.radians(e.roll) if e.roll is not None else 0.0
        pitch = -math.radians(e.pitch) if e.pitch is not None else 0.0
        yaw = float(yaw_from_heading(math.radians(e.heading)))
        q = quaternion_from_euler(roll, pitch, yaw)
        msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w = q

        def var(value, std_deg, default):
            if value is None:
                return UNKNOWN
            return math.radians(std_deg) ** 2 if std_deg else default ** 2
        cov = [0.0] * 9
        cov[0] = var(e.roll, e.roll_std, self.heading_std)
        cov[4] = var(e.pitch, e.pitch_std, self.heading_std)
        cov[8] = var(e.heading, e.heading_std, self.heading_std)
        msg.orientation_covariance = cov
        msg.angular_velocity_covariance[0] = -1.0
        msg.linear_acceleration_covariance[0] = -1.0
        self.heading.publish(msg)

    def _time(self, e: g.ReceiverTime):
        msg = TimeReference()
        msg.header.stamp = self.node.stamp(e.host_time)
        msg.header.frame_id = self.frame_id
        msg.time_ref = to_stamp(e.receiver_time)
        msg.source = e.source
        self.time_ref.publish(msg)

