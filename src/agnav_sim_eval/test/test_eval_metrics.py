"""Evaluator: truth echo scores zero, known perturbations score exactly, datum change and bag round trip."""
import json
import math

import numpy as np
import pytest
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin

from agnav_sim_eval.evaluate import evaluate_arrays, main, odometry_arrays, read_bag
from agnav_common.bagio import typestore
from agnav_common.frames import quaternion_from_euler
from agnav_common.geodesy import LocalTangentPlane
from agnav_sim_eval.sim.bag import record
from agnav_sim_eval.sim.route import DriverParams, rounded_loop
from agnav_sim_eval.sim.simulator import TractorSimulator


def _truth(n=500):
    t = np.linspace(0.0, 50.0, n)
    yaw = np.linspace(-3.0, 3.0, n)  # crosses ±pi when wrapped
    return dict(t=t, x=np.cos(t / 8) * 10, y=np.sin(t / 8) * 10, roll=0.02 * np.sin(t), pitch=0.01 * np.cos(t),
                yaw=np.angle(np.exp(1j * yaw)))


def test_truth_echo_scores_zero():
    truth = _truth()
    m = evaluate_arrays(truth, truth)
    for key in ("roll_deg", "pitch_deg", "yaw_deg", "horizontal_cm", "cross_track_cm"):
        assert m[key]["rms"] == pytest.approx(0.0, abs=1e-9) and m[key]["max"] == pytest.approx(0.0, abs=1e-9)
    assert m["samples"] == 500


def test_known_perturbations_score_exactly():
    truth = _truth()
    est = dict(truth, yaw=truth["yaw"] + math.radians(1.0), x=truth["x"] + 0.05)
    m = evaluate_arrays(est, truth)
    assert m["yaw_deg"]["rms"] == pytest.approx(1.0, abs=1e-9)
    assert m["yaw_deg"]["max"] == pytest.approx(1.0, abs=1e-9)
    assert m["horizontal_cm"]["rms"] == pytest.approx(5.0, abs=1e-9)
    # cross-track of a +5 cm east error = 5 |sin(yaw)| cm
    expected = 5.0 * np.abs(np.sin(truth["yaw"]))
    assert m["cross_track_cm"]["rms"] == pytest.approx(np.sqrt(np.mean(expected ** 2)), abs=1e-9)
    assert m["roll_deg"]["rms"] == pytest.approx(0.0, abs=1e-12)


def test_interpolates_truth_at_output_stamps():
    truth = _truth(2000)
    tq = np.linspace(1.0, 49.0, 137)
    est = {k: np.interp(tq, truth["t"], truth[k]) for k in ("x", "y", "roll", "pitch")}
    est.update(t=tq, yaw=np.interp(tq, truth["t"], np.unwrap(truth["yaw"])))
    m = evaluate_arrays(est, truth)
    assert m["horizontal_cm"]["max"] < 1e-6 and m["yaw_deg"]["max"] < 1e-9 and m["samples"] == 137


@pytest.fixture(scope="module")
def truth_bag(tmp_path_factory):
    path = tmp_path_factory.mktemp("eval") / "truth"
    sim = TractorSimulator("asphalt_loop", seed=3, route=rounded_loop(12.0, 8.0, 3.0)[:60],
                           driver=DriverParams(start_standstill_s=1.0, end_standstill_s=1.0))
    record(sim, path)
    return path


def _write_output(path, truth, datum, dyaw=0.0, d_east=0.0, imu_yaw_variance=None):
    ts = typestore()
    T = ts.types
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        odo = w.add_connection("/odometry/filtered", "nav_msgs/msg/Odometry", typestore=ts)
        imu = w.add_connection("/imu/data", "sensor_msgs/msg/Imu", typestore=ts) if imu_yaw_variance else None
        fix = w.add_connection("/map_datum", "sensor_msgs/msg/NavSatFix", typestore=ts)
        stamp0 = T["builtin_interfaces/msg/Time"](sec=int(truth["t"][0]), nanosec=0)
        msg = T["sensor_msgs/msg/NavSatFix"](
            header=T["std_msgs/msg/Header"](stamp=stamp0, frame_id="map"),
            status=T["sensor_msgs/msg/NavSatStatus"](status=0, service=1), latitude=datum[0], longitude=datum[1],
            altitude=datum[2], position_covariance=np.zeros(9), position_covariance_type=0)
        w.write(fix, 1, ts.serialize_cdr(msg, "sensor_msgs/msg/NavSatFix"))
        for i in range(0, truth["t"].size, 7):
            ns = int(round(truth["t"][i] * 1e9))
            x, y, z, w_ = quaternion_from_euler(truth["roll"][i], truth["pitch"][i], truth["yaw"][i] + dyaw)
            pose = T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=truth["x"][i] + d_east, y=truth["y"][i], z=truth["z"][i]),
                orientation=T["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w_))
            zero = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
            m = T["nav_msgs/msg/Odometry"](
                header=T["std_msgs/msg/Header"](
                    stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10 ** 9, nanosec=ns % 10 ** 9), frame_id="map"),
                child_frame_id="base_link",
                pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
                twist=T["geometry_msgs/msg/TwistWithCovariance"](
                    twist=T["geometry_msgs/msg/Twist"](linear=zero, angular=zero), covariance=np.zeros(36)))
            w.write(odo, ns, ts.serialize_cdr(m, "nav_msgs/msg/Odometry"))
            if imu is not None:  # attitude with a relative (unknown) yaw, as attitude_node publishes it
                cov = np.diag([1e-4, 1e-4, imu_yaw_variance]).ravel()
                vec = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
                w.write(imu, ns, ts.serialize_cdr(T["sensor_msgs/msg/Imu"](
                    header=m.header, orientation=pose.orientation, orientation_covariance=cov,
                    angular_velocity=vec, angular_velocity_covariance=np.zeros(9), linear_acceleration=vec,
                    linear_acceleration_covariance=np.zeros(9)), "sensor_msgs/msg/Imu"))


def _truth_and_datum(bag):
    found = read_bag(bag, ["/ground_truth/odometry", "/map_datum"])
    m = found["/map_datum"][0][1]
    return odometry_arrays(found["/ground_truth/odometry"]), (m.latitude, m.longitude, m.altitude)


def _run_json(capsys, argv):
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out.strip().splitlines()[-1])


def test_cli_truth_echo_and_perturbation(truth_bag, tmp_path, capsys):
    truth, datum = _truth_and_datum(truth_bag)
    _write_output(tmp_path / "echo", truth, datum)
    m = _run_json(capsys, [str(tmp_path / "echo"), "--truth", str(truth_bag), "--json", "--plots", str(tmp_path)])
    assert all(m[k]["max"] == pytest.approx(0.0, abs=1e-6) for k in ("roll_deg", "yaw_deg", "horizontal_cm"))
    assert (tmp_path / "track.png").stat().st_size > 0 and (tmp_path / "errors.png").stat().st_size > 0
    _write_output(tmp_path / "pert", truth, datum, dyaw=math.radians(1.0), d_east=0.05)
    m = _run_json(capsys, [str(tmp_path / "pert"), "--truth", str(truth_bag), "--json"])
    assert m["yaw_deg"]["rms"] == pytest.approx(1.0, abs=1e-6) and m["yaw_deg"]["max"] == pytest.approx(1.0, abs=1e-6)
    assert m["horizontal_cm"]["rms"] == pytest.approx(5.0, abs=1e-6)
    assert m["pitch_deg"]["max"] == pytest.approx(0.0, abs=1e-6)


def test_cli_converts_truth_into_the_output_datum(truth_bag, tmp_path, capsys):
    truth, datum = _truth_and_datum(truth_bag)
    shifted = LocalTangentPlane(*datum).to_geodetic(250.0, -120.0, 3.0)
    lat, lon, alt = LocalTangentPlane(*datum).to_geodetic(truth["x"], truth["y"], truth["z"])
    x, y, z = LocalTangentPlane(*map(float, shifted)).to_enu(lat, lon, alt)
    _write_output(tmp_path / "moved", dict(truth, x=x, y=y, z=z), tuple(map(float, shifted)))
    m = _run_json(capsys, [str(tmp_path / "moved"), "--truth", str(truth_bag), "--json"])
    assert m["horizontal_cm"]["max"] < 0.01


def test_unknown_imu_yaw_is_not_scored(truth_bag, tmp_path, capsys):
    truth, datum = _truth_and_datum(truth_bag)
    _write_output(tmp_path / "imu", truth, datum, imu_yaw_variance=99999.0)
    m = _run_json(capsys, [str(tmp_path / "imu"), "--truth", str(truth_bag), "--json", "--plots", str(tmp_path)])
    assert m["imu_data"]["roll_deg"]["max"] == pytest.approx(0.0, abs=1e-6)
    assert m["imu_data"]["yaw_deg"]["rms"] is None
    assert (tmp_path / "errors.png").stat().st_size > 0


def test_eval_names_agnav_recover_for_an_unfinished_recording(tmp_path, capsys):
    from agnav_sim_eval.evaluate import main
    rec = tmp_path / "killed"
    rec.mkdir()
    (rec / "killed_0.mcap").write_bytes(b"\x89MCAP0\r\n")  # a writer killed before metadata.yaml
    assert main([str(rec), "--truth", str(rec)]) == 1
    assert "agnav recover" in capsys.readouterr().err
