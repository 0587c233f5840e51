"""WGS-84 earth model: radii of curvature, earth rate, normal gravity (SPEC §7.2 steps 8, 10, 11)."""
import math

import numpy as np

A = 6378137.0                    # equatorial radius [m]
F = 1.0 / 298.257223563          # flattening
E2 = 6.69437999014e-3            # first eccentricity squared
OMEGA = 7.2921159e-5             # earth rate [rad/s] (report: "7.959 5" after digit loss)
GM_RATIO = 0.00344978600308      # m = omega^2 a^2 b / GM
GAMMA_E = 9.7803253359           # normal gravity at the equator [m/s^2]
K_SOMIGLIANA = 0.00193185265241


def radii(lat):
    """Meridian R_M and prime-vertical R_N radii of curvature at latitude lat [rad] (5-3-18)."""
    s2 = math.sin(lat) ** 2
    w = math.sqrt(1.0 - E2 * s2)
    return A * (1.0 - E2) / w ** 3, A / w


def wander_radii(lat, h, alpha):
    """1/R_x, 1/R_y and 1/tau of the wander frame, sin^2/cos^2 form (5-3-16..18, 5-3-29/30)."""
    rm, rn = radii(lat)
    im, i_n = 1.0 / (rm + h), 1.0 / (rn + h)
    sa, ca = math.sin(alpha), math.cos(alpha)
    return sa * sa * i_n + ca * ca * im, ca * ca * i_n + sa * sa * im, sa * ca * (im - i_n)


def local_terms(lat, h, sl, sa, ca):
    """wander_radii(lat, h, alpha) and gravity(lat, h) at once, from sl = sin(lat), sa, ca = sin, cos(alpha)."""
    s2 = sl ** 2
    w = math.sqrt(1.0 - E2 * s2)
    rm, rn = A * (1.0 - E2) / w ** 3, A / w
    im, i_n = 1.0 / (rm + h), 1.0 / (rn + h)
    g0 = GAMMA_E * (1.0 + K_SOMIGLIANA * s2) / w
    return (sa * sa * i_n + ca * ca * im, ca * ca * i_n + sa * sa * im, sa * ca * (im - i_n),
            g0 * (1.0 - 2.0 / A * (1.0 + F + GM_RATIO - 2.0 * F * s2) * h + 3.0 * h * h / (A * A)))


def transport_rate(v, lat, h, alpha):
    """rho^C of the wander frame, rho_z = 0 (5-3-16..18)."""
    irx, iry, itau = wander_radii(lat, h, alpha)
    v0, v1 = float(v[0]), float(v[1])
    return np.array([-v1 * iry + v0 * itau, v0 * irx - v1 * itau, 0.0])


def earth_rate_c(lat, alpha):
    """Earth rate resolved in C (5-3-23..25)."""
    cl = math.cos(lat)
    return OMEGA * np.array([cl * math.cos(alpha), -cl * math.sin(alpha), math.sin(lat)])


def gravity(lat, h):
    """Normal gravity magnitude [m/s^2] (Somigliana + free-air series; SI replacement of 5-3-28)."""
    s2 = math.sin(lat) ** 2
    g0 = GAMMA_E * (1.0 + K_SOMIGLIANA * s2) / math.sqrt(1.0 - E2 * s2)
    return g0 * (1.0 - 2.0 / A * (1.0 + F + GM_RATIO - 2.0 * F * s2) * h + 3.0 * h * h / (A * A))


def gravity_c(lat, h, alpha):
    """Gravity vector in C (up is +Z): [g_N cos a, -g_N sin a, -g] (5-3-26..28)."""
    g_n = -8.08e-9 * h * math.sin(2.0 * lat)
    return np.array([g_n * math.cos(alpha), -g_n * math.sin(alpha), -gravity(lat, h)])


def mean_radius(lat):
    """Geometric mean radius sqrt(R_M R_N), the R of the spherical error model (SPEC §7.3)."""
    rm, rn = radii(lat)
    return math.sqrt(rm * rn)
