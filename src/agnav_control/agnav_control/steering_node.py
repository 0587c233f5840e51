"""Straight-line autosteer node: /odometry/filtered -> /guidance/state + /steering/command, with AB line
set/teach/engage services and the fail-safe watchdog (INTERFACES; issue 6).

Odometry stamps (issue 16): one StreamClock per stream rejects bad, backwards and lone future stamps and stamps
more than `watchdog.max_stamp_lead` s ahead of the reference time; the watchdog trips when the last stamp is more
than `watchdog.max_stamp_age` s behind it. The reference time is the node clock (sim time under use_sim_time);
without use_sim_time, a published /clock (a live simulator stamps on its own clock) is the reference instead."""
import inspect
import math
from dataclasses import dataclass, field, replace

from agnav_common.diagnostics import ERROR, OK, WARN, Diagnostics
from agnav_common.frames import euler_from_quaternion
from agnav_common.geodesy import LocalTangentPlane
from agnav_common.input_guard import EventWindow, StreamClock, StreamClockSettings
from agnav_common.node_main import main_for
from agnav_common.parameters import bounded, declare, leaves
from agnav_common.qos import LATCHED_QOS, PUBLISHER_QOS, SENSOR_QOS, subscribe_input
from agnav_common.stamps import to_sec
from agnav_common.variance_weighted_average import VwaSettings
from agnav_msgs.msg import GnssStatus, GuidanceState, SteeringCommand
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import NavSatFix
from std_msgs.msg import Header
from std_srvs.srv import SetBool, Trigger

from .controllers import CONTROLLERS
from .guidance_line import GuidanceLine, LineTeacher, ParallelPasses, VariableTargetLine, MAX_CRAB, crab_angle
from .limits import SteeringLimits
from .watchdog import Watchdog, WatchdogSettings, odometry_sample

MAX_DT = 0.5  # s, longest controller step accepted between two odometry messages


@dataclass
class SteeringWatchdog(WatchdogSettings):
    rate: float = field(default=100.0, metadata=bounded(0.1, 1000.0))  # Hz of the watchdog timer
    max_stamp_jump: float = 1.0  # s, a larger step of the odometry stamps is held until 3 stamps confirm it
    max_stamp_lead: float = 0.1  # s an odometry stamp may lie ahead of the reference time


_TEACHER = inspect.signature(LineTeacher).parameters


@dataclass
class TeachSettings:
    min_distance: float = _TEACHER["min_distance"].default    # m to drive before a taught line is accepted
    heading_source: str = _TEACHER["heading_source"].default  # yaw (mean odometry yaw) | track (start-to-end)


@dataclass
class VariableTarget(VwaSettings):
    window: float = VwaSettings.window      # s, T: the VWA window of the variable target line (Table 2.5)
    interval: float = VwaSettings.interval  # s, ΔT: target update interval
    enabled: bool = False                   # move the line to the VWA target while engaged (thesis ch. II)


@dataclass
class LineSettings:
    frame: str = "map"                  # frame of a and b: map (x, y in m) | latlon (deg, at /map_datum)
    a: list = field(default_factory=lambda: [0.0, 0.0])  # m or deg, point A of the AB line (x, y or lat, lon)
    b: list = field(default_factory=lambda: [0.0, 0.0])  # m or deg, point B; a == b: no line from parameters


@dataclass
class EventWindowSettings:
    window: float = 10.0  # s of recent odometry rejections that /diagnostics describes


@dataclass
class SteeringNodeSettings:
    controller: str = "pid"  # steering law: one of CONTROLLERS (thesis_pi, pid, stanley, pure_pursuit)
    max_steering_angle: float = SteeringLimits.max_angle  # rad, largest front-wheel angle commanded either way
    max_steering_rate: float = SteeringLimits.max_rate    # rad/s, slew limit of the wheel angle; 0 disables it
    watchdog: SteeringWatchdog = field(default_factory=SteeringWatchdog)
    diagnostics: EventWindowSettings = field(default_factory=EventWindowSettings)
    bidirectional: bool = True      # follow the line in whichever direction the vehicle drives along it
    implement_width: float = 0.0    # m between parallel passes (steering/next_pass); 0: the AB line only
    teach: TeachSettings = field(default_factory=TeachSettings)
    variable_target: VariableTarget = field(default_factory=VariableTarget)
    line: LineSettings = field(default_factory=LineSettings)
    engage_when_ready: bool = False  # engage once, at the first healthy odometry with a line (unattended runs)
    crab_feed_forward: bool = True   # steer the course over ground: crab = atan(twist linear.y / linear.x)
    max_crab: float = field(default=MAX_CRAB, metadata=bounded(0.0, 1.0))  # rad, clamp of that crab angle


def _controller_settings():
    """{name: settings} of every controller, actuator limits left out (shared: max_steering_*)."""
    return {name: settings_cls() for name, (_, settings_cls) in CONTROLLERS.items()}


def parameter_entries():
    """[(name, default, description)] of every parameter (tools/gen_params.py writes the params file from it)."""
    return leaves(SteeringNodeSettings()) + [entry for name, settings in _controller_settings().items()
                                             for entry in leaves(settings, f"{name}.", skip=("limits",))]


class SteeringNode(Node):
    def __init__(self, **kwargs):
        super().__init__("steering_node", **kwargs)
        s = declare(self, SteeringNodeSettings())
        gains = {name: declare(self, settings, f"{name}.", skip=("limits",))
                 for name, settings in _controller_settings().items()}
        self.controller_name = s.controller
        if self.controller_name not in CONTROLLERS:
            raise ValueError(f"controller must be one of {sorted(CONTROLLERS)}")
        LineTeacher(s.teach.min_distance, s.teach.heading_source)  # refuses a bad heading_source at start
        if s.line.frame not in ("map", "latlon"):
            raise ValueError("line.frame must be map | latlon")
        limits = SteeringLimits(s.max_steering_angle, s.max_steering_rate)
        self.controller = CONTROLLERS[self.controller_name][0](replace(gains[self.controller_name], limits=limits))
        self.limits = limits
        self.watchdog = Watchdog(s.watchdog, on_transition=self._on_transition)
        self.stamps = StreamClock(StreamClockSettings(max_jump=s.watchdog.max_stamp_jump,
                                                      max_lead=s.watchdog.max_stamp_lead))
        self.events = EventWindow(s.diagnostics.window)  # rejections of the last window s
        self.bidirectional = s.bidirectional
        self.implement_width = s.implement_width
        self.teach_min_distance = s.teach.min_distance
        self.teach_heading_source = s.teach.heading_source
        self.vwa_settings = VwaSettings(s.variable_target.window, s.variable_target.interval)
        self.use_variable_target = s.variable_target.enabled
        self.line_frame = s.line.frame
        self.line_a = list(s.line.a)
        self.line_b = list(s.line.b)
        # one explicit engage request from the config, honoured once at the first healthy odometry with a line
        # (unattended simulation runs); a later disengage is final like any other
        self.engage_pending = s.engage_when_ready
        self.max_crab = s.max_crab if s.crab_feed_forward else 0.0
        self.settings = s

        self.base_line = self.line = None
        self.passes = None
        self.pass_index = 0
        self.teacher = None
        self.variable_target = None
        self.pose = None         # (t, x, y, yaw, speed) of the last accepted odometry
        self.angle = 0.0
        self.clock_topic = None  # s, last /clock without use_sim_time
        if self.line_frame == "map" and self.line_a != self.line_b:
            self._set_line(GuidanceLine.from_points(self.line_a, self.line_b), "parameters")

        self.state_pub = self.create_publisher(GuidanceState, "guidance/state", PUBLISHER_QOS)
        self.cmd_pub = self.create_publisher(SteeringCommand, "steering/command", PUBLISHER_QOS)
        subscribe_input(self, Odometry, "odometry/filtered", self._on_odometry)
        self.create_subscription(NavSatFix, "map_datum", self._on_datum, LATCHED_QOS)
        subscribe_input(self, GnssStatus, "gnss/status", self._on_gnss_status)  # receiver class of the gates
        if not self.get_parameter("use_sim_time").value:
            self.create_subscription(Clock, "/clock", self._on_clock, SENSOR_QOS)
        self.create_service(Trigger, "steering/set_line_here", self._srv_set_line_here)
        self.create_service(SetBool, "steering/teach", self._srv_teach)
        self.create_service(SetBool, "steering/engage", self._srv_engage)
        self.create_service(Trigger, "steering/next_pass", self._srv_next_pass)
        self.create_timer(1.0 / s.watchdog.rate, self._on_timer)
        self.diagnostics = Diagnostics(self, "steering")
        self.diagnostics.add("autosteer", self._diagnose)

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _ref(self) -> float | None:
        """Reference time of the odometry stamps (s); None until a simulated clock runs."""
        if self.clock_topic is not None:
            return self.clock_topic
        now = self._now()
        return now if now > 0.0 else None

    def _on_clock(self, msg: Clock):
        self.clock_topic = to_sec(msg.clock)

    def _on_gnss_status(self, msg: GnssStatus):
        self.watchdog.fix_type = msg.fix_type

    # ---- line management -------------------------------------------------------------------------------
    def _set_line(self, line: GuidanceLine, source: str):
        self.watchdog.disengage(self._now(), f"line changed ({source})")
        self.base_line = self.line = line
        self.passes = ParallelPasses(line, self.implement_width) if self.implement_width > 0.0 else None
        self.pass_index = 0
        self.get_logger().info(f"guidance line from {source}: ({line.x:.2f}, {line.y:.2f}) yaw {math.degrees(line.yaw):.2f} deg")

    def _on_datum(self, msg: NavSatFix):
        if self.line_frame != "latlon" or self.base_line is not None or self.line_a == self.line_b:
            return
        plane = LocalTangentPlane(msg.latitude, msg.longitude, msg.altitude)
        self._set_line(GuidanceLine.from_latlon(plane, self.line_a, self.line_b), "lat/lon parameters")

    def _srv_set_line_here(self, _request, response):
        if self.pose is None:
            response.success, response.message = False, "no odometry yet"
        else:
            _, x, y, yaw, _ = self.pose
            self._set_line(GuidanceLine(x, y, yaw), "current pose")
            response.success, response.message = True, f"line through ({x:.2f}, {y:.2f}) yaw {math.degrees(yaw):.2f} deg"
        return response

    def _srv_teach(self, request, response):
        if request.data:
            self.teacher = LineTeacher(self.teach_min_distance, self.teach_heading_source)
            response.success, response.message = True, "teaching: drive the line"
            return response
        line = self.teacher.line() if self.teacher is not None else None
        if line is None:
            dist = self.teacher.distance if self.teacher is not None else 0.0
            response.success = False
            response.message = f"taught {dist:.1f} m, need {self.teach_min_distance} m"
        else:
            self._set_line(line, "teaching")
            response.success, response.message = True, f"taught yaw {math.degrees(line.yaw):.2f} deg"
        self.teacher = None
        return response

    def _srv_engage(self, request, response):
        now = self._now()
        if not request.data:
            self.watchdog.disengage(now, "disengage requested")
            response.success, response.message = True, "disengaged"
        elif self.base_line is None:
            response.success, response.message = False, "refused: no guidance line"
        else:
            response.success, response.message = self._engage(now)
        return response

    def _engage(self, now):
        """Explicit engage: on the pass nearest the vehicle when passes are configured."""
        if self.passes is not None and self.pose is not None:
            self.pass_index = self.passes.nearest(self.pose[1], self.pose[2])
            self.line = self.passes.line(self.pass_index)
        return self.watchdog.request_engage(now, self._ref())

    def _srv_next_pass(self, _request, response):
        if self.passes is None or self.pose is None:
            response.success, response.message = False, "needs implement_width > 0, a line and odometry"
        elif self.watchdog.engaged:
            response.success, response.message = False, "disengage before changing pass"
        else:
            self.pass_index = self.passes.next_index(self.pass_index, self.pose[1], self.pose[2])
            self.line = self.passes.line(self.pass_index)
            response.success, response.message = True, f"pass {self.pass_index}"
        return response

    # ---- control loop ----------------------------------------------------------------------------------
    def _on_odometry(self, msg: Odometry):
        t, now, ref = to_sec(msg.header.stamp), self._now(), self._ref()
        reason = self.stamps.check(t, ref)
        if reason is not None:  # dropped: the stream goes stale if it lasts
            self.events.add("stamp_ahead_of_clock" if reason == "stamp_off_reference" else reason, now)
            return
        q = msg.pose.pose.orientation
        _, _, yaw = euler_from_quaternion(q.x, q.y, q.z, q.w)
        sample, problem = odometry_sample(msg.pose.pose.position.x, msg.pose.pose.position.y, yaw,
                                          msg.twist.twist.linear.x, msg.pose.covariance, msg.twist.covariance, t,
                                          msg.twist.twist.linear.y)
        if sample is None:
            self.events.add(problem.replace(" ", "_"), now)
            self.watchdog.reject(now, f"invalid odometry: {problem}")
            self._publish_command(msg.header.stamp, 0.0)
            return
        fault = self.watchdog.odometry(now, sample, ref)
        if fault == "non-finite odometry":
            self.events.add("non_finite", now)
            self._publish_command(msg.header.stamp, 0.0)
            return
        if fault is not None and fault.startswith("odometry stamp"):
            self.events.add("old_stamp", now)
        dt = t - self.pose[0] if self.pose is not None else 0.0
        self.pose = (t, sample.x, sample.y, yaw, sample.speed)
        if self.teacher is not None:
            self.teacher.add(sample.x, sample.y, yaw)
        if self.line is None:
            self._publish_command(msg.header.stamp, 0.0)
            return
        if self.engage_pending and fault is None:
            self.engage_pending = not self._engage(self._now())[0]
        if self.use_variable_target and self.watchdog.engaged:
            self.line = self.variable_target.update(self.line, t, sample.x, sample.y, yaw)
        err = self.line.error(sample.x, sample.y, yaw, sample.speed, self.bidirectional,
                              crab_angle(sample.speed, sample.lateral_speed, self.max_crab))
        self.state_pub.publish(GuidanceState(header=msg.header, engaged=self.watchdog.engaged,
                                             cross_track_error=err.cross_track, heading_error=err.heading_error,
                                             line_yaw=err.line_yaw, speed=err.speed))
        angle = self.controller.update(err, min(max(dt, 0.0), MAX_DT)) if self.watchdog.engaged else 0.0
        self._publish_command(msg.header.stamp, angle)

    def _publish_command(self, stamp, angle: float):
        engaged = self.watchdog.engaged and math.isfinite(angle)
        self.angle = angle if engaged else 0.0
        self.cmd_pub.publish(SteeringCommand(header=Header(stamp=stamp, frame_id="base_link"), engaged=engaged, steering_angle=self.angle,
                                             steering_rate_limit=self.limits.max_rate))

    def _on_timer(self):
        self.watchdog.check(self._now(), self._ref())

    def _on_transition(self, transition):
        if transition.engaged:
            self.controller.reset()
            self.variable_target = VariableTargetLine(self.vwa_settings) if self.use_variable_target else None
        else:
            self._publish_command(self.get_clock().now().to_msg(), 0.0)
        text = f"{'ENGAGED' if transition.engaged else 'DISENGAGED'}: {transition.reason}"
        if transition.engaged or transition.reason == "disengage requested":
            self.get_logger().info(text)
        else:
            self.get_logger().warning(text)
        self.diagnostics.publish()

    def _diagnose(self):
        wd = self.watchdog
        last = wd.transitions[-1] if wd.transitions else None
        values = {"engaged": wd.engaged, "fault": wd.fault or "none", "controller": self.controller_name,
                  "line": "none" if self.line is None else f"{self.line.x:.2f},{self.line.y:.2f},{self.line.yaw:.4f}",
                  "pass": self.pass_index, "steering_angle": f"{self.angle:.4f}",
                  "last_transition": "none" if last is None else f"{last.time:.3f} {'engaged' if last.engaged else 'disengaged'}: {last.reason}"}
        age = wd.stamp_age(self._ref())
        values["stamp_age"] = "unknown" if age is None else f"{age:.3f}"
        recent = self.events.recent(self._now())
        for name, total in sorted(self.events.totals.items()):  # odometry rejected or tripping the watchdog
            values[f"odometry.{name}"] = f"{recent.get(name, 0)} in the last {self.events.window:g} s, {total} total"
        if wd.engaged:
            return (WARN, f"engaged; odometry problems in the last {self.events.window:g} s", values) if recent \
                else (OK, "engaged", values)
        if last is not None and not last.engaged and last.reason != "disengage requested" and wd.fault is not None:
            return ERROR, f"disengaged by fail-safe: {last.reason}", values
        return (WARN if wd.fault else OK), f"disengaged ({wd.fault or 'ready'})", values


main = main_for(SteeringNode)
