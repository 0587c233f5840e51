"""Satellite states from broadcast ephemerides (cssrlib) against RTKLIB's own (pyrtklib) on the same records, the
Earth-rotation correction against cssrlib's Sagnac range term, and the RINEX reader against the file's text."""
import numpy as np
import pyrtklib as rtk
import pytest
from cssrlib.gnss import geodist, gpst2time, timediff

from agnav_fusion.gnss_raw.ephemeris import (OMEGA_E, ephemeris_for, orbit_at, rotate_z, satellite_state,
                                             satellite_states)
from agnav_fusion.gnss_raw.geometry import llh_to_ecef
from agnav_fusion.gnss_raw.rinex import read_nav, read_obs

DATA = "/work/shared/data/real/gnss_raw/matrtklib_static/"
BASE = llh_to_ecef(35.134707705, 136.977577939, 104.853)
# GPS, Galileo, QZSS, BeiDou MEO/IGSO and GEO (C01, C59)
SATS = ("G05", "G13", "G30", "E04", "E12", "E33", "J03", "J07", "C01", "C08", "C38", "C59")


@pytest.fixture(scope="module")
def navs():
    nav = rtk.nav_t()
    rtk.readrnx(DATA + "base.nav", 1, "", rtk.obs_t(), nav, rtk.sta_t())
    return read_nav(DATA + "base.nav"), [nav.eph[i] for i in range(nav.n)]


def _rtk_sat(sid):
    system = {"G": rtk.SYS_GPS, "E": rtk.SYS_GAL, "J": rtk.SYS_QZS, "C": rtk.SYS_CMP}[sid[0]]
    prn = int(sid[1:])
    return rtk.satno(system, prn + 192 if sid[0] == "J" else prn)


def _rtk_orbit(eph, week, tow):
    rs, dts, var = rtk.Arr1Ddouble(3), rtk.Arr1Ddouble(1), rtk.Arr1Ddouble(1)
    out = []
    for dt in (0.0, 0.01, -0.01):
        rtk.eph2pos(rtk.gpst2time(week, tow + dt), eph, rs, dts, var)
        out.append((np.array([rs[0], rs[1], rs[2]]), dts[0]))
    return out[0][0], (out[1][0] - out[2][0]) / 0.02, out[0][1], (out[1][1] - out[2][1]) / 0.02


@pytest.mark.parametrize("tow", [116400.0, 116700.0])
def test_orbits_match_rtklib_on_the_same_broadcast_record(navs, tow):
    nav, rtk_ephs = navs
    t = gpst2time(2320, tow)
    for sid in SATS:
        eph = ephemeris_for(sid, t, nav)
        assert eph is not None, sid
        rt = rtk.gpst2time(2320, tow)
        same = [e for e in rtk_ephs if e.sat == _rtk_sat(sid) and e.iode == eph.iode
                and abs(rtk.timediff(e.toe, rt) - timediff(eph.toe, t)) < 1.0]
        assert same, sid
        pos, vel, clock, drift = orbit_at(t, eph)
        r_pos, r_vel, r_clock, r_drift = _rtk_orbit(same[0], 2320, tow)
        assert np.linalg.norm(pos - r_pos) < 1e-3, sid                  # m
        assert np.linalg.norm(vel - r_vel) < 1e-3, sid                  # m/s
        assert abs(clock - r_clock) * 299792458.0 < 1e-3, sid           # m
        assert abs(drift - r_drift) * 299792458.0 < 1e-4, sid           # m/s
        assert 2.5e7 < np.linalg.norm(pos) < 4.3e7 and np.linalg.norm(vel) < 4.5e3, sid   # MEO .. GEO (J07)


def test_earth_rotation_matches_the_sagnac_range_term(navs):
    nav, _ = navs
    t = gpst2time(2320, 116500.0)
    terms = []
    for sid in SATS:
        pos, *_ = orbit_at(t, ephemeris_for(sid, t, nav))
        rng, _ = geodist(pos, BASE)
        tau = rng / 299792458.0
        assert abs(np.linalg.norm(rotate_z(pos, OMEGA_E * tau) - BASE) - rng) < 2e-3, sid
        terms.append(abs(np.linalg.norm(pos - BASE) - rng))
    assert max(terms) > 10.0     # the correction itself reaches tens of metres


def test_reader_and_epoch_states_on_the_rinex_text(navs):
    nav, _ = navs
    epoch = read_obs(DATA + "base.obs", max_epochs=2)[1]
    assert (epoch.week, epoch.tow) == (2320, 116401.0)
    i = epoch.row("G05")
    # the file's own text: second epoch, G05 line, C1C after the channel pseudo-observable X1
    text = open(DATA + "base.obs").read().split("\n> ")[2]
    line = next(row for row in text.splitlines() if row.startswith("G05"))
    assert epoch.code[i, 0] == float(line[3 + 16:3 + 16 + 14])
    assert epoch.phase[i, 0] == float(line[3 + 32:3 + 32 + 14])
    assert len(epoch.sats) >= 45
    assert np.isfinite(epoch.code[i]).all() and np.isfinite(epoch.phase[i]).all()
    assert epoch.wavelength[i, 0] == pytest.approx(299792458.0 / 1575.42e6)
    assert epoch.wavelength[epoch.row("C08"), 0] == pytest.approx(299792458.0 / 1561.098e6)
    sv = satellite_states(epoch, nav, BASE)
    assert sv.valid.sum() >= 45
    # pseudorange − range + satellite clock: one receiver clock for all satellites, plus atmosphere (≤ ~70 m
    # near the horizon; GPS only: no inter-system offsets); km would mean a wrong orbit or time
    pr = epoch.first_code()
    rest = pr - np.linalg.norm(sv.pos - BASE, axis=1) + 299792458.0 * sv.clock
    gps = sv.valid & np.array([s[0] == "G" for s in epoch.sats])
    rest = rest[gps] - np.median(rest[gps])
    assert np.abs(rest).max() < 100.0
    # one call for one satellite agrees with the epoch's row
    state = satellite_state("G05", epoch.week, epoch.tow, pr[i], nav, BASE)
    assert np.allclose(state[0], sv.pos[i])
