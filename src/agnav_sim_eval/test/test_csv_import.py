"""csv_import: a VN-100-style CSV (z-down body frame) -> rosbag2 with FLU IMU, GPS fixes and mounts."""
from agnav_sim_eval.evaluate import read_bag
from agnav_drivers.csv_import import convert

HEADER = ("timestamp_sec_gps,timestamp_nanosec_gps,timestamp_sec_imu,timestamp_nanosec_imu,latitude,longitude,"
          "altitude,orientation_x,orientation_y,orientation_z,orientation_w,linear_acceleration_x,"
          "linear_acceleration_y,linear_acceleration_z,angular_velocity_x,angular_velocity_y,angular_velocity_z,"
          "magnetic_field_x,magnetic_field_y,magnetic_field_z")


def test_frd_rows_become_flu_messages_and_gps_fixes(tmp_path):
    csv_path = tmp_path / "log.csv"
    imu = ",,100.0,{ns},,,,0,0,0,1,0.5,0.2,-9.8,0.01,0.02,-0.3,2e-5,1e-5,4e-5"
    csv_path.write_text("\n".join([HEADER, imu.format(ns=0), imu.format(ns=500000000),
                                   "100.0,250000000.0,,,42.3,-71.1,10.0" + "," * 13]) + "\n")
    counts = convert(csv_path, tmp_path / "bag", gps_sigma=2.0, gps_time_offset=1.5)
    assert counts == {"/tf_static": 1, "/imu/data_raw": 2, "/imu/mag": 2, "/gnss/fix": 1}
    topics = read_bag(tmp_path / "bag", ["/imu/data_raw", "/gnss/fix"])
    t, m = topics["/imu/data_raw"][1]
    assert t == 100.5 and m.header.frame_id == "imu_link"
    assert (m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z) == (0.5, -0.2, 9.8)
    assert (m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z) == (0.01, -0.02, 0.3)
    assert m.orientation_covariance[0] == -1.0
    t, fix = topics["/gnss/fix"][0]
    assert t == 101.75 and fix.latitude == 42.3 and fix.position_covariance[0] == 4.0
