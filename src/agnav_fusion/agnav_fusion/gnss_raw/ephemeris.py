"""Satellite positions, velocities and clocks from broadcast ephemerides (cssrlib's Keplerian maths).

For each satellite of an epoch: transmission time from the pseudorange (t_rx - P/c, corrected by the satellite
clock), orbit and clock at that time (cssrlib eph2pos: GPS/Galileo/QZSS/BeiDou incl. BeiDou GEO, relativistic
clock term included), then the Earth-rotation (Sagnac) correction: the ECEF frame of transmission time is rotated
by ω_E·τ, τ = geometric range / c to the approximate receiver position, into the frame of reception time, so
ranges are plain Euclidean norms. Velocity and clock drift are central differences of the library's position and
clock (its analytic velocity is off by ~0.2 m/s and ignores the BeiDou GEO rotation). GLONASS is not covered
(no common wavelength for double differences).
"""
from dataclasses import dataclass

import numpy as np
from cssrlib.ephemeris import eph2pos, findeph
from cssrlib.gnss import gpst2time, id2sat, timeadd, timediff

from agnav_fusion.gnss_raw.observations import CLIGHT

OMEGA_E = 7.2921151467e-5  # rad/s, WGS-84 Earth rotation rate
DIFF_STEP = 0.01           # s, half-step of the central differences (velocity, clock drift)
REUSE_WITHIN = 0.01        # s: a cached orbit this close in time is extrapolated (error < 0.1 mm)


@dataclass
class SatelliteStates:
    """Per satellite of an epoch (rows as ObsEpoch.sats), ECEF at reception time of the given receiver."""
    sats: list
    pos: np.ndarray      # (n, 3) m
    vel: np.ndarray      # (n, 3) m/s
    clock: np.ndarray    # (n,) s, satellite clock offset incl. relativistic term
    drift: np.ndarray    # (n,) s/s
    valid: np.ndarray    # (n,) bool: ephemeris found, healthy, pseudorange present


def rotate_z(vec, angle):
    """`vec` (..., 3) expressed in a frame rotated by `angle` about z (the Earth's turn over angle/ω_E)."""
    vec = np.asarray(vec, float)
    c, s = np.cos(angle), np.sin(angle)
    out = vec.copy()
    out[..., 0] = c * vec[..., 0] + s * vec[..., 1]
    out[..., 1] = -s * vec[..., 0] + c * vec[..., 1]
    return out


def ephemeris_for(sid, t, nav):
    """cssrlib's broadcast record for satellite `sid` nearest gtime `t`, None if absent or unhealthy."""
    eph = findeph(nav.eph, t, id2sat(sid))
    return eph if eph is not None and eph.svh == 0 else None


def orbit_at(t, eph):
    """(pos, vel, clock, drift) of the record `eph` at gtime `t` (GPS time of transmission), ECEF of that time."""
    pos, clock = eph2pos(t, eph)
    pos_p, clock_p = eph2pos(timeadd(t, DIFF_STEP), eph)
    pos_m, clock_m = eph2pos(timeadd(t, -DIFF_STEP), eph)
    return pos, (pos_p - pos_m) / (2 * DIFF_STEP), float(clock), float(clock_p - clock_m) / (2 * DIFF_STEP)


def satellite_state(sid, week, tow, pseudorange, nav, rx_pos, cache=None):
    """(pos, vel, clock, drift) of satellite `sid` for a signal received at GPS (week, tow) with `pseudorange`
    [m] by a receiver near `rx_pos` (ECEF m), in the ECEF frame of reception; None without a healthy record.
    `cache` (dict, shared by the receivers of one epoch) keeps orbits to extrapolate instead of recomputing."""
    t_tx = timeadd(gpst2time(week, tow), -pseudorange / CLIGHT)
    hit = cache.get(sid) if cache is not None else None
    if hit is not None and abs(timediff(t_tx, hit[0])) < REUSE_WITHIN:
        t0, pos0, vel, clock0, drift = hit
        dt = timediff(t_tx, t0) - clock0
        dt -= drift * dt                                        # clock at the corrected transmission time
        pos, clock = pos0 + vel * dt, clock0 + drift * dt
    else:
        eph = ephemeris_for(sid, t_tx, nav)
        if eph is None:
            return None
        t_tx = timeadd(t_tx, -eph2pos(t_tx, eph)[1])
        pos, vel, clock, drift = orbit_at(t_tx, eph)
        if cache is not None:
            cache[sid] = (t_tx, pos, vel, clock, drift)
    tau = np.linalg.norm(pos - rx_pos) / CLIGHT
    tau = np.linalg.norm(rotate_z(pos, OMEGA_E * tau) - rx_pos) / CLIGHT
    return rotate_z(pos, OMEGA_E * tau), rotate_z(vel, OMEGA_E * tau), clock, drift


def satellite_states(epoch, nav, rx_pos, cache=None):
    """SatelliteStates for every satellite of an ObsEpoch, received near `rx_pos` (ECEF m); `cache` as in
    satellite_state (pass one dict for the rover and base epochs of the same time)."""
    n = len(epoch.sats)
    pos, vel = np.full((n, 3), np.nan), np.full((n, 3), np.nan)
    clock, drift, valid = np.full(n, np.nan), np.full(n, np.nan), np.zeros(n, bool)
    rx_pos = np.asarray(rx_pos, float)
    for i, (sid, pr) in enumerate(zip(epoch.sats, epoch.first_code())):
        if sid[0] not in "GEJC" or not np.isfinite(pr):
            continue
        state = satellite_state(sid, epoch.week, epoch.tow, pr, nav, rx_pos, cache)
        if state is not None:
            pos[i], vel[i], clock[i], drift[i] = state
            valid[i] = True
    return SatelliteStates(list(epoch.sats), pos, vel, clock, drift, valid)
