"""Simulated raw GNSS observations (gnss_raw_sim) and the tightly coupled filter on them (gnss_raw.tight)."""
from pathlib import Path

import numpy as np
import pytest

from agnav_fusion.gnss_raw.double_difference import DDConfig, form_double_differences
from agnav_fusion.gnss_raw.ephemeris import satellite_states
from agnav_fusion.gnss_raw.geometry import elevation_azimuth
from agnav_fusion.gnss_raw.observations import CLIGHT
from agnav_fusion.gnss_raw.rinex import read_nav
from agnav_sim_eval.sim.gnss_raw_sim import RawSimConfig, SkyMask, enu_frame, simulate_raw

NAV = Path("/work/shared/data/real/gnss_raw/matrtklib_static/base.nav")
pytestmark = pytest.mark.skipif(not NAV.exists(), reason="shared GNSS data not present")
DATUM = (35.996, 139.6, 50.0)


@pytest.fixture(scope="module")
def nav():
    return read_nav(NAV)


def straight_track(duration=30.0, speed=2.0):
    origin, axes = enu_frame(DATUM)
    t = np.round(np.arange(0.0, duration + 1e-9, 0.01), 2)
    enu = np.stack([speed * t, np.zeros_like(t), np.full_like(t, 2.8)], axis=1)
    return t, origin + enu @ axes, np.tile(np.array([speed, 0.0, 0.0]) @ axes, (len(t), 1)), origin, axes


def test_observations_consistent_with_geometry(nav):
    t, pos, vel, origin, axes = straight_track()
    sim = simulate_raw(t, pos, vel, nav, origin, axes, RawSimConfig(slip_rate=0.0, seed=3))
    assert len(sim.epochs) == 31 and len(sim.epochs[0].rover.sats) >= 15
    frac, code = [], []
    for e in sim.epochs:
        cache = {}
        sv_r = satellite_states(e.rover, nav, e.antenna, cache)
        sv_b = satellite_states(e.base, nav, sim.base_pos, cache)
        dd = form_double_differences(e.rover, e.base, sv_r, sv_b, sim.base_pos, DDConfig())
        h, _ = dd.geometry(e.antenna)          # DD residuals at the true antenna position
        code += list(dd.code - h)
        cyc = (dd.phase - h) / dd.wavelength
        frac += list(cyc - np.round(cyc))
        # Doppler between satellites (receiver drift cancels) against the true range rates
        i, j = 0, 1
        lam = e.rover.wavelength[:, 0]
        rr = [(sv_r.vel[k] - vel[0]) @ (sv_r.pos[k] - e.antenna) / np.linalg.norm(sv_r.pos[k] - e.antenna)
              - CLIGHT * sv_r.drift[k] for k in (i, j)]
        meas = -lam[i] * e.rover.doppler[i, 0] + lam[j] * e.rover.doppler[j, 0]
        assert abs(meas - (rr[0] - rr[1])) < 0.2
    assert np.sqrt(np.mean(np.square(code))) < 1.5 and abs(np.mean(code)) < 0.3
    assert np.max(np.abs(frac)) < 0.25 and np.sqrt(np.mean(np.square(frac))) < 0.06   # integers + cm of noise


def test_sky_masks_and_reacquisition(nav):
    t, pos, vel, origin, axes = straight_track(20.0)
    masks = [SkyMask(5.0, 10.0, keep=3), SkyMask(12.0, 20.0, az_deg=(180.0, 360.0), max_el_deg=45.0)]
    sim = simulate_raw(t, pos, vel, nav, origin, axes, RawSimConfig(masks=masks, slip_rate=0.0))
    for e in sim.epochs:
        sv = satellite_states(e.rover, nav, e.antenna)
        el, az = (np.degrees(a) for a in elevation_azimuth(e.antenna, sv.pos))
        if 5.0 <= e.t < 10.0:
            assert len(e.rover.sats) == 3 and all(s[0] == "G" for s in e.rover.sats) and el.min() > 15.0
        if 12.0 <= e.t < 20.0:
            assert not np.any(((az % 360) >= 180.0) & (el < 45.0))
        if e.t in (10.0, 20.0):      # satellites back from behind the mask restart with loss of lock
            back = [i for i, s in enumerate(e.rover.sats) if s not in prev.rover.sats]
            assert back and e.rover.lli[back, 0].all()
        prev = e
    assert all(len(e.base.sats) >= 15 for e in sim.epochs)      # the base sees the whole sky


def test_tight_filter_converges_and_bridges_three_satellites(nav):
    from agnav_sim_eval.sim.gnss_raw_sim_runs import run_coupled, window_errors
    from agnav_sim_eval.sim.run import simulate
    from agnav_sim_eval.sim.scenarios import field_passes
    run = simulate("mems_field", seed=2, route=field_passes(40.0, 6.0, 2))
    res = run_coupled(run, nav, "three_sat", window=(45.0, 60.0), handover=30.0)
    before = np.linalg.norm(res.tight_err[res.t < 45.0, :2], axis=1)
    assert before[-5:].max() < 0.05 and res.fixed[res.t < 45.0].any()
    _, tight, loose = window_errors(res)
    assert np.all(res.n_dd[(res.t >= 45.0) & (res.t < 60.0)] == 2)
    assert tight[-1] < 0.10 and tight[-1] < loose[-1]


def test_jacobians_follow_the_ins_conventions(nav):
    from agnav_fusion.gnss_raw.tight import TightFilter, antenna_state
    from agnav_fusion.ins import InsEkf, InsEkfSettings, InsState, Mechanization
    from agnav_fusion.ins import error_model as em
    from agnav_fusion.gnss_raw.geometry import enu_basis
    mech = Mechanization(InsState.from_geodetic(np.radians(36.0), np.radians(139.6), 50.0, 0.0, 0.0, 0.5,
                                                (1.0, 1.0, 0.0)))
    s = InsEkfSettings(lever_gnss_frd=(0.0, 0.0, -2.0))
    ins = InsEkf(s)
    ins.adopt(mech, np.eye(16) * 1e-4, t=0.0)
    f = TightFilter(ins, np.zeros(3))
    jp, jv = f.jacobians()
    east, north, up = enu_basis(antenna_state(mech, f.lever, np.zeros(3))[0])
    assert np.allclose(jp[:, em.H], up, atol=1e-6)                         # δh > 0: antenna computed too high
    assert abs(np.linalg.norm(jp[:, em.RX]) - 6.37e6) < 2e4                # a radian of position error
    assert np.allclose(jv[:, em.VZ], up, atol=1e-6)
    assert np.linalg.norm(jp[:, em.GAMMA]) < 1e-4                          # antenna above the IMU: no heading arm
    assert abs(np.linalg.norm(jv[:, em.GAMMA]) - np.sqrt(2.0)) < 1e-3      # velocity turned by the azimuth error


def test_unflagged_slips_found_by_doppler_phase(nav):
    from agnav_fusion.gnss_raw.tight import doppler_phase_slips
    t, pos, vel, origin, axes = straight_track(40.0)
    sim = simulate_raw(t, pos, vel, nav, origin, axes, RawSimConfig(slip_rate=0.02, slip_flagged=0.0, seed=5))
    truth, found = set(), set()
    for prev, e in zip(sim.epochs, sim.epochs[1:]):
        assert not e.rover.lli[[e.rover.row(s) for s in e.slipped], 0].any()     # silent slips
        truth |= {(e.t, s) for s in e.slipped}
        found |= {(e.t, s) for s in doppler_phase_slips(prev.rover, e.rover)}
    assert len(truth) >= 5 and truth == found


def test_switching_every_transition_without_a_jump(nav):
    from agnav_sim_eval.sim.gnss_raw_sim_switch import SWITCH_WINDOWS as W, run_switching
    from agnav_sim_eval.sim.run import simulate
    res = run_switching(simulate("mems_field", seed=1), nav)
    seen = [(tr["from"], tr["to"]) for tr in res.transitions]
    assert seen == [("loose", "tight"), ("tight", "ins_only"), ("ins_only", "tight"), ("tight", "loose")]
    assert all(tr["jump_sigma"] < 3.0 for tr in res.transitions)
    mode = np.array(res.mode)
    for name, want in (("three_sat", "tight"), ("outage", "ins_only"), ("refloat", "tight")):
        sel = (res.t >= W[name][0]) & (res.t < W[name][1])
        assert np.all(mode[sel] == want), name
    assert np.all(mode[res.t >= W["refloat"][1] + 1.0] == "loose")
    horiz = np.linalg.norm(res.err[:, :2], axis=1)
    assert horiz[(res.t >= W["three_sat"][0]) & (res.t < W["three_sat"][1])].max() < 0.10
    assert res.refix_time_s < 10.0 and horiz[res.t >= W["outage"][1] + res.refix_time_s].max() < 0.05
