"""Outputs every agnav navigation node shares: the /map_datum message, the map->odom->base_link transforms and the
base_link velocity of a state."""
import math

from sensor_msgs.msg import NavSatFix, NavSatStatus

from agnav_common.tf import make_transform

IDENTITY = (0.0, 0.0, 0.0, 1.0)


def map_datum_message(lat, lon, alt, frame_id, stamp):
    """NavSatFix of the geodetic origin of `map` (INTERFACES /map_datum)."""
    msg = NavSatFix()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp
    msg.latitude, msg.longitude, msg.altitude = float(lat), float(lon), float(alt)
    msg.status.status = NavSatStatus.STATUS_FIX
    msg.position_covariance_type = NavSatFix.COVARIANCE_TYPE_UNKNOWN
    return msg


def pose_transforms(frames, stamp, position, quat, map_to_odom=((0.0, 0.0, 0.0), IDENTITY)):
    """map->odom (default identity) and odom->base_link (xyz, quaternion xyzw) transforms."""
    return [make_transform(frames["map"], frames["odom"], stamp, *map_to_odom),
            make_transform(frames["odom"], frames["base"], stamp, position, quat)]


def body_velocity(state):
    """(vx, vy, twist covariance 6x6) in base_link of a state moving at `speed` along its course, the heading turned
    by the crab (course = yaw - crab): vy = -speed sin(crab) is the side slip steering can feed forward."""
    cov = state.twist_cov
    if not math.isfinite(state.crab_var):
        return float(state.speed), 0.0, cov
    cov = cov.copy()
    cov[1, 1] = max(cov[1, 1], state.speed ** 2 * state.crab_var)
    return float(state.speed * math.cos(state.crab)), float(-state.speed * math.sin(state.crab)), cov
