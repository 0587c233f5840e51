"""Double differences: the correlated covariance 2σ²(I + 11ᵀ), masks and references on the real static pair, and
the re-indexing of DD ambiguity states when the reference changes (exact against single differences)."""
import numpy as np
import pytest

from agnav_fusion.gnss_raw.ambiguities import reindex
from agnav_fusion.gnss_raw.double_difference import (DDConfig, dd_covariance, dd_operator,
                                                     form_double_differences, undifferenced_variance)
from agnav_fusion.gnss_raw.ephemeris import satellite_states
from agnav_fusion.gnss_raw.geometry import elevation_azimuth, llh_to_ecef
from agnav_fusion.gnss_raw.observations import match_epochs
from agnav_fusion.gnss_raw.rinex import read_nav, read_obs

DATA = "/work/shared/data/real/gnss_raw/matrtklib_static/"


def test_equal_variances_give_two_sigma_squared_i_plus_ones():
    sigma2, n = 0.003 ** 2, 6
    cov = dd_covariance(2 * sigma2, np.full(n - 1, 2 * sigma2))
    assert np.allclose(cov, 2 * sigma2 * (np.eye(n - 1) + np.ones((n - 1, n - 1))))


def test_covariance_is_the_dd_operator_applied_to_single_differences():
    rng = np.random.default_rng(7)
    sd_var = rng.uniform(1e-6, 1e-4, 5)
    D = dd_operator(5)
    assert np.allclose(dd_covariance(sd_var[0], sd_var[1:]), D @ np.diag(sd_var) @ D.T)


def test_variance_grows_as_elevation_drops():
    el = np.radians([90.0, 45.0, 15.0])
    var = undifferenced_variance(0.003, el)
    assert var[0] == pytest.approx(2 * 0.003 ** 2) and np.all(np.diff(var) > 0)


@pytest.fixture(scope="module")
def real_dd():
    nav = read_nav(DATA + "base.nav")
    rover, base = match_epochs(read_obs(DATA + "rover.obs", max_epochs=1), read_obs(DATA + "base.obs", max_epochs=1))[0]
    base_pos = llh_to_ecef(35.134707705, 136.977577939, 104.853)
    rover_pos = llh_to_ecef(35.13469901, 136.97757549, 104.8626)
    cache = {}
    sv_b, sv_r = satellite_states(base, nav, base_pos, cache), satellite_states(rover, nav, base_pos, cache)
    config = DDConfig()
    return form_double_differences(rover, base, sv_r, sv_b, base_pos, config), rover, base, sv_b, base_pos, \
        rover_pos, config


def test_real_dd_masks_references_and_block_structure(real_dd):
    dd, rover, base, sv_b, base_pos, _, config = real_dd
    assert len(dd) > 30 and set(dd.refs) >= {("G", 0), ("E", 0), ("J", 0), ("C", 0)}
    assert np.all(np.degrees(dd.elevation) >= config.elevation_mask_deg)
    for system, slot, sat in dd.keys:
        assert min(rover.snr[rover.row(sat), slot], base.snr[base.row(sat), slot]) >= config.snr_mask_dbhz
    # the reference is the highest satellite of its group (no loss of lock in the first epoch)
    for group, ref in dd.refs.items():
        el_ref = elevation_azimuth(base_pos, sv_b.pos[base.row(ref)])[0][0]
        members = [i for i, k in enumerate(dd.keys) if k[:2] == group]
        assert np.all(dd.elevation[members] <= el_ref)
        # one group's phase covariance: v_ref on every entry plus v_j on the diagonal; zero to other groups
        block = dd.cov_phase[np.ix_(members, members)]
        v_ref = 2 * undifferenced_variance(config.sigma_phase, el_ref)
        assert np.allclose(block[~np.eye(len(block), dtype=bool)], v_ref)
        assert np.allclose(np.diag(block), v_ref + 2 * undifferenced_variance(config.sigma_phase,
                                                                              dd.elevation[members]))
        others = [i for i in range(len(dd)) if i not in members]
        assert not dd.cov_code[np.ix_(members, others)].any()


def test_real_dd_residuals_at_the_known_baseline(real_dd):
    """Code DDs within metres, phase DDs within a few hundredths of a cycle of an integer."""
    dd, *_, rover_pos, _ = real_dd
    h, _ = dd.geometry(rover_pos)
    code, cycles = dd.code - h, (dd.phase - h) / dd.wavelength
    assert np.sqrt(np.mean(code ** 2)) < 0.8 and np.abs(code).max() < 3.0
    assert np.abs(cycles - np.round(cycles)).max() < 0.06


def test_reference_change_keeps_the_implied_single_differences():
    """DD states built from SD ambiguities s (cov Q) re-indexed to a new reference equal the DDs of s against
    it, with the covariance D' Q D'ᵀ, cross-covariance with the position included; a slipped satellite restarts."""
    rng = np.random.default_rng(3)
    sats = ["G01", "G02", "G03", "G04"]
    s = rng.normal(0, 5, 4)
    A = rng.normal(size=(7, 7))
    Q = A @ A.T                                  # joint covariance of [position (3), SD ambiguities (4)]
    old_keys = [("G", 0, j) for j in sats[1:]]
    D_old = np.zeros((6, 7)); D_old[:3, :3] = np.eye(3); D_old[3:, 3:] = dd_operator(4)
    x_old = D_old @ np.concatenate([[1.0, 2.0, 3.0], s])
    new_keys = [("G", 0, j) for j in ("G01", "G02", "G04")]      # new reference G03
    x, P, fresh = reindex(x_old, D_old @ Q @ D_old.T, 3, old_keys, {("G", 0): "G01"}, new_keys,
                          {("G", 0): "G03"}, np.zeros(3, bool), np.zeros(3), np.ones(3))
    D_new = np.zeros((6, 7)); D_new[:3, :3] = np.eye(3)
    for row, j in enumerate((0, 1, 3)):
        D_new[3 + row, 3 + 2], D_new[3 + row, 3 + j] = 1.0, -1.0
    assert not fresh.any()
    assert np.allclose(x, D_new @ np.concatenate([[1.0, 2.0, 3.0], s]))
    assert np.allclose(P, D_new @ Q @ D_new.T)
    x2, P2, fresh2 = reindex(x_old, D_old @ Q @ D_old.T, 3, old_keys, {("G", 0): "G01"}, old_keys,
                             {("G", 0): "G01"}, np.array([False, True, False]), np.full(3, 42.0), np.full(3, 9.0))
    assert list(fresh2) == [False, True, False] and x2[4] == 42.0 and P2[4, 4] == 9.0
    assert not P2[4, :4].any() and not P2[4, 5:].any()
