"""ROS-free tractor simulator (SPEC §11, SIM_CONTRACT.md): scenarios, sensor models, offline runs and bags."""
from .run import SimRun, simulate
from .scenarios import SCENARIOS, Scenario
from .simulator import TractorSimulator

__all__ = ["SCENARIOS", "Scenario", "SimRun", "TractorSimulator", "simulate"]
