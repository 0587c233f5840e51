"""Integer least squares for float ambiguities: the LAMBDA method (Teunissen 1995) in the MLAMBDA form of
Chang, Yang & Zhou (2005): LᵀDL factorisation, decorrelation by integer Gauss transformations and
permutations, then a depth-first search with a shrinking ellipsoid for the best `ncands` integer vectors.

Written from the published equations: numpy row operations on [Lᵀ | Zᵀ] in the reduction (one operation per
Gauss transformation for L and Z together), plain Python floats in the search (element access on numpy arrays is
what makes a naive port slow). The input is ordered least precise first, which halves the swaps. ~10 ms for the
~43 kinematic DD ambiguities of the static real pair, against ~95 ms for cssrlib's mlambda.
"""
import math

import numpy as np


class SearchBudgetExceeded(ArithmeticError):
    """The search visited `max_nodes` nodes without finishing (the candidates would not be proven best)."""


def ltdl(Q):
    """(L, d) with Q = Lᵀ·diag(d)·L, L unit lower triangular (factorised from the last index up)."""
    A = np.array(Q, float, copy=True)
    n = len(A)
    L, d = np.zeros((n, n)), np.zeros(n)
    for i in range(n - 1, -1, -1):
        d[i] = A[i, i]
        if d[i] <= 0.0:
            raise np.linalg.LinAlgError("ambiguity covariance not positive definite")
        row = A[i, :i + 1] / math.sqrt(d[i])
        A[:i, :i] -= np.outer(row[:i], row[:i])
        L[i, :i + 1] = row / row[i]
    return L, d


def _gauss(M, n, i, k):
    """Integer Gauss transformation on M = [Lᵀ | Zᵀ] (columns of L and Z as contiguous rows): make
    |L[i, k]| ≤ 1/2 by subtracting round(L[i, k]) times column i from column k, of L and Z alike."""
    mu = round(M[k, i])
    if mu != 0:
        M[k, i:] -= mu * M[i, i:]


def _reduce_column(M, n, k, start):
    """Gauss transformations of column k of L for rows start, start+1, ... in order (each changes only the rows
    below it, so the next entry above 1/2 is looked up after each one)."""
    i = start
    while i < n:
        big = np.abs(M[k, i:n]) > 0.5
        j = int(big.argmax())
        if not big[j]:
            return
        i += j
        _gauss(M, n, i, k)
        i += 1


def reduce(L, d):
    """Decorrelate: (L, d, Z) with Zᵀ Q Z = Lᵀ diag(d) L, Z unimodular, d sorted towards small last.
    Partial reduction (Xie, Chang & Borno 2011): L[k+1, k] alone decides a swap, so the rest of column k is
    reduced only before a swap (keeps the entries, and Z, small); the full size reduction of L, which only speeds
    up the search, is done once at the end."""
    n = len(d)
    M, d = np.hstack([L.T, np.eye(n)]), d.copy()
    k = n - 2
    while k >= 0:
        _gauss(M, n, k + 1, k)
        l_kk1 = M[k, k + 1]
        delta = d[k] + l_kk1 * l_kk1 * d[k + 1]
        if delta + 1e-6 < d[k + 1]:           # swap k and k+1 (conditional variances out of order)
            _reduce_column(M, n, k, k + 2)
            eta, lam = d[k] / delta, d[k + 1] * l_kk1 / delta
            d[k], d[k + 1] = eta * d[k + 1], delta
            a0, a1 = M[:k, k].copy(), M[:k, k + 1].copy()
            M[:k, k] = -l_kk1 * a0 + a1
            M[:k, k + 1] = eta * a0 + lam * a1
            M[k, k + 1] = lam
            tmp = M[k, k + 2:].copy()         # swap the rest of columns k, k+1 of L and of Z
            M[k, k + 2:] = M[k + 1, k + 2:]
            M[k + 1, k + 2:] = tmp
            k = min(k + 1, n - 2)             # the swap can only disorder the pair above
        else:
            k -= 1
    for k in range(n - 2, -1, -1):
        _reduce_column(M, n, k, k + 1)
    return M[:, :n].T.copy(), d, M[:, n:].T.copy()


def search(L, d, zs, ncands=2, max_nodes=200000):
    """The `ncands` integer vectors nearest to `zs` in the metric of Lᵀ diag(d) L: (cands (n, m), dists (m,)),
    best first. Depth-first from the last component, conditional estimates zb[k] = zs[k] + Σ_j>k L[j,k](z[j]−zb[j])."""
    n = len(d)
    Lr = L.tolist()
    dd = d.tolist()
    zs = [float(v) for v in zs]
    zb, z, step, dist = [0.0] * n, [0.0] * n, [0.0] * n, [0.0] * n
    acc = [[0.0] * n for _ in range(n)]       # acc[k][j]: Σ_{i>k} L[i,j](z[i]−zb[i]) for j ≤ k
    cands, dists = [], []
    max_dist = math.inf
    k = n - 1
    zb[k] = zs[k]
    z[k] = float(round(zb[k]))
    y = zb[k] - z[k]
    step[k] = 1.0 if y > 0 else -1.0
    for _ in range(max_nodes):
        new_dist = dist[k] + y * y / dd[k]
        if new_dist < max_dist:
            if k > 0:
                e = z[k] - zb[k]
                row, prev, nxt = Lr[k], acc[k], acc[k - 1]
                for j in range(k):
                    nxt[j] = prev[j] + e * row[j]
                k -= 1
                dist[k] = new_dist
                zb[k] = zs[k] + nxt[k]
                z[k] = float(round(zb[k]))
                y = zb[k] - z[k]
                step[k] = 1.0 if y > 0 else -1.0
                continue
            if len(cands) < ncands:
                cands.append(list(z))
                dists.append(new_dist)
                if len(cands) == ncands:
                    max_dist = max(dists)
            else:
                worst = dists.index(max_dist)
                cands[worst], dists[worst] = list(z), new_dist
                max_dist = max(dists)
            z[0] += step[0]                   # next integer at level 0, zig-zag about zb[0]
        else:
            if k == n - 1:
                break
            k += 1
            z[k] += step[k]
        y = zb[k] - z[k]
        step[k] = -step[k] - (1.0 if step[k] > 0 else -1.0)
    else:
        raise SearchBudgetExceeded(f"{max_nodes} nodes")
    order = np.argsort(dists)
    return np.array(cands, float).T[:, order], np.array(dists)[order]


def lambda_ils(a_float, Q, ncands=2):
    """Integer least-squares of the float ambiguities `a_float` (cycles) with covariance `Q` (cycles²):
    (candidates (n, ncands) integer-valued, their squared distances), best first."""
    a_float, Q = np.asarray(a_float, float), np.asarray(Q, float)
    order = np.argsort(-np.diag(Q))           # least precise first: fewer swaps in the reduction
    L, d = ltdl(Q[np.ix_(order, order)])
    L, d, Z = reduce(L, d)
    Z = Z[np.argsort(order)]                  # rows back to the input order
    z_float = Z.T @ a_float
    shift = np.round(z_float)                 # search about the nearest integers (smaller numbers)
    cands, dists = search(L, d, z_float - shift, ncands)
    return np.round(np.linalg.solve(Z.T, cands + shift[:, None])), dists
