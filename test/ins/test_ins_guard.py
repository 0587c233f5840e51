"""The GNSS/INS backend's input clocks (nav_ins.InsNavigation): a receiver back after an outage, its stamps on the
IMU clock, loses no fix and no velocity to the stamp-jump confirmation (campaign tuning seed 93: the first three
fixes and four velocities after a 10 s outage were held back, the error stayed 15 cm for 3 s); a fix stamped further
ahead of the IMU than the EKF's lead bound is still rejected."""
import numpy as np

from agnav_common.geodesy import LocalTangentPlane
from agnav_fusion.nav_ins import InsNavigation

OUTAGE = (10.5, 20.0)   # s: fixes at 5 Hz before and after
LATENCY = 0.1           # s, each fix reaches the backend this late
COV = [[1e-4, 0.0, 0.0], [0.0, 1e-4, 0.0], [0.0, 0.0, 4e-4]]


def _fed(early_fix=None):
    nav = InsNavigation()
    nav.set_mounts((-1.0, 0.0, 2.0), (0.0, 0.0, 0.0), (0.5, 0.0, 1.0))
    nav.set_plane(LocalTangentPlane(43.0, 141.0, 10.0))
    fixes = [k * 0.2 for k in range(1, 126) if not OUTAGE[0] < k * 0.2 < OUTAGE[1]]
    rng = np.random.default_rng(0)
    for k in range(1, 2600):
        t = k * 0.01
        nav.imu(t, 1e-3 * rng.standard_normal(3), (0.0, 0.0, 9.80665) + 0.01 * rng.standard_normal(3))
        due = [f for f in fixes if f + LATENCY <= t + 1e-9]
        if early_fix is not None and abs(t - early_fix[1]) < 1e-9:
            due.insert(0, early_fix[0])
        for f in due:
            if f in fixes:
                fixes.remove(f)
            nav.gnss(f, (0.0, 0.0, 2.0), COV, (0.0, 0.0, 0.0), COV)
    return nav.guard.totals


def test_a_receiver_back_after_an_outage_loses_no_fix_and_no_velocity():
    totals = _fed()
    assert not any(name.endswith("future_stamp") for name in totals), totals
    assert totals["gnss"] == 125 - 47   # every fix outside the outage reached the EKF


def test_a_fix_far_ahead_of_the_imu_clock_is_still_rejected():
    totals = _fed(early_fix=(16.0, 10.0))   # inside the outage, handed over at IMU time 10 s: 6 s ahead
    assert totals.get("gnss_stamp_off_reference") == 1 and totals["gnss"] == 125 - 47, totals
