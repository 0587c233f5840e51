"""A bag through the navigation pipeline without ROS, exactly as nav_sensor_module_node runs it: the node's settings
from the graph config's parameters, mounts from the config's static transforms and the bag's /tf_static, every input
message in log order to the same NavigationPipeline method the node's subscription calls, and the states the node
would publish. Benchmarks use it where they need the pipeline's insides (RTS smoother, cost per sample);
test_offline_equals_graph checks it against `agnav run` on the same bag.
"""
from agnav_common.bagio import typestore
from agnav_common.frames import rotation_matrix
from agnav_common.parameters import apply
from agnav_fusion.nav_sensor_module import NavSensorModule, NavSensorModuleSettings
from agnav_fusion.pipeline import FrontEndSettings, NavigationPipeline
from rosbags.highlevel import AnyReader
from scipy.spatial.transform import Rotation

INPUTS = {"/imu/data_raw": "on_imu", "/inclinometer": "on_inclinometer", "/gnss/fix": "on_fix",
          "/gnss/vel": "on_velocity", "/wheel/odometry": "on_wheel"}
NODE = "nav_sensor_module_node"


def node_parameters(config, executable=NODE):
    spec = next((n for n in config.nodes if n.executable == executable), None)
    if spec is None:
        raise ValueError(f"config {config.name!r} runs no {executable}")
    return spec.parameters


def pipeline_for(config, executable=NODE):
    """The NavigationPipeline the config's navigation node builds (same parameters, same defaults)."""
    params = node_parameters(config, executable)
    return NavigationPipeline(NavSensorModule(apply(NavSensorModuleSettings(), params)),
                              apply(FrontEndSettings(), params))


def _mounts(config, tf_messages):
    """{(parent, child): (xyz, 3x3 rotation)}: the config's static transforms, then the bag's /tf_static."""
    edges = {(t["parent"], t["child"]): (t.get("xyz", [0, 0, 0]), rotation_matrix(*t.get("rpy", [0, 0, 0])))
             for t in config.static_transforms}
    for msg in tf_messages:
        for t in msg.transforms:
            tr, q = t.transform.translation, t.transform.rotation
            edges[(t.header.frame_id, t.child_frame_id)] = (
                [tr.x, tr.y, tr.z], Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix())
    return edges


def replay(config, bag, pipeline=None, frames=("base_link", "imu_link", "gnss_link", "inclinometer_link")):
    """States the navigation node publishes for `bag` (list), and the pipeline (its backend holds the insides)."""
    pipeline = pipeline or pipeline_for(config)
    remap = config.bag_remap
    with AnyReader([bag], default_typestore=typestore()) as reader:
        topic_of = {c.id: remap.get(c.topic, c.topic) for c in reader.connections}
        wanted = [c for c in reader.connections if topic_of[c.id] in INPUTS or topic_of[c.id] == "/tf_static"]
        tf_static = [reader.deserialize(raw, c.msgtype) for c, _, raw in
                     reader.messages(connections=[c for c in wanted if topic_of[c.id] == "/tf_static"])]
        edges = _mounts(config, tf_static)
        base, imu, gnss, incl = frames
        if (base, imu) not in edges or (base, gnss) not in edges:
            raise ValueError(f"{bag}: no mount for {imu} or {gnss}")
        incl_xyz = edges.get((base, incl), edges[(base, imu)])[0]
        pipeline.set_mounts(edges[(base, imu)][1], edges[(base, gnss)][0], incl_xyz)
        pipeline.start()
        published = []
        for c, _, raw in reader.messages(connections=[c for c in wanted if topic_of[c.id] in INPUTS]):
            method = INPUTS[topic_of[c.id]]
            state = getattr(pipeline, method)(reader.deserialize(raw, c.msgtype))
            if method == "on_imu" and state is not None and pipeline.ready(state):
                published.append(state)
    return published, pipeline
