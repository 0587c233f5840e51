"""Bag mutator for fault injection (no ROS): copy a rosbag2 with one fault applied to one input stream.

A `FaultCase` names a kind of fault, the topic it hits, its start `t0` (s after the bag's start, log time) and
its `duration` (s; 0: the first message on the topic at or after t0 only). Messages are matched by log time;
the mutated messages keep their log time, so the copy keeps the original log order (a duplicate follows its
original, a future/backwards stamp is a header stamp only). Other topics are copied untouched. `crop` drops
everything logged more than `crop` s after the start.

Kinds: nan, inf (gyro / fix lat+lon / GNSS velocity / magnetic field), zero_cov, negative_cov (fix
position_covariance, GNSS velocity covariance), zero_stamp, backwards_stamp and future_stamp (header stamp
shifted by -amount / +amount s), duplicate, drop (a gap; `also` lists further topics dropped with it: an outage),
stuck (the last good message repeated with the current stamps), step (fix moved `amount` m north), no_fix
(status -1, lat/lon 0), mag_offset (+amount T on the field's x), mag_rotate (field rotated amount deg about z).
"""
import copy
import math
from dataclasses import dataclass, field

import numpy as np

from agnav_common.bagio import typestore
from agnav_common.geodesy import LocalTangentPlane

KINDS = ("nan", "inf", "zero_cov", "negative_cov", "zero_stamp", "backwards_stamp", "future_stamp", "duplicate",
         "drop", "stuck", "step", "no_fix", "mag_offset", "mag_rotate")
IMU, FIX, VEL, MAG = ("sensor_msgs/msg/Imu", "sensor_msgs/msg/NavSatFix",
                      "geometry_msgs/msg/TwistWithCovarianceStamped", "sensor_msgs/msg/MagneticField")


@dataclass(frozen=True)
class FaultCase:
    name: str
    kind: str
    topic: str
    t0: float = 100.0       # s after the bag's first message (log time)
    duration: float = 0.0   # s; 0: one message
    amount: float = 0.0     # kind-specific: s (stamps), m (step), T (mag_offset), deg (mag_rotate)
    also: tuple = field(default_factory=tuple)  # further topics dropped with a `drop`

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"unknown fault kind {self.kind!r}; one of {', '.join(KINDS)}")

    @property
    def end(self):
        """s after the bag start at which the fault is over."""
        return self.t0 + self.duration


def _vectors(msg, msgtype):
    """The value vectors a nan/inf fault overwrites: (object, attribute names)."""
    if msgtype == IMU:
        return [(msg.angular_velocity, ("x", "y", "z"))]
    if msgtype == FIX:
        return [(msg, ("latitude", "longitude"))]
    if msgtype == VEL:
        return [(msg.twist.twist.linear, ("x", "y"))]
    if msgtype == MAG:
        return [(msg.magnetic_field, ("x", "y", "z"))]
    raise ValueError(f"no value fault for {msgtype}")


def _covariance(msg, msgtype):
    """(owner, attribute, diagonal indices) of the covariance a covariance fault rewrites."""
    if msgtype == FIX:
        return msg, "position_covariance", [0, 4, 8]
    if msgtype == VEL:
        return msg.twist, "covariance", [0, 7, 14]
    raise ValueError(f"no covariance fault for {msgtype}")


def _shift_stamp(msg, dt):
    ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec + round(dt * 1e9)
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(max(ns, 0), 1_000_000_000)


def mutate(case, msg, msgtype, last_good=None):
    """The messages to write in place of msg (a deserialized rosbags message; mutated in place or copied)."""
    kind = case.kind
    if kind == "drop":
        return []
    if kind == "duplicate":
        return [msg, msg]
    if kind in ("nan", "inf"):
        value = math.nan if kind == "nan" else math.inf
        for obj, names in _vectors(msg, msgtype):
            for name in names:
                setattr(obj, name, value)
    elif kind in ("zero_cov", "negative_cov"):
        owner, name, diag = _covariance(msg, msgtype)
        cov = np.array(getattr(owner, name), dtype=float)  # deserialized arrays are read-only
        if kind == "zero_cov":
            cov[:] = 0.0
        else:
            cov[diag] = -np.abs(cov[diag]) - 1e-3
        setattr(owner, name, cov)
    elif kind == "zero_stamp":
        msg.header.stamp.sec, msg.header.stamp.nanosec = 0, 0
    elif kind in ("backwards_stamp", "future_stamp"):
        _shift_stamp(msg, case.amount if kind == "future_stamp" else -case.amount)
    elif kind == "stuck":
        if last_good is not None:
            stamp = msg.header.stamp
            msg = copy.deepcopy(last_good)
            msg.header.stamp = stamp
    elif kind == "step":
        plane = LocalTangentPlane(msg.latitude, msg.longitude, msg.altitude)
        lat, lon, _ = plane.to_geodetic(0.0, case.amount, 0.0)
        msg.latitude, msg.longitude = float(lat), float(lon)
    elif kind == "no_fix":
        msg.status.status, msg.latitude, msg.longitude = -1, 0.0, 0.0
    elif kind == "mag_offset":
        msg.magnetic_field.x += case.amount
    elif kind == "mag_rotate":
        f, a = msg.magnetic_field, math.radians(case.amount)
        f.x, f.y = f.x * math.cos(a) - f.y * math.sin(a), f.x * math.sin(a) + f.y * math.cos(a)
    return [msg]


def mutate_bag(src, dst, case=None, crop=None):
    """Copy the rosbag2 at src to dst (mcap) with `case` applied (None: a clean copy) and cropped to `crop` s
    after the start. Returns {"start": bag start s, "hit": messages the fault touched, "written": messages}."""
    from rosbags.rosbag2 import Reader, Writer
    from rosbags.rosbag2.enums import StoragePlugin

    store = typestore()
    hit = written = 0
    last_good = None
    with Reader(src) as reader, Writer(dst, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        out = {c.id: writer.add_connection(c.topic, c.msgtype, typestore=store,
                                           offered_qos_profiles=c.ext.offered_qos_profiles)
               for c in reader.connections}
        start = reader.start_time
        a = b = None
        if case is not None:
            a, b = start + round(case.t0 * 1e9), start + round(case.end * 1e9)
        topics = {case.topic, *case.also} if case is not None else set()
        for c, t, raw in reader.messages():
            if crop is not None and t > start + round(crop * 1e9):
                continue
            inside = c.topic in topics and t >= a and (t < b if case.duration > 0 else hit == 0)
            if not inside:
                if c.topic == (case.topic if case else None) and t < a:
                    last_good = raw
                writer.write(out[c.id], t, raw)
                written += 1
                continue
            hit += 1
            if case.kind == "drop":
                continue
            msg = store.deserialize_cdr(raw, c.msgtype)
            good = store.deserialize_cdr(last_good, c.msgtype) if last_good is not None else None
            for m in mutate(case, msg, c.msgtype, good):
                writer.write(out[c.id], t, store.serialize_cdr(m, c.msgtype))
                written += 1
    return {"start": start * 1e-9, "hit": hit, "written": written}


def bag_span(path):
    """(first, last) log time of a rosbag2 in s."""
    from rosbags.rosbag2 import Reader
    with Reader(path) as reader:
        return reader.start_time * 1e-9, reader.end_time * 1e-9


def repeat_bag(src, dst, copies, once=("/tf_static", "/map_datum")):
    """Copy the rosbag2 at src `copies` times end to end into dst (a long replay for memory tests): copy k has
    log times and header stamps shifted by k × (the bag's length + 10 ms); `once` topics only from the first copy.
    Stamps are patched in the CDR bytes, so every other message must begin with a std_msgs/Header."""
    import struct

    from rosbags.rosbag2 import Reader, Writer
    from rosbags.rosbag2.enums import StoragePlugin

    store = typestore()
    with Reader(src) as reader, Writer(dst, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        out = {c.id: writer.add_connection(c.topic, c.msgtype, typestore=store,
                                           offered_qos_profiles=c.ext.offered_qos_profiles)
               for c in reader.connections}
        period = reader.end_time - reader.start_time + 10_000_000
        for k in range(copies):
            for c, t, raw in reader.messages():
                if k and c.topic in once:
                    continue
                if k:
                    sec, nsec = struct.unpack_from("<iI", raw, 4)  # after the 4-byte CDR encapsulation header
                    sec, nsec = divmod(sec * 1_000_000_000 + nsec + k * period, 1_000_000_000)
                    raw = bytearray(raw)
                    struct.pack_into("<iI", raw, 4, sec, nsec)
                writer.write(out[c.id], t + k * period, bytes(raw))
    return period * copies * 1e-9
