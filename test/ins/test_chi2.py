"""Closed-form chi-square quantiles of the INS innovation gates (agnav_fusion.ins.chi2) against scipy.stats."""
import numpy as np
import pytest
from scipy import stats

from agnav_fusion.ins import chi2


@pytest.mark.parametrize("dof", list(range(1, 41)))
def test_ppf_and_sf_match_scipy(dof):
    for p in (0.5, 0.9, 0.95, 0.99, 0.999, 0.9999, 0.99999, 1e-3):
        assert chi2.ppf(p, dof) == pytest.approx(stats.chi2.ppf(p, dof), rel=1e-11)
    for x in np.random.default_rng(dof).uniform(0.0, 5.0 * dof, 20):
        assert chi2.sf(x, dof) == pytest.approx(stats.chi2.sf(x, dof), rel=1e-10, abs=1e-300)


def test_ppf_rejects_bad_arguments():
    for p, dof in ((0.0, 3), (1.0, 3), (0.9, 0), (0.9, 2.5)):
        with pytest.raises(ValueError):
            chi2.ppf(p, dof)
