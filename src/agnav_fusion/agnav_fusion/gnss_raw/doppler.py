"""Receiver velocity and clock drift from undifferenced Doppler (SPEC §7.8), and a code-only position for the
line-of-sight vectors.

Range rate of satellite j: -λ·D_j = u_j·(v_j − v) + c·(δ̇ − δ̇_j), u_j the unit vector receiver → satellite,
δ̇ the receiver clock drift (one for all systems: one oscillator), δ̇_j the satellite's. Weighted least squares in
(v, c·δ̇) with σ²(el) = σ0²(1 + 1/sin²el), residuals beyond 4σ dropped one at a time. The position only orients
u_j: a pseudorange fix with per-system clocks and no atmosphere (tens of metres) is plenty.
"""
from dataclasses import dataclass

import numpy as np

from agnav_fusion.gnss_raw.geometry import elevation_azimuth
from agnav_fusion.gnss_raw.observations import CLIGHT


@dataclass
class DopplerVelocity:
    vel: np.ndarray       # (3,) ECEF m/s
    drift: float          # m/s, c·receiver clock drift
    cov: np.ndarray       # (3, 3) m²/s²
    n: int                # satellites used
    rms: float            # m/s, residual RMS


def first_slot(values):
    """(n,) the first finite value of each row and the slot it came from (-1 if none)."""
    out, slot = np.full(len(values), np.nan), np.full(len(values), -1)
    for f in range(values.shape[1] - 1, -1, -1):
        ok = np.isfinite(values[:, f])
        out[ok], slot[ok] = values[ok, f], f
    return out, slot


def code_position(epoch, sv, guess, iterations=8):
    """Receiver ECEF position (m) from the first pseudorange of each valid satellite, one clock per system."""
    pr = epoch.first_code()
    ok = sv.valid & np.isfinite(pr)
    systems = sorted({s[0] for s, k in zip(epoch.sats, ok) if k})
    x = np.concatenate([np.asarray(guess, float), np.zeros(len(systems))])
    if ok.sum() < 3 + len(systems):
        return None
    idx = np.flatnonzero(ok)
    for _ in range(iterations):
        d = sv.pos[idx] - x[:3]
        r = np.linalg.norm(d, axis=1)
        H = np.zeros((len(idx), len(x)))
        H[:, :3] = -d / r[:, None]
        clock = np.zeros(len(idx))
        for j, i in enumerate(idx):
            k = systems.index(epoch.sats[i][0])
            H[j, 3 + k] = 1.0
            clock[j] = x[3 + k]
        dx = np.linalg.lstsq(H, pr[idx] + CLIGHT * sv.clock[idx] - r - clock, rcond=None)[0]
        x += dx
        if np.linalg.norm(dx[:3]) < 1e-3:
            break
    return x[:3]


def doppler_velocity(epoch, sv, rx_pos, sigma0=0.05, mask_deg=10.0, gate=4.0):
    """DopplerVelocity of the receiver at `rx_pos` (ECEF m) from one ObsEpoch and its SatelliteStates; None with
    fewer than 5 usable satellites."""
    dop, slot = first_slot(epoch.doppler)
    lam = np.array([epoch.wavelength[i, f] if f >= 0 else np.nan for i, f in enumerate(slot)])
    ok = sv.valid & np.isfinite(dop) & np.isfinite(lam)
    idx = np.flatnonzero(ok)
    if len(idx) < 5:
        return None
    el = elevation_azimuth(rx_pos, sv.pos[idx])[0]
    keep = el > np.radians(mask_deg)
    idx, el = idx[keep], el[keep]
    d = sv.pos[idx] - rx_pos
    u = d / np.linalg.norm(d, axis=1, keepdims=True)
    # -λD − u·v_j + c·δ̇_j = −u·v + c·δ̇
    y = -lam[idx] * dop[idx] - np.sum(u * sv.vel[idx], axis=1) + CLIGHT * sv.drift[idx]
    H = np.hstack([-u, np.ones((len(idx), 1))])
    w = 1.0 / (sigma0 ** 2 * (1.0 + 1.0 / np.sin(el) ** 2))
    use = np.ones(len(idx), bool)
    while use.sum() >= 5:
        Hw = H[use] * w[use, None]
        N = H[use].T @ Hw
        x = np.linalg.solve(N, Hw.T @ y[use])
        res = (y - H @ x) * np.sqrt(w)
        worst = np.argmax(np.where(use, np.abs(res), -1.0))
        if abs(res[worst]) <= gate:
            rms = float(np.sqrt(np.mean((y - H @ x)[use] ** 2)))
            return DopplerVelocity(x[:3], float(x[3]), np.linalg.inv(N)[:3, :3], int(use.sum()), rms)
        use[worst] = False
    return None
