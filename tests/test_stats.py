"""The shared statistics of the claims (pfrepro.stats), against numbers computed by hand."""
import numpy as np
import pytest

from pfrepro import stats


def test_holm_by_hand():
    # m = 4, alpha 0.05: thresholds 0.0125, 0.0167, 0.025, 0.05 in p order
    p = [0.010, 0.040, 0.016, 0.030]
    assert list(stats.holm(p, 0.05)) == [True, False, True, False]   # 0.010 <= .0125, 0.016 <= .0167, 0.030 > .025 stops
    assert list(stats.holm([0.06, 0.001], 0.05)) == [False, True]
    assert list(stats.holm([0.02, 0.001], 0.05)) == [True, True]
    assert list(stats.holm([0.001, np.nan], 0.05)) == [True, False]
    assert list(stats.holm([0.02, 0.001], 0.01)) == [False, True]     # the level is the caller's
    assert stats.p_two_sided(2.0, 1.0) == pytest.approx(0.0455, abs=1e-4) and stats.p_two_sided(0.0, 1.0) == 1.0


def test_ratio_of_means_by_hand():
    a, b = np.array([2.0, 4.0, 6.0]), np.array([1.0, 2.0, 4.0])
    r, se = stats.ratio_of_means(a, b)
    assert r == pytest.approx(12 / 7)
    c = np.cov(a, b, ddof=1)
    var = (c[0, 0] - 2 * r * c[0, 1] + r * r * c[1, 1]) / ((7 / 3) ** 2 * 3)
    assert se == pytest.approx(np.sqrt(var))
    with pytest.raises(ValueError):
        stats.ratio_of_means(a, b[:2])


def test_bootstrap_median_is_the_median_and_reproducible():
    d = np.array([0.0, 1.0, 2.0, 10.0, 100.0])
    med, se, lo, hi = stats.bootstrap_median(d, 500, 3)
    assert med == 2.0 and se > 0 and lo <= med <= hi
    assert stats.bootstrap_median(d, 500, 3) == (med, se, lo, hi)
    # the finite-pairs median of median_paired is the bootstrap median of the finite differences
    a = np.array([1.0, np.nan, 3.0, 11.0, 101.0, 2.0])
    b = np.array([1.0, 0.0, 1.0, 1.0, 1.0, 2.0])
    assert stats.median_paired(a, b, 500, 3) == stats.bootstrap_median(np.array([0.0, 2.0, 10.0, 100.0, 0.0]), 500, 3)[:2]


def test_equivalence_and_heavy_tails():
    assert stats.equivalence(0.03, 0.007, 0.1) is True
    assert stats.equivalence(0.09, 0.01, 0.1) is None
    assert stats.equivalence(-0.2, 0.01, 0.1) is False
    assert stats.heavy_tailed([1, 1, 1, 10], 0.5) and not stats.heavy_tailed([1, 1, 1, 1], 0.5)
