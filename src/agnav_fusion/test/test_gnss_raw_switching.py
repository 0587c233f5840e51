"""Mode switching (gnss_raw.switching): Table 5-8-1 and the hand-over of the INS state between the loosely and the
tightly coupled filter (InsEkf.export_state / adopt)."""
import numpy as np

from agnav_fusion.gnss_raw.observations import ObsEpoch
from agnav_fusion.gnss_raw.switching import INS_ONLY, LOOSE, TIGHT, Switching, select_mode
from agnav_fusion.gnss_raw.tight import TightFilter, antenna_state
from agnav_fusion.ins import GnssSample, InsEkf, InsEkfSettings, InsState, Mechanization
from agnav_fusion.ins import error_model as em


def epoch(sats, code=20e6):
    n = len(sats)
    full = np.full((n, 2), code)
    return ObsEpoch(2320, 0.0, list(sats), full, full, full, full, np.zeros((n, 2), bool), np.full((n, 2), 0.19))


def test_table_5_8_1():
    base = epoch(["G01", "G02", "G03", "E01", "E02"])
    assert select_mode(True, None, None) == LOOSE                          # RTK fixed wins
    assert select_mode(False, epoch(["G01", "G03"]), base) == TIGHT        # 2 common satellites: one DD
    assert select_mode(False, epoch(["G01", "E01"]), base) == INS_ONLY     # 2 common, no DD (two systems)
    assert select_mode(False, epoch(["G01", "G09"]), base) == INS_ONLY     # G09 not at the base
    assert select_mode(False, epoch(["G01", "G02"], np.nan), base) == INS_ONLY   # no code
    assert select_mode(False, epoch([]), base) == INS_ONLY
    assert select_mode(False, epoch(["G01", "G02"]), None) == INS_ONLY    # no base link


def aligned_ekf():
    ekf = InsEkf(InsEkfSettings(lever_gnss_frd=(0.3, 0.0, -2.0)))
    ekf.adopt(Mechanization(InsState.from_geodetic(0.63, 2.44, 50.0, 0.0, 0.0, 0.5, (2.0, 0.0, 0.0))),
              np.diag(np.linspace(1e-6, 1e-4, 16)), t=0.0)
    return ekf


def test_hand_over_keeps_state_and_covariance():
    ekf = aligned_ekf()
    n = em.N_INS                  # crab and gyro scale added with their steady / initial variances
    assert ekf.p.shape == (n, n) and ekf.p[em.CRAB, em.CRAB] > 0 and ekf.p[em.GYRO_SCALE, em.GYRO_SCALE] > 0
    for k in range(1, 51):
        ekf.add_imu(k * 0.01, np.zeros(3), np.array([0.0, 0.0, -9.8]))
    before = antenna_state(ekf.mech, ekf.s.lever_gnss_frd, ekf.omega_b)
    tight = TightFilter.from_ins(ekf, np.zeros(3))
    assert np.array_equal(tight.p[:n, :n], ekf.p) and tight.mech is not ekf.mech
    assert np.allclose(tight.antenna()[0], before[0], atol=0) and np.allclose(tight.antenna()[1], before[1], atol=0)
    for k in range(51, 101):
        tight.add_imu(k * 0.01, np.zeros(3), np.array([0.0, 0.0, -9.8]))
    tight.p[n:, :] = tight.p[:, n:] = 0.0          # drift/ambiguity rows are dropped on the way back
    state = tight.export_state()
    ekf.adopt(**state)
    assert ekf.t == tight.t and np.array_equal(ekf.p, tight.p[:n, :n]) and ekf.crab == tight.ins.crab
    assert np.allclose(antenna_state(ekf.mech, ekf.s.lever_gnss_frd, ekf.omega_b)[0], tight.antenna()[0], atol=0)


def test_a_fix_after_a_silence_is_no_fixed_one_until_its_status_says_so():
    """The receiver's status may follow its fix: the last status (RTK fixed, before a 2.2 s blockage) says nothing
    about the first fix after the blockage (float), which leaves the filter INS only; a fresh fixed status
    returns it to loose coupling."""
    switching = Switching(aligned_ekf(), np.zeros(3))
    switching.mode = INS_ONLY                  # no satellites in the blockage
    switching.receiver_status(True, 47.8)
    switching.add_gnss(GnssSample(50.0, 0.63, 2.44, 50.0, np.eye(3) * 1e-4))
    assert switching.mode == INS_ONLY
    switching.receiver_status(True, 50.2)
    switching.add_gnss(GnssSample(50.2, 0.63, 2.44, 50.0, np.eye(3) * 1e-4))
    assert switching.mode == LOOSE
