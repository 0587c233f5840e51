"""tractor_sim: the simulator at real time on a wall timer, publishing the INTERFACES topics and /clock, and
steering through the bicycle model from /steering/command while it is engaged (else the built-in driver)."""
import time
from dataclasses import dataclass, field, replace

from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from agnav_common.diagnostics import OK, WARN, Diagnostics
from agnav_common.node_main import main_for
from agnav_common.parameters import SIGNED, declare, leaves
from agnav_common.qos import LATCHED_QOS, PUBLISHER_QOS, SENSOR_QOS
from agnav_common.stamps import to_stamp
from agnav_msgs.msg import SteeringCommand

from agnav_drivers.ros_types import message_class
from .sim.messages import LATCHED_TOPICS, TOPIC_TYPES, MessageFactory
from .sim.scenarios import SCENARIOS
from .sim.simulator import TractorSimulator


@dataclass
class TractorSimSettings:
    scenario: str = "asphalt_loop"  # name in agnav_sim_eval.sim.scenarios.SCENARIOS
    seed: int = 0                   # random seed of the simulated sensor and vehicle noise
    real_time_factor: float = 1.0   # simulated time per wall time
    command_timeout_s: float = 0.5  # s: an older /steering/command hands the steering back to the built-in driver
    exit_when_done: bool = True     # finish the node when the scenario has ended
    start_standstill_s: float = field(default=-1.0, metadata=SIGNED)  # s at standstill before driving; < 0: the
    # scenario's own


def parameter_entries():
    """[(name, default, description)] of every parameter (tools/gen_params.py writes the params file from it)."""
    return leaves(TractorSimSettings())


class TractorSimNode(Node):
    """Steps TractorSimulator so that simulated time follows wall time × real_time_factor."""

    def __init__(self, **kwargs):
        super().__init__("tractor_sim", **kwargs)
        p = declare(self, TractorSimSettings())
        if p.scenario not in SCENARIOS:
            raise ValueError(f"scenario must be one of {sorted(SCENARIOS)}")
        scenario = SCENARIOS[p.scenario]
        if p.start_standstill_s >= 0:
            scenario = replace(scenario, driver=replace(scenario.driver, start_standstill_s=p.start_standstill_s))
        self.sim = TractorSimulator(scenario, p.seed)
        self.factory = MessageFactory(self.sim)
        self.rtf, self.timeout, self.exit_when_done = p.real_time_factor, p.command_timeout_s, p.exit_when_done
        self.pubs = {topic: self.create_publisher(message_class(kind), topic,
                                                  LATCHED_QOS if topic in LATCHED_TOPICS else PUBLISHER_QOS)
                     for topic, kind in TOPIC_TYPES.items()}
        self.clock_pub = self.create_publisher(Clock, "/clock", 10)
        self.create_subscription(SteeringCommand, "/steering/command", self._on_command, SENSOR_QOS)
        self._command = None  # (wall time received, angle)
        self.rejected = 0
        self.finished = False
        for topic, msg in self.factory.static():
            self.pubs[topic].publish(self.factory.serialize(topic, msg))
        self._pending = []  # (publish sim time, topic, msg)
        self._wall0 = time.monotonic()
        self.diagnostics = Diagnostics(self, "tractor_sim")
        self.diagnostics.add("simulation", self._status)
        self.create_timer(self.sim.dt / max(self.rtf, 1e-3), self._tick)

    def _on_command(self, msg):
        angle = msg.steering_angle
        if angle != angle or abs(angle) == float("inf"):
            self.rejected += 1
            return
        self._command = (time.monotonic(), angle) if msg.engaged else None

    def _steering(self):
        if self._command is None or time.monotonic() - self._command[0] > self.timeout:
            return None
        return self._command[1]

    def _tick(self):
        """Advance the simulation to the wall clock (at most 10 ticks per call), then publish what is due."""
        target = (time.monotonic() - self._wall0) * self.rtf
        for _ in range(10):
            if self.sim.done or self.sim.t + self.sim.dt > target:
                break
            for sample in self.sim.step(self._steering()):
                self._pending.extend((when, topic, msg) for topic, when, msg in self.factory.convert(*sample))
            self.clock_pub.publish(Clock(clock=to_stamp(self.factory.t0 + self.sim.t)))
        self._pending.sort(key=lambda row: row[0])
        while self._pending and self._pending[0][0] <= self.sim.t + 1e-9:
            _, topic, msg = self._pending.pop(0)
            self.pubs[topic].publish(self.factory.serialize(topic, msg))
        if self.sim.done and not self._pending and self.exit_when_done:
            self.finished = True

    def _status(self):
        lag = (time.monotonic() - self._wall0) * self.rtf - self.sim.t
        values = {"sim_time_s": f"{self.sim.t:.2f}", "lag_s": f"{lag:.3f}", "scenario": self.sim.scenario.name,
                  "steering": "external" if self._steering() is not None else "route driver",
                  "rejected_commands": self.rejected}
        if self.sim.done:
            return OK, "scenario finished", values
        if lag > 1.0:
            return WARN, "simulation slower than the requested real-time factor", values
        return (WARN, "rejected non-finite steering commands", values) if self.rejected else (OK, "running", values)


main = main_for(TractorSimNode)
