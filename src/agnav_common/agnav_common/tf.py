"""Small TF helper (tf2_ros is not on PyPI): static mounts lookup, broadcasters, transform builder."""
import numpy as np
from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage

from agnav_common.qos import LATCHED_QOS


def make_transform(parent, child, stamp, xyz, quat):
    """TransformStamped parent->child with translation xyz and quaternion (x, y, z, w)."""
    t = TransformStamped()
    t.header.stamp = stamp
    t.header.frame_id = parent
    t.child_frame_id = child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = (float(v) for v in xyz)
    (t.transform.rotation.x, t.transform.rotation.y,
     t.transform.rotation.z, t.transform.rotation.w) = (float(v) for v in quat)
    return t


class TfBuffer:
    """Latest transform per (parent, child) from /tf_static and /tf; direct edges only (sensor mounts)."""

    def __init__(self, node):
        self._edges = {}
        node.create_subscription(TFMessage, "/tf_static", self._on_tf, LATCHED_QOS)
        node.create_subscription(TFMessage, "/tf", self._on_tf, 100)

    def _on_tf(self, msg):
        for t in msg.transforms:
            tr, q = t.transform.translation, t.transform.rotation
            self._edges[(t.header.frame_id, t.child_frame_id)] = (
                np.array([tr.x, tr.y, tr.z]), np.array([q.x, q.y, q.z, q.w]))

    def lookup(self, parent, child):
        """(xyz ndarray, quaternion xyzw ndarray) of parent->child, identity for equal frames, else None."""
        if parent == child:
            return np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0])
        return self._edges.get((parent, child))

    def lookup_mounts(self, parent, *children):
        """[lookup(parent, child) for each child], or None until every one of them is known."""
        found = [self.lookup(parent, child) for child in children]
        return None if any(f is None for f in found) else found


class StaticTransformPublisher:
    """Publishes static transforms on /tf_static (transient-local), accumulating across calls."""

    def __init__(self, node):
        self._pub = node.create_publisher(TFMessage, "/tf_static", LATCHED_QOS)
        self._transforms = {}

    def send(self, transforms):
        for t in transforms:
            self._transforms[(t.header.frame_id, t.child_frame_id)] = t
        self._pub.publish(TFMessage(transforms=list(self._transforms.values())))


class TransformBroadcaster:
    """Publishes dynamic transforms on /tf."""

    def __init__(self, node):
        self._pub = node.create_publisher(TFMessage, "/tf", 100)

    def send(self, transforms):
        self._pub.publish(TFMessage(transforms=list(transforms)))
