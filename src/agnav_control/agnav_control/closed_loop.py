"""Offline closed loop (ROS-free): TractorSimulator -> sensor samples -> estimator -> controller -> steering.
The operator drives the first metres (the simulator's route driver), then engages; the run is scored on the
true base_link cross-track to the desired line (the scenario route, offset by line_offset)."""
import math
from dataclasses import dataclass, field, fields

import numpy as np
from agnav_drivers.sim import TractorSimulator

from .controllers import CONTROLLERS, make_controller
from .guidance_line import GuidanceLine, TrackingError
from .limits import SteeringLimits
from .sim_estimators import GdsVwaEstimator, RtkEstimator
from .watchdog import OdometrySample, Watchdog


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


@dataclass
class ClosedLoopResult:
    t: np.ndarray           # s
    along: np.ndarray       # m along the desired line since engaging
    cross_track: np.ndarray  # m, true base_link cross-track (+ left)
    estimated: np.ndarray   # m, the controller's cross-track
    steering: np.ndarray    # rad, commanded
    disengaged: str | None  # watchdog reason if it ended the run early

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


def run(settings: ClosedLoopSettings) -> ClosedLoopResult:
    """Simulate one engaged straight run and return its trace."""
    sim = TractorSimulator(settings.scenario, settings.seed)
    sc = sim.scenario
    route = np.asarray(sc.route, dtype=float)
    line = GuidanceLine.from_points(route[0], route[-1]).offset(settings.line_offset)
    rtk = sc.gnss is not None
    est = RtkEstimator(sc.datum, sc.mounts["gnss_link"][0], 1.0 / sc.gnss.rate_hz, settings.tilt) if rtk else GdsVwaEstimator()
    controller = _controller(settings, sc.vehicle)
    watchdog = Watchdog()
    period = 1.0 / settings.control_rate if settings.control_rate > 0 else 0.0
    command, next_control, last_control, eps, start = None, -math.inf, None, 0.0, None
    rows, reason = [], None
    while not sim.done:
        for kind, stamp, data in sim.step(command if watchdog.engaged else None):
            if kind != "truth":
                est.feed(kind, stamp, data)
        truth = sim.truth_state()
        t = truth["t"]
        if not est.ready or t < next_control:
            continue
        dt = 0.0 if last_control is None else t - last_control
        next_control, last_control = t + period - 1e-9, t
        if rtk:
            odo = est.odometry()
            watchdog.odometry(t, OdometrySample(odo.x, odo.y, odo.yaw, odo.speed, odo.position_var, odo.yaw_var))
            err = line.error(odo.x, odo.y, odo.yaw, odo.speed)
        else:  # GDS system: heading deviation only; cross-track dead-reckoned with (2.7) at the fixed speed
            dphi = est.deviation
            if watchdog.engaged:
                eps += settings.gds_speed * dt * math.sin(dphi)
            err = TrackingError(-eps, -dphi, line.yaw, settings.gds_speed, 0.0)
            watchdog.odometry(t, OdometrySample(0.0, 0.0, 0.0, settings.gds_speed, 0.0, 0.0))
        if start is None and sim.travelled >= settings.manual_distance:
            if watchdog.request_engage(t)[0]:
                controller.reset()
                start = line.error(truth["x"], truth["y"], truth["yaw"], 0.0).along_track
        if start is not None and not watchdog.engaged:
            reason = watchdog.transitions[-1].reason
            break
        if not watchdog.engaged:
            continue
        command = controller.update(err, dt)
        true = line.error(truth["x"], truth["y"], truth["yaw"], truth["speed"])
        rows.append((t, true.along_track - start, true.cross_track, err.cross_track, command))
        if true.along_track - start >= settings.auto_distance:
            break
    if not rows:
        raise RuntimeError(f"never engaged in {settings.scenario} ({watchdog.fault})")
    t, along, cross, est_cross, steer = (np.array(c) for c in zip(*rows))
    return ClosedLoopResult(t, along, cross, est_cross, steer, reason)
