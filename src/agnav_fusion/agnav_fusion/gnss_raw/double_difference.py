"""Double differences (rover − base, reference − satellite) of code and carrier phase, with their covariance.

One reference satellite per (system, frequency) group — the highest above the elevation mask whose phase did
not lose lock (double differences between systems or carriers would keep inter-system/inter-frequency biases
and non-integer ambiguities). Sign as SPEC §7.7 (5-7-7): DD = (ρ_u^ref − ρ_k^ref) − (ρ_u^j − ρ_k^j).

Covariance: undifferenced variance σ²(el) = σ0²·(1 + 1/sin²el) per receiver (both receivers see a satellite at
about the same elevation on a short baseline), single-difference variance v = 2σ²(el), and for one group
cov(DD) = v_ref·11ᵀ + diag(v_j) — with equal variances 2σ²(I + 11ᵀ). Groups are uncorrelated; code and phase
are uncorrelated.
"""
from dataclasses import dataclass, field

import numpy as np

from agnav_fusion.gnss_raw.geometry import elevation_azimuth

SYSTEMS = "GEJC"


@dataclass
class DDConfig:
    elevation_mask_deg: float = 15.0  # deg, satellites below are not used
    snr_mask_dbhz: float = 35.0       # dB-Hz, weaker signals are not used
    sigma_code: float = 1.5     # m, undifferenced σ0 of the pseudorange: 0.3 m of epoch noise inflated by ~5 for
    #                             multipath correlated over ~10 s (the filter takes epochs as independent)
    sigma_phase: float = 0.003  # m, undifferenced σ0 of the carrier phase


@dataclass
class DoubleDifferences:
    """One epoch's double differences; row i belongs to ambiguity key keys[i] = (system, slot, satellite)."""
    keys: list
    refs: dict                   # (system, slot) -> reference satellite
    code: np.ndarray             # (m,) m
    phase: np.ndarray            # (m,) m (λ·cycles)
    wavelength: np.ndarray       # (m,) m
    ref_pos: np.ndarray          # (m, 3) reference satellite at the rover (ECEF m)
    sat_pos: np.ndarray          # (m, 3) satellite j at the rover
    base_term: np.ndarray        # (m,) ρ_k^ref − ρ_k^j at the known base position
    cov_code: np.ndarray         # (m, m)
    cov_phase: np.ndarray        # (m, m)
    slip: np.ndarray             # (m,) bool: loss of lock of satellite j at either receiver
    ref_slip: dict = field(default_factory=dict)  # (system, slot) -> reference lost lock
    elevation: np.ndarray = None  # (m,) rad of satellite j

    def __len__(self):
        return len(self.keys)

    def geometry(self, rover_pos):
        """(h, H): DD geometric ranges at `rover_pos` (m,) and their Jacobian ∂h/∂rover_pos (m, 3)."""
        d_ref, d_sat = self.ref_pos - rover_pos, self.sat_pos - rover_pos
        r_ref, r_sat = np.linalg.norm(d_ref, axis=1), np.linalg.norm(d_sat, axis=1)
        h = r_ref - r_sat - self.base_term
        return h, -d_ref / r_ref[:, None] + d_sat / r_sat[:, None]


def undifferenced_variance(sigma0, elevation):
    return sigma0 ** 2 * (1.0 + 1.0 / np.sin(elevation) ** 2)


def dd_covariance(var_ref, var_sats):
    """Covariance of the DDs of one group from single-difference variances: v_ref·11ᵀ + diag(v_j)."""
    var_sats = np.asarray(var_sats, float)
    return np.full((len(var_sats), len(var_sats)), float(var_ref)) + np.diag(var_sats)


def dd_operator(n):
    """(n−1, n) matrix taking single differences [ref, j2, ...] to double differences ref − j."""
    return np.hstack([np.ones((n - 1, 1)), -np.eye(n - 1)])


def _block_diag(blocks):
    m = sum(len(b) for b in blocks)
    out, i = np.zeros((m, m)), 0
    for b in blocks:
        out[i:i + len(b), i:i + len(b)] = b
        i += len(b)
    return out


def form_double_differences(rover, base, sv_rover, sv_base, base_pos, config=DDConfig()):
    """DoubleDifferences of two ObsEpochs with their SatelliteStates; None if no group has two satellites."""
    base_pos = np.asarray(base_pos, float)
    mask_el = np.radians(config.elevation_mask_deg)
    rows = []   # (system, slot, sat, i_rover, i_base, elevation, slip)
    for sid in rover.sats:
        i, k = rover.row(sid), base.row(sid)
        if sid[0] not in SYSTEMS or k is None or not (sv_rover.valid[i] and sv_base.valid[k]):
            continue
        el = float(elevation_azimuth(base_pos, sv_base.pos[k])[0][0])
        if el < mask_el:
            continue
        for f in range(rover.code.shape[1]):
            obs = (rover.code[i, f], rover.phase[i, f], base.code[k, f], base.phase[k, f])
            if not np.all(np.isfinite(obs)) or min(rover.snr[i, f], base.snr[k, f]) < config.snr_mask_dbhz:
                continue
            rows.append((sid[0], f, sid, i, k, el, bool(rover.lli[i, f] or base.lli[k, f])))
    groups = {}
    for r in rows:
        groups.setdefault((r[0], r[1]), []).append(r)
    keys, refs, ref_slip, parts = [], {}, {}, []
    for g, members in sorted(groups.items()):
        if len(members) < 2:
            continue
        ref = max(members, key=lambda r: (not r[6], r[5]))   # lock kept first, then elevation
        others = [r for r in members if r is not ref]
        refs[g], ref_slip[g] = ref[2], ref[6]
        keys += [(g[0], g[1], r[2]) for r in others]
        parts.append((ref, others))
    if not parts:
        return None
    code, phase, wl, ref_pos, sat_pos, base_term, slip, elev, cov_c, cov_p = ([] for _ in range(10))
    for ref, others in parts:
        f = ref[1]

        def sd(r):
            i, k = r[3], r[4]
            lam = rover.wavelength[i, f]
            return (rover.code[i, f] - base.code[k, f], lam * (rover.phase[i, f] - base.phase[k, f]), lam,
                    np.linalg.norm(sv_base.pos[k] - base_pos))
        c0, p0, lam0, rb0 = sd(ref)
        for r in others:
            c, p, lam, rb = sd(r)
            code.append(c0 - c)
            phase.append(p0 - p)
            wl.append(lam)
            ref_pos.append(sv_rover.pos[ref[3]])
            sat_pos.append(sv_rover.pos[r[3]])
            base_term.append(rb0 - rb)
            slip.append(r[6])
            elev.append(r[5])
        el_o = np.array([r[5] for r in others])
        cov_c.append(dd_covariance(2 * undifferenced_variance(config.sigma_code, ref[5]),
                                   2 * undifferenced_variance(config.sigma_code, el_o)))
        cov_p.append(dd_covariance(2 * undifferenced_variance(config.sigma_phase, ref[5]),
                                   2 * undifferenced_variance(config.sigma_phase, el_o)))
    return DoubleDifferences(keys, refs, np.array(code), np.array(phase), np.array(wl), np.array(ref_pos),
                             np.array(sat_pos), np.array(base_term), _block_diag(cov_c), _block_diag(cov_p),
                             np.array(slip), ref_slip, np.array(elev))
