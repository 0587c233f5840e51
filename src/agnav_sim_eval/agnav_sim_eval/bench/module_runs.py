"""The shipped navigation pipeline on a simulated run, for the benchmarks: the run's own ROS messages (simulate(...,
messages=True), in the order of its bag) through nav_sensor_module_node's NavigationPipeline with config nsm's
parameters (agnav_sim_eval.offline), estimates returned as arrays at every IMU message in the scenario's map frame."""
import dataclasses
import time

import numpy as np

from agnav_sim_eval import offline
from agnav_bringup.graph_config import load_config
from agnav_common.geodesy import LocalTangentPlane
from agnav_common.parameters import leaves
from agnav_sim_eval.sim.messages import START_EPOCH_S

NSM = load_config("nsm")  # the shipped graph whose navigation node every module row runs
UNCALIBRATED = {"incl_zero_deg": (0.0, 0.0)}


def _parameters(overrides):
    """run_module overrides (settings fields, nested settings dataclasses) as the node's flat parameters."""
    params = {}
    for name, value in overrides.items():
        if dataclasses.is_dataclass(value):
            params.update({n: v for n, v, _ in leaves(value, name + ".")})
        else:
            params[name] = [float(v) for v in value] if isinstance(value, (tuple, list, np.ndarray)) else value
    return params


def sim_rows(run, outage=None, latency=True):
    """(topic, msg) of a run simulated with messages=True, in bag order; fixes of epochs in `outage` (s) dropped;
    latency=False: GNSS messages at their epoch instead of their arrival."""
    rows = []
    for when, topic, msg in run.messages:
        if topic.startswith("/gnss/"):
            epoch = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9 - START_EPOCH_S
            if outage is not None and outage[0] <= epoch < outage[1]:
                continue
            when = when if latency else epoch
        rows.append((when, topic, msg))
    return [(topic, msg) for _, topic, msg in sorted(rows, key=lambda r: r[0])]


def run_module(run, estimator="agnav", outage=None, latency=True, prepare=None, **overrides):
    """The run's messages through the shipped navigation pipeline of config nsm (agnav_sim_eval.offline: the node's
    parameters, message order and fix handling), estimator and `overrides` (settings fields) replacing parameters;
    prepare(backend) runs before the replay. Returns arrays at every IMU message and the cost per message."""
    pipeline = offline.pipeline_for(NSM, estimator=estimator, **_parameters(overrides))
    if prepare:
        prepare(pipeline.backend)
    rows = sim_rows(run, outage, latency)
    start = time.perf_counter()
    states = offline.run_rows(pipeline, NSM, rows)
    cost = (time.perf_counter() - start) / len(states) * 1e6
    # the node's map is at its datum (config nsm: the first fix), truth at the scenario's: as agnav eval does
    plane = pipeline.plane
    east, north, _ = LocalTangentPlane(*run.datum).to_enu(plane.lat_deg, plane.lon_deg, plane.alt_m)
    a = np.array([(s.position[0] + east, s.position[1] + north, s.rpy[0], s.rpy[1], s.rpy[2], pipeline.ready(s),
                   *np.diag(s.pose_cov)[[0, 1, 3, 4, 5]]) for s in states])
    return dict(x=a[:, 0], y=a[:, 1], roll=a[:, 2], pitch=a[:, 3], yaw=a[:, 4], valid=a[:, 5] > 0,
                var_x=a[:, 6], var_y=a[:, 7], var_roll=a[:, 8], var_pitch=a[:, 9], var_yaw=a[:, 10], us=cost,
                counters=pipeline.backend.counters, module=pipeline.backend)
