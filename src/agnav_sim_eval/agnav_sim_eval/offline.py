"""Messages through the navigation pipeline without ROS, exactly as nav_sensor_module_node runs them: the node's
settings from the graph config's parameters, mounts from the config's static transforms and /tf_static, every input
message in log order to the NavigationPipeline method the node's subscription calls. Benchmarks use it where they
need the pipeline's insides (RTS smoother, cost per sample); test_nsm_graph checks it against `agnav run`.
"""
from agnav_common.bagio import typestore
from agnav_common.frames import rotation_matrix
from agnav_fusion.backends import pipeline_from_parameters
from rosbags.highlevel import AnyReader
from scipy.spatial.transform import Rotation

INPUTS = {"/imu/data_raw": "on_imu", "/inclinometer": "on_inclinometer", "/gnss/fix": "on_fix",
          "/gnss/vel": "on_velocity", "/wheel/odometry": "on_wheel"}
RAW_INPUTS = {"/gnss/status": "on_status", "/gnss/raw_observations": "on_raw_observations",   # a raw_gnss backend's
              "/gnss/base/observations": "on_base_observations", "/gnss/nav_data": "on_nav_data",
              "/gnss/base/position": "on_base_position"}
IMU = "/imu/data_raw"
NODE = "nav_sensor_module_node"
FRAMES = ("base_link", "imu_link", "gnss_link", "inclinometer_link")


def node_parameters(config, executable=NODE):
    spec = next((n for n in config.nodes if n.executable == executable), None)
    if spec is None:
        raise ValueError(f"config {config.path} runs no {executable}")
    return spec.parameters


def pipeline_for(config, executable=NODE, **overrides):
    """The NavigationPipeline the config's navigation node builds (same parameters, same defaults); `overrides`
    replace parameters by name (e.g. estimator="thesis", incl_zero_deg=[...])."""
    return pipeline_from_parameters(dict(node_parameters(config, executable), **overrides))


def set_mounts(pipeline, config, tf_messages, frames=FRAMES):
    """Mounts as the node takes them from TF: the config's static transforms, then /tf_static."""
    edges = {(t["parent"], t["child"]): (t.get("xyz", [0, 0, 0]), rotation_matrix(*t.get("rpy", [0, 0, 0])))
             for t in config.static_transforms}
    for msg in tf_messages:
        for t in msg.transforms:
            tr, q = t.transform.translation, t.transform.rotation
            edges[(t.header.frame_id, t.child_frame_id)] = (
                [tr.x, tr.y, tr.z], Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix())
    base, imu, gnss, incl = frames
    if (base, imu) not in edges or (base, gnss) not in edges:
        raise ValueError(f"no mount for {imu} or {gnss}")
    pipeline.set_mounts(edges[(base, imu)][1], edges[(base, gnss)][0], edges.get((base, incl), edges[(base, imu)])[0],
                        edges[(base, imu)][0])
    pipeline.start()


def inputs(pipeline):
    """{topic: pipeline method} of the node's subscriptions for this pipeline's backend."""
    return {**INPUTS, **RAW_INPUTS} if pipeline.raw is not None else INPUTS


def feed(pipeline, topic, msg):
    """Hand one message to the pipeline as the node's subscription on `topic` does; the state of an IMU message."""
    method = inputs(pipeline).get(topic)
    return getattr(pipeline, method)(msg) if method else None


def run_rows(pipeline, config, rows, observe=None):
    """Feed (topic, msg) rows in order (the first /tf_static sets the mounts); -> [state of every IMU message].
    observe(topic, msg), when given, is called after each message fed (a benchmark's look at the pipeline)."""
    states, mounted = [], False
    for topic, msg in rows:
        if topic == "/tf_static" and not mounted:
            set_mounts(pipeline, config, [msg])
            mounted = True
        elif topic in inputs(pipeline):
            state = feed(pipeline, topic, msg)
            if topic == IMU:
                states.append(state)
            if observe:
                observe(topic, msg)
    return states


def replay(config, bag, pipeline=None, observe=None):
    """The states the navigation node publishes for `bag` (initialised ones), and the pipeline it ran (observe: as
    in run_rows)."""
    pipeline = pipeline or pipeline_for(config)
    remap, topics = config.bag_remap, inputs(pipeline)
    with AnyReader([bag], default_typestore=typestore()) as reader:
        topic_of = {c.id: remap.get(c.topic, c.topic) for c in reader.connections}
        statics = [c for c in reader.connections if topic_of[c.id] == "/tf_static"]
        streams = [c for c in reader.connections if topic_of[c.id] in topics]
        # (rosbags reads every connection for an empty list)
        tf_static = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=statics)
                     ] if statics else []
        set_mounts(pipeline, config, tf_static)
        rows = ((topic_of[c.id], reader.deserialize(raw, c.msgtype))
                for c, _, raw in (reader.messages(connections=streams) if streams else ()))
        states = run_rows(pipeline, config, rows, observe)
    return [s for s in states if s is not None and pipeline.ready(s)], pipeline
