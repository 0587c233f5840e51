"""Chi-square quantiles for the innovation gates, in closed form (integer degrees of freedom): importing scipy.stats
for `chi2.ppf` cost every graph ~0.3 s of start-up. The survival function of an integer-dof chi-square is a finite
sum (even dof: a Poisson tail; odd dof: erfc plus half-integer terms), inverted by bisection to full precision;
test/ins/test_chi2.py checks it against scipy."""
import math


def sf(x, dof):
    """P(X > x) for X ~ chi-square with integer dof >= 1."""
    if x <= 0.0:
        return 1.0
    h = 0.5 * x
    e = math.exp(-h)
    if dof % 2 == 0:
        term = total = 1.0
        for i in range(1, dof // 2):
            term *= h / i
            total += term
        return e * total
    term = math.sqrt(h) / (0.5 * math.sqrt(math.pi))      # h^(1/2) / Gamma(3/2)
    total = 0.0
    for i in range(1, (dof + 1) // 2):
        total += term
        term *= h / (i + 0.5)
    return math.erfc(math.sqrt(h)) + e * total


def ppf(p, dof):
    """x with P(X <= x) = p (0 < p < 1) for X ~ chi-square with integer dof >= 1."""
    if not (0.0 < p < 1.0) or dof < 1 or dof != int(dof):
        raise ValueError(f"chi2.ppf needs 0 < p < 1 and an integer dof >= 1 (got {p}, {dof})")
    dof, q = int(dof), 1.0 - p
    lo, hi = 0.0, float(dof) + 1.0
    while sf(hi, dof) > q:
        lo, hi = hi, 2.0 * hi
    while True:
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            return hi if abs(sf(hi, dof) - q) <= abs(sf(lo, dof) - q) else lo
        if sf(mid, dof) > q:
            lo = mid
        else:
            hi = mid
