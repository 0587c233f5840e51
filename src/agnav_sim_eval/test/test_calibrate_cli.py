"""`agnav calibrate` on the bundled set-up drive: recovers the simulated inclinometer zeros, and config nsm uses them."""
import math
import re

import numpy as np
import pytest
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


def test_calibrate_levels_a_mems_imu(tmp_path, capsys):
    """A MEMS IMU (accelerometer bias ±0.1 m/s², bracket tilted 0.3°/-0.2° and turned 90° in /tf_static) on the
    set-up drive: the levelled imu_link mount makes its accelerometers read the true roll and pitch when parked
    (the scale error, 0.5 % of the 3° pad, stays). Before: no IMU result, and the INS took the mount as it is (its
    roll on a straight run is off by this zero)."""
    import json
    from agnav_common.frames import rotation_matrix
    from agnav_fusion.pipeline import accelerometer_tilt
    from agnav_sim_eval.evaluate import odometry_arrays, read_bag
    from agnav_sim_eval.sim.bag import record
    from agnav_sim_eval.sim.scenarios import MEMS_ACCEL, MEMS_GYRO, mounts
    m = mounts()
    m["imu_link"] = (m["imu_link"][0], (0.0, 0.0, math.pi / 2))
    sim = TractorSimulator("tilt_calibration", seed=3, gyro=MEMS_GYRO, accel=MEMS_ACCEL, incl=None, mounts=m,
                           mount_errors={"imu_link": (math.radians(0.3), math.radians(-0.2), 0.0)})
    bag = tmp_path / "mems_setup"
    record(sim, bag)
    assert calibrate.main([str(bag), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["inclinometer"] is None and res["imu"]["turn"] == pytest.approx(math.pi, abs=0.3)
    data = read_bag(bag, ["/imu/data_raw", "/ground_truth/odometry"])
    t = np.array([stamp for stamp, _ in data["/imu/data_raw"]])
    f = np.array([[a.x, a.y, a.z] for a in (msg.linear_acceleration for _, msg in data["/imu/data_raw"])])
    truth = odometry_arrays(data["/ground_truth/odometry"])
    levelled, mounted = [], []
    for park in (res["imu"]["first"], res["imu"]["second"]):
        mean_f = f[(t >= park["start"]) & (t <= park["end"])].mean(axis=0)
        k = (truth["t"] >= park["start"]) & (truth["t"] <= park["end"])
        true = np.array([truth["roll"][k].mean(), truth["pitch"][k].mean()])
        for rpy, out in ((res["imu_link"][1], levelled), (m["imu_link"][1], mounted)):
            out.append(np.degrees(np.array(accelerometer_tilt(rotation_matrix(*rpy) @ mean_f)) - true))
    assert np.abs(levelled).max() < 0.05, levelled
    assert np.abs(mounted).max() > 0.25, mounted
