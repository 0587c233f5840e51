import math

import pytest
from agnav_common.geodesy import LocalTangentPlane
from agnav_control.guidance_line import GuidanceLine, LineTeacher, ParallelPasses, VariableTargetLine
from agnav_common.variance_weighted_average import VwaSettings


def test_cross_track_sign_left_positive_and_heading_error():
    line = GuidanceLine.from_points((0, 0), (10, 0))  # east
    err = line.error(5.0, 0.3, math.radians(10), 2.0)
    assert err.cross_track == pytest.approx(0.3)
    assert err.heading_error == pytest.approx(math.radians(10))
    assert err.along_track == pytest.approx(5.0)
    assert err.speed == pytest.approx(2.0 * math.cos(math.radians(10)))
    assert line.error(5.0, -0.3, 0.0, 1.0).cross_track == pytest.approx(-0.3)


def test_opposite_direction_follows_reversed_line():
    line = GuidanceLine.from_points((0, 0), (0, 10))  # north
    # driving south, 0.5 m east of the line: east is the vehicle's left when heading south
    err = line.error(0.5, 3.0, -math.pi / 2 + 0.05, 1.0)
    assert err.line_yaw == pytest.approx(-math.pi / 2)
    assert err.cross_track == pytest.approx(0.5)
    assert err.heading_error == pytest.approx(0.05)
    fixed = line.error(0.5, 3.0, -math.pi / 2 + 0.05, 1.0, bidirectional=False)
    assert fixed.cross_track == pytest.approx(-0.5)
    assert fixed.heading_error == pytest.approx(-math.pi + 0.05)


def test_heading_error_wraps_at_pi():
    line = GuidanceLine(0.0, 0.0, math.pi - 0.01)
    err = line.error(0.0, 0.0, -math.pi + 0.01, 1.0)
    assert err.heading_error == pytest.approx(0.02)


def test_latlon_line_matches_map_points():
    plane = LocalTangentPlane(43.07, 141.34, 20.0)
    lat_b, lon_b, _ = plane.to_geodetic(100.0, 100.0, 0.0)
    line = GuidanceLine.from_latlon(plane, (43.07, 141.34), (float(lat_b), float(lon_b)))
    assert line.yaw == pytest.approx(math.pi / 4, abs=1e-6)
    assert (line.x, line.y) == pytest.approx((0.0, 0.0), abs=1e-6)


def test_coincident_points_rejected():
    with pytest.raises(ValueError):
        GuidanceLine.from_points((1, 1), (1, 1))


def test_parallel_passes_offset_nearest_and_next():
    passes = ParallelPasses(GuidanceLine(0.0, 0.0, 0.0), width=6.0)
    assert passes.line(2).error(3.0, 12.0, 0.0, 1.0).cross_track == pytest.approx(0.0)
    assert passes.line(-1).error(3.0, -5.0, 0.0, 1.0).cross_track == pytest.approx(1.0)
    assert passes.nearest(50.0, 10.0) == 2
    assert passes.nearest(50.0, -8.0) == -1
    # after finishing pass 0 and turning to the left side, the next pass is 1; to the right, -1
    assert passes.next_index(0, 100.0, 4.0) == 1
    assert passes.next_index(0, 100.0, -2.0) == -1


def test_rotated_about_keeps_cross_track():
    line = GuidanceLine(0.0, 0.0, 0.0)
    new = line.rotated_about(20.0, 0.4, 0.02)
    assert new.yaw == pytest.approx(0.02)
    assert new.error(20.0, 0.4, 0.02, 1.0).cross_track == pytest.approx(0.4)


def test_teacher_needs_distance_and_averages_heading():
    teacher = LineTeacher(min_distance=3.0)
    for i, wobble in enumerate([0.02, -0.02, 0.01, -0.01, 0.0]):
        teacher.add(i * 0.5, 1.0, math.pi / 2 + wobble)  # drifts east while yaw says north
    assert teacher.line() is None
    for i in range(5, 10):
        teacher.add(i * 0.5, 1.0, math.pi / 2)
    assert teacher.line().yaw == pytest.approx(math.pi / 2)
    track = LineTeacher(min_distance=3.0, heading_source="track")
    for i in range(10):
        track.add(i * 0.5, 1.0, math.pi / 2)
    assert track.line().yaw == pytest.approx(0.0)


def test_variable_target_line_retargets_every_interval_keeping_cross_track():
    vt = VariableTargetLine(VwaSettings(window=10.0, interval=2.0))
    line = GuidanceLine(0.0, 0.5, math.pi - 0.05)  # heading west, across the +-pi seam
    updates = []
    for k in range(300):  # 15 Hz for 20 s; yaw turns slowly through +-pi
        t = k / 15.0
        yaw = math.remainder(math.pi - 0.05 + 0.01 * t, 2 * math.pi)
        x, y = -t, 0.0
        new = vt.update(line, t, x, y, yaw)
        if new is not line:
            assert new.error(x, y, yaw, 1.0).cross_track == pytest.approx(line.error(x, y, yaw, 1.0).cross_track)
            updates.append(t)
            line = new
    assert [round(t) for t in updates] == [10, 12, 14, 16, 18]
    # target = mean yaw over the last 10 s window = yaw 5 s before the update
    assert line.yaw == pytest.approx(math.remainder(math.pi - 0.05 + 0.01 * (updates[-1] - 5.0), 2 * math.pi), abs=2e-3)
