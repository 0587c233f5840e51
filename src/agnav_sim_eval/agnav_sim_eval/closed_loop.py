"""Offline closed loop (ROS-free): TractorSimulator -> sensor samples -> estimator -> controller -> steering.
The operator drives the first metres (the simulator's route driver), then engages; the run is scored on the
true base_link cross-track to the desired line (the scenario route, offset by line_offset). The watchdog has the
steering node's default gates and hears the receiver class (/gnss/status fix type) as the node does.
estimator: "nav" (the navigation node's pipeline on RTK/DGPS scenarios, the VWA on GDS ones) or "truth"
(perfect state: true pose, speed and lateral speed, to test the steering alone)."""
import math
from dataclasses import dataclass, field, fields

import numpy as np
from agnav_control.controllers import CONTROLLERS, make_controller
from agnav_control.guidance_line import GuidanceLine, crab_angle
from agnav_control.limits import SteeringLimits
from agnav_control.watchdog import OdometrySample, Watchdog

from agnav_sim_eval.fusion_adapters import GdsSettings, GdsVwaEstimator, NsmEstimator, Pose
from agnav_sim_eval.sim import TractorSimulator


@dataclass
class ClosedLoopSettings:
    scenario: str = "rtk_straight_fast"
    seed: int = 0
    controller: str = "pid"
    gains: dict = field(default_factory=dict)  # scalar settings overrides of the controller
    tilt: bool = True                # GNSS antenna tilt correction (RTK scenarios)
    manual_distance: float = 3.0     # m driven by the operator before engaging (thesis: RTK 3 m, GDS 5 m)
    auto_distance: float = 150.0     # m scored after engaging
    line_offset: float = 0.0         # m, desired line left of the route: step response / settling
    control_rate: float = 0.0        # Hz; 0 = at every estimator output (as the node: at the odometry rate)
    gds_speed: float = 0.5           # m/s, v(k) of (2.7) for the GDS system (no odometer; thesis value)
    estimator: str = "nav"           # nav | truth (perfect state)
    crab_feed_forward: bool = True   # steer the course over ground (crab from the lateral speed), as the node


@dataclass
class ClosedLoopResult:
    t: np.ndarray           # s
    along: np.ndarray       # m along the desired line since engaging
    cross_track: np.ndarray  # m, true base_link cross-track (+ left)
    estimated: np.ndarray   # m, the controller's cross-track
    steering: np.ndarray    # rad, commanded
    disengaged: str | None  # watchdog reason if it ended the run early
    gnss_error: np.ndarray = field(default_factory=lambda: np.zeros(0))  # m, fix error across the line while engaged
    engaged_at: float = math.nan  # m travelled when the engage request was granted (the fusion had converged)

    @property
    def mean(self) -> float:
        return float(np.mean(self.cross_track))

    @property
    def rms(self) -> float:
        return float(np.sqrt(np.mean(self.cross_track**2)))

    @property
    def max_abs(self) -> float:
        return float(np.max(np.abs(self.cross_track)))

    def settling_distance(self, band: float = 0.1) -> float:
        """Distance after engaging beyond which |cross-track| stays inside band (m); inf if never."""
        outside = np.nonzero(np.abs(self.cross_track) > band)[0]
        if len(outside) == 0:
            return 0.0
        return float(self.along[outside[-1] + 1]) if outside[-1] + 1 < len(self.along) else math.inf

    def summary(self) -> dict:
        return {"rms_cm": 100 * self.rms, "max_cm": 100 * self.max_abs, "distance_m": float(self.along[-1]),
                "settling_m": self.settling_distance()}


def _controller(settings: ClosedLoopSettings, vehicle):
    known = {f.name for f in fields(CONTROLLERS[settings.controller][1])}
    gains = dict(settings.gains)
    if "wheelbase" in known:
        gains.setdefault("wheelbase", vehicle.wheelbase_m)
    limits = SteeringLimits(max_angle=vehicle.max_steer_rad, max_rate=vehicle.steer_rate_rad_s)
    return make_controller(settings.controller, limits=limits, **gains)


class TruthEstimator:
    """Perfect state: the simulator's true base_link pose, forward and lateral speed, with tiny variances."""

    VAR = 1e-8

    def __init__(self, sim):
        self.sim = sim

    @staticmethod
    def feed_order(sample):
        return 0

    def feed(self, kind: str, stamp: float, data: dict):
        pass

    def pose(self) -> Pose:
        tr = self.sim.truth_state()
        c, s = math.cos(tr["yaw"]), math.sin(tr["yaw"])
        forward, lateral = c * tr["vx"] + s * tr["vy"], -s * tr["vx"] + c * tr["vy"]
        return Pose(tr["t"], OdometrySample(tr["x"], tr["y"], tr["yaw"], forward, self.VAR, self.VAR,
                                            lateral_speed=lateral))


def _estimator(settings, sim, line_yaw):
    sc = sim.scenario
    if settings.estimator == "truth":
        return TruthEstimator(sim)
    if settings.estimator != "nav":
        raise ValueError(f"estimator must be nav | truth, not {settings.estimator!r}")
    if sc.gnss is not None:
        return NsmEstimator(sim, settings.tilt)
    return GdsVwaEstimator(sc, line_yaw, GdsSettings(speed=settings.gds_speed))


def run(settings: ClosedLoopSettings) -> ClosedLoopResult:
    """Simulate one engaged straight run and return its trace."""
    sim = TractorSimulator(settings.scenario, settings.seed)
    sc = sim.scenario
    route = np.asarray(sc.route, dtype=float)
    line = GuidanceLine.from_points(route[0], route[-1]).offset(settings.line_offset)
    score_line = line
    absolute = sc.gnss is not None or settings.estimator == "truth"  # an absolute position: the line stays put
    est = _estimator(settings, sim, line.yaw)
    controller = _controller(settings, sc.vehicle)
    watchdog = Watchdog()
    period = 1.0 / settings.control_rate if settings.control_rate > 0 else 0.0
    command, next_control, last_control, start, engaged_at = None, -math.inf, None, None, math.nan
    rows, reason, gnss_errors = [], None, []
    while not sim.done:
        for kind, stamp, data in sorted(sim.step(command if watchdog.engaged else None), key=est.feed_order):
            if kind != "truth":
                est.feed(kind, stamp, data)
            if kind == "gnss":
                watchdog.fix_type = data["fix_type"]  # /gnss/status
            if kind == "gnss" and watchdog.engaged:
                gnss_errors.append(score_line.error(*data["enu"][:2], 0.0, 0.0).cross_track
                                   - score_line.error(*data["truth_enu"][:2], 0.0, 0.0).cross_track)
        truth = sim.truth_state()
        pose = est.pose()
        if pose is None or truth["t"] < next_control:
            continue
        t, odo = pose.t, pose.sample
        dt = 0.0 if last_control is None else t - last_control
        next_control, last_control = t + period - 1e-9, t
        watchdog.odometry(t, odo)
        if start is None and sim.travelled >= settings.manual_distance:
            if watchdog.request_engage(t)[0]:
                controller.reset()
                if not absolute:  # no absolute position: the target line starts where the system engages
                    line = GuidanceLine(odo.x, odo.y, line.yaw)
                start = score_line.error(truth["x"], truth["y"], truth["yaw"], 0.0).along_track
                engaged_at = sim.travelled
        drive = sim.driver.params
        if sim.driver.length - sim.travelled <= drive.speed_mps ** 2 / (2 * drive.accel_mps2):
            break  # the route's final braking: the run is over (the watchdog's stop at low speed is no fault)
        if start is not None and not watchdog.engaged:
            reason = watchdog.transitions[-1].reason
            break
        if not watchdog.engaged:
            continue
        crab = crab_angle(odo.speed, odo.lateral_speed) if settings.crab_feed_forward else 0.0
        err = line.error(odo.x, odo.y, odo.yaw, odo.speed, crab=crab)
        command = controller.update(err, dt)
        true = score_line.error(truth["x"], truth["y"], truth["yaw"], truth["speed"])
        rows.append((t, true.along_track - start, true.cross_track, err.cross_track, command))
        if true.along_track - start >= settings.auto_distance:
            break
    if not rows:
        raise RuntimeError(f"never engaged in {settings.scenario} ({watchdog.fault})")
    t, along, cross, est_cross, steer = (np.array(c) for c in zip(*rows))
    return ClosedLoopResult(t, along, cross, est_cross, steer, reason, np.array(gnss_errors), engaged_at)
