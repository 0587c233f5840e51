"""`agnav calibrate` on the bundled set-up drive: recovers the simulated inclinometer zeros, and config nsm uses them."""
import math
import re

import numpy as np
import yaml

from agnav_sim_eval import calibrate
from agnav_sim_eval.sim.simulator import TractorSimulator


def test_calibrate_bag_recovers_the_zero_offsets(capsys, repo_root):
    assert calibrate.main([str(repo_root / "bags" / "tilt_calibration")]) == 0
    out = capsys.readouterr().out
    found = [float(v) for v in re.search(r"incl_zero_deg: \[(\S+), (\S+)\]", out).groups()]
    true = np.degrees(TractorSimulator("tilt_calibration", seed=1).incl.offset)  # the bag's seed
    assert np.abs(np.array(found) - true).max() < 0.05
    config = yaml.safe_load((repo_root / "src/agnav_bringup/config/nsm.yaml").read_text())
    module = next(n for n in config["nodes"] if n["executable"] == "nav_sensor_module_node")
    assert module["parameters"]["incl_zero_deg"] == found


def test_calibrate_without_a_reversal_fails_clearly(capsys, repo_root):
    assert calibrate.main([str(repo_root / "bags" / "rough_road")]) == 1
    assert "agnav calibrate:" in capsys.readouterr().err
