"""`agnav bench cost --idle-ms`: the idle figure times the IMU messages of the window one by one, each after a sleep,
through the shipped pipeline."""
import math

from agnav_sim_eval.bench import cost
from agnav_sim_eval.bench.module_runs import sim_rows
from agnav_sim_eval.sim import simulate
from agnav_sim_eval.sim.route import DriverParams, straight


def test_idle_cost_window(monkeypatch):
    rows = sim_rows(simulate("asphalt_loop", seed=1, messages=True, route=straight(20.0),
                             driver=DriverParams(speed_mps=1.0, start_standstill_s=1.0, end_standstill_s=0.5)))
    monkeypatch.setattr(cost, "IDLE_SAMPLES", 40)
    sleeps = []
    monkeypatch.setattr(cost.time, "sleep", sleeps.append)
    us = cost.idle_us(rows, "agnav", 0.01)
    assert sleeps == [0.01] * 40
    assert math.isfinite(us) and us > 0.0
