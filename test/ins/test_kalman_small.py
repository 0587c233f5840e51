"""kalman.mahalanobis2 (the INS gates' y^T S^-1 y on floats up to 3x3) against np.linalg.solve."""
import numpy as np
import pytest

from agnav_fusion import kalman


@pytest.mark.parametrize("n", [1, 2, 3, 4, 6])
def test_mahalanobis2_matches_solve(n):
    rng = np.random.default_rng(n)
    for _ in range(200):
        a = rng.normal(size=(n, n))
        s = a @ a.T + np.eye(n) * 10.0 ** rng.uniform(-6, 1) + rng.normal(0, 1e-9, (n, n))   # not exactly symmetric
        y = rng.normal(size=n) * 10.0 ** rng.uniform(-3, 3)
        assert kalman.mahalanobis2(s, y) == pytest.approx(float(y @ np.linalg.solve(s, y)), rel=1e-9)


def test_mahalanobis2_singular_raises_as_solve():
    with pytest.raises(np.linalg.LinAlgError):
        kalman.mahalanobis2(np.zeros((3, 3)), np.ones(3))
