"""Height aiding of the tightly coupled filter in poor geometry: a vehicle on a field does not change height quickly.

With few double differences (3 satellites: 2 DDs) the direction they leave unobserved is mostly up with some north
in it, and the INS alone lets the horizontal drift along it. The tight filter carries a height reference state
(total, metres of the antenna's geodetic height, like the clock drift):
  learnt   while the geometry is good (≥ `min_dd` DDs and the antenna's vertical σ ≤ `max_sigma`, and at the
           hand-over from the loosely coupled filter): set to the antenna height estimate with its variance and
           cross-covariances (a copy of the estimate: nothing counted twice, the reference's error stays correlated
           with the position's);
  walks    with the terrain: variance `walk`² per metre driven (none standing still);
  fused    otherwise, as z = ĥ_ref − h(r̂) = −u·δr_E − δh_ref + n with n ~ `sigma` (terrain roughness, tilt × lever
           arm under the antenna; white at the epoch rate), u the geodetic up in ECEF.
Sign conventions of gnss_raw.tight: INS error states x = computed − true (δr_E = J_pos x), total states corrected
by + x. ROS-free.
"""
from dataclasses import dataclass

import numpy as np

from agnav_fusion.gnss_raw.geometry import ecef_to_llh, enu_basis


@dataclass
class HeightAidConfig:
    min_dd: int = 4             # fewer DDs than this: the antenna height is held to the reference (0: never)
    max_sigma: float = 0.1      # m, a larger antenna vertical sigma is also held; else (enough DDs) learnt
    sigma: float = 0.03         # m, antenna height about the reference (terrain roughness, tilt x lever arm)
    walk: float = 0.01          # m/sqrt(m), random walk of the reference per metre driven (terrain slope)


def height_row(pos, jp):
    """(geodetic height [m], a) of the antenna at ECEF `pos`: a = u·J_pos, its height error per state."""
    return float(ecef_to_llh(pos)[2]), enu_basis(pos)[2] @ jp


def poor_geometry(config, n_dd, a, p):
    """True when the vertical is poorly determined: fewer than min_dd DDs or σ_up = √(a P aᵀ) above max_sigma."""
    return n_dd < config.min_dd or float(a @ p @ a) > config.max_sigma ** 2


def learn(p, k, a):
    """P with state k (the reference) a copy of the antenna height: its correction δh_ref = −a x."""
    a = a.copy()
    a[k] = 0.0
    row = -(a @ p)
    p = p.copy()
    p[k, :], p[:, k] = row, row
    p[k, k] = -float(row @ a)
    return p


def block(config, k, x_ref, height, a):
    """(z, H, R) of the height pseudo-measurement against the reference state k at value x_ref."""
    h = -a
    h[k] = -1.0
    return np.array([x_ref - height]), h[None, :], np.array([[config.sigma ** 2]])
