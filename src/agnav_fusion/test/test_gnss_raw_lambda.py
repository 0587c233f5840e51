"""numpy LAMBDA (gnss_raw.lambda_search) against cssrlib's mlambda and brute force: the same two best integer
vectors and squared distances; the decorrelation is unimodular and preserves the quadratic form."""
import itertools

import numpy as np
import pytest
from cssrlib.mlambda import mlambda

from agnav_fusion.gnss_raw.lambda_search import SearchBudgetExceeded, lambda_ils, ltdl, reduce, search


def _problem(rng, n):
    A, G = rng.normal(size=(n, n)), rng.normal(size=(3, n)) * 5       # noise + a strong 3-D (position) part
    return rng.normal(size=n) * 20, A @ A.T * 0.01 + G.T @ G + np.eye(n) * 1e-3


def test_ltdl_and_reduction_preserve_q():
    rng = np.random.default_rng(3)
    _, Q = _problem(rng, 12)
    L, d = ltdl(Q)
    assert np.allclose(L.T @ np.diag(d) @ L, Q) and np.allclose(np.diag(L), 1.0)
    L2, d2, Z = reduce(L.copy(), d.copy())
    assert np.allclose(Z, np.round(Z)) and abs(abs(np.linalg.det(Z)) - 1.0) < 1e-6
    assert np.allclose(Z.T @ Q @ Z, L2.T @ np.diag(d2) @ L2)
    assert np.abs(np.tril(L2, -1)).max() <= 0.5 + 1e-9                  # size-reduced
    assert np.prod(d2) == pytest.approx(np.prod(d))                     # same volume


def test_matches_mlambda_on_random_problems():
    rng = np.random.default_rng(7)
    for _ in range(40):
        a, Q = _problem(rng, int(rng.integers(4, 14)))
        mine, s_mine = lambda_ils(a, Q, ncands=2)
        ref, s_ref, _, _ = mlambda(a, Q, 2)
        assert np.array_equal(mine, ref) and np.allclose(s_mine, s_ref, rtol=1e-9)


def test_matches_brute_force():
    rng = np.random.default_rng(11)
    a, Q = _problem(rng, 4)
    Qi = np.linalg.inv(Q)
    base = np.round(a)
    best = sorted((float((a - z) @ Qi @ (a - z)), tuple(z)) for z in
                  (base + np.array(o) for o in itertools.product(range(-6, 7), repeat=4)))
    cands, s = lambda_ils(a, Q, ncands=3)
    assert [tuple(c) for c in cands.T] == [b[1] for b in best[:3]]
    assert np.allclose(s, [b[0] for b in best[:3]])


def test_search_budget_is_reported():
    rng = np.random.default_rng(5)
    _, Q = _problem(rng, 30)
    L, d = ltdl(Q * 1e4)                     # huge float uncertainty, not decorrelated: many nodes
    with pytest.raises(SearchBudgetExceeded):
        search(L, d, rng.normal(size=30) * 50, ncands=2, max_nodes=50)
