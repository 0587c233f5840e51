"""Small TF helper (tf2_ros is not on PyPI): transform lookup along the TF tree, broadcasters, transform builder."""
import numpy as np
from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage

from agnav_common.message_factory import new_message
from agnav_common.qos import LATCHED_QOS, create_output


def make_transform(parent, child, stamp, xyz, quat):
    """TransformStamped parent->child with translation xyz and quaternion (x, y, z, w)."""
    t = new_message(TransformStamped)
    t.header.stamp = stamp
    t.header.frame_id = parent
    t.child_frame_id = child
    tr, rot = t.transform.translation, t.transform.rotation
    tr.x, tr.y, tr.z = map(float, xyz)
    rot.x, rot.y, rot.z, rot.w = map(float, quat)
    return t


class TfBuffer:
    """Latest transform per frame from /tf_static and /tf, composed along the tree (e.g. base_link -> mast ->
    gnss_link from a URDF's robot_state_publisher); stamps are ignored (latest value of every edge)."""

    def __init__(self, node=None, dynamic=False):
        """dynamic: also /tf (moving joints); sensor mounts come from /tf_static alone, which spares a node the
        100 Hz /tf of the navigation output."""
        self._parent = {}  # child frame -> (parent frame, xyz ndarray, quaternion xyzw ndarray)
        if node is not None:
            node.create_subscription(TFMessage, "/tf_static", self.add, LATCHED_QOS)
            if dynamic:
                node.create_subscription(TFMessage, "/tf", self.add, 100)

    def add(self, msg):
        """Takes a TFMessage (the /tf and /tf_static callback)."""
        for t in msg.transforms:
            tr, q = t.transform.translation, t.transform.rotation
            self._parent[t.child_frame_id] = (
                t.header.frame_id, np.array([tr.x, tr.y, tr.z]), np.array([q.x, q.y, q.z, q.w]))

    def _to_ancestors(self, frame):
        """{ancestor: (xyz, quat) of ancestor->frame} for frame itself (None: identity) and every frame above it."""
        chain, xyz, quat = {frame: None}, None, None
        while frame in self._parent:
            parent, t, q = self._parent[frame]
            if parent in chain:  # a cycle in bad TF data: stop climbing
                break
            xyz, quat = (t, q) if xyz is None else _compose((t, q), (xyz, quat))
            chain[parent], frame = (xyz, quat), parent
        return chain

    def lookup(self, parent, child):
        """(xyz ndarray, quaternion xyzw ndarray) of parent->child (child's origin and axes in parent), through
        any chain of edges in either direction; identity for equal frames; None while they are not connected."""
        if parent == child:
            return np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0])
        from_child = self._to_ancestors(child)
        from_parent = self._to_ancestors(parent)
        common = next((f for f in from_child if f in from_parent), None)
        if common is None:
            return None
        up, down = from_parent[common], from_child[common]  # common->parent, common->child
        if up is None:
            return down
        inv = _inverse(up)
        return inv if down is None else _compose(inv, down)

    def lookup_mounts(self, parent, *children):
        """[lookup(parent, child) for each child], or None until every one of them is known."""
        found = [self.lookup(parent, child) for child in children]
        return None if any(f is None for f in found) else found


def _compose(a, b):
    """a∘b for transforms (xyz, quat xyzw): frame A->B then B->C gives A->C."""
    from scipy.spatial.transform import Rotation  # only for chains of frames: most graphs start without scipy
    ra = Rotation.from_quat(a[1])
    return ra.apply(b[0]) + a[0], (ra * Rotation.from_quat(b[1])).as_quat()


def _inverse(a):
    """B->A from A->B."""
    from scipy.spatial.transform import Rotation
    r = Rotation.from_quat(a[1]).inv()
    return -r.apply(a[0]), r.as_quat()


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
        self._pub = create_output(node, TFMessage, "/tf", 100)

    def send(self, transforms):
        msg = new_message(TFMessage)
        msg.transforms = list(transforms)
        self._pub.publish(msg)
