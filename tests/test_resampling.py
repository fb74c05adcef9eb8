"""Resampling schemes: unbiasedness, variance ordering, range/shape invariants, scheme-specific bounds."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pfrepro.filters.resampling import (RESAMPLING_SCHEMES, effective_sample_size, indices_from_counts,
                                        multinomial_resample, normalize_weights, offspring_counts,
                                        residual_resample, resample, resample_counts,
                                        stratified_resample, systematic_resample)

SCHEMES = list(RESAMPLING_SCHEMES)
REPS = 20000  # repetitions, as rows of one batched call

WEIGHT_CASES = {
    "mixed": np.array([0.05, 0.3, 0.0, 0.125, 0.025, 0.2, 0.1, 0.15, 0.05, 0.0]),
    "integer-Nw": np.array([0.25, 0.125, 0.0, 0.125, 0.25, 0.0, 0.125, 0.125]),  # N w exact integers
    "skewed": np.array([0.9, 0.05, 0.02, 0.01, 0.01, 0.005, 0.003, 0.001, 0.0005, 0.0005]),
}


def counts_of(w, scheme, reps=REPS, seed=0):
    return resample_counts(np.tile(w, (reps, 1)), np.random.default_rng(seed), scheme)


def test_scheme_names():
    assert set(SCHEMES) == {"multinomial", "residual", "stratified", "systematic"}


@pytest.mark.parametrize("case", list(WEIGHT_CASES))
@pytest.mark.parametrize("scheme", SCHEMES)
def test_offspring_counts_are_unbiased(scheme, case):
    w = WEIGHT_CASES[case]
    N = w.size
    c = counts_of(w, scheme, seed=SCHEMES.index(scheme))
    assert c.shape == (REPS, N)
    np.testing.assert_array_equal(c.sum(axis=1), N)
    mean, sd = c.mean(axis=0), c.std(axis=0, ddof=1)
    target = N * w
    random = sd > 0
    # where the count is deterministic it must equal N w exactly
    np.testing.assert_allclose(mean[~random], target[~random], rtol=0, atol=1e-12)
    z = (mean[random] - target[random]) / (sd[random] / np.sqrt(REPS))
    # 8-10 particles x 12 cases: |z| < 4.5 has a family-wise false-alarm probability < 1e-3
    assert np.all(np.abs(z) < 4.5), (scheme, case, z)


def test_zero_weights_never_get_offspring():
    w = np.tile(WEIGHT_CASES["mixed"], (2000, 1))
    for i, scheme in enumerate(SCHEMES):
        c = resample_counts(w, np.random.default_rng(i), scheme)
        assert np.all(c[:, w[0] == 0] == 0), scheme


def test_variance_ordering_and_theory():
    w = WEIGHT_CASES["mixed"]
    N = w.size
    var = {s: counts_of(w, s, seed=10 + i).var(axis=0, ddof=1) for i, s in enumerate(SCHEMES)}
    # multinomial counts are Binomial(N, w): var N w (1 - w)
    np.testing.assert_allclose(var["multinomial"], N * w * (1 - w), rtol=0.06, atol=1e-12)
    # systematic counts are floor(Nw) or ceil(Nw): var frac(Nw) (1 - frac(Nw))
    frac = N * w - np.floor(N * w)
    np.testing.assert_allclose(var["systematic"], frac * (1 - frac), rtol=0.06, atol=1e-12)
    total = {s: v.sum() for s, v in var.items()}
    # measured totals: multinomial ~8.7, residual ~1.6, stratified ~1.2, systematic ~0.88
    for s in ("systematic", "stratified", "residual"):
        assert total[s] < 0.5 * total["multinomial"], total


def test_residual_deterministic_part():
    w = WEIGHT_CASES["skewed"]
    N = w.size
    c = counts_of(w, "residual", reps=5000, seed=3)
    # floor of N w as the scheme sees it (after normalisation, so 10 * 0.9 may be 8.999...)
    floor = np.floor(N * normalize_weights(w)[0]).astype(int)
    assert np.all(c >= floor)
    # the random remainder is N - sum floor(N w) draws from the residual weights
    rest = c - floor
    np.testing.assert_array_equal(rest.sum(axis=1), N - floor.sum())
    resid = N * w - floor
    np.testing.assert_allclose(rest.mean(axis=0), resid, atol=4.5 * np.sqrt(resid.sum() / 5000) + 1e-12)
    # weights with integer N w leave nothing to chance
    w_int = WEIGHT_CASES["integer-Nw"]
    np.testing.assert_array_equal(counts_of(w_int, "residual", reps=10, seed=4),
                                  np.tile(np.round(w_int.size * w_int).astype(int), (10, 1)))


def test_stratified_can_exceed_ceil_bound_systematic_cannot():
    """For w = (1/4, 1/2, 1/4), N = 3, particle 1 has N w = 1.5; stratified gives it 3 copies
    with probability 1/16, systematic only ever 1 or 2."""
    w = np.array([0.25, 0.5, 0.25])
    strat = counts_of(w, "stratified", reps=4000, seed=5)
    syst = counts_of(w, "systematic", reps=4000, seed=5)
    assert strat[:, 1].max() == 3 and set(np.unique(syst[:, 1])) == {1, 2}
    np.testing.assert_allclose(np.mean(strat[:, 1] == 3), 1 / 16, atol=0.02)


# ---------------------------------------------------------------- edge cases -----------------------
EDGE = {
    "tiny": np.full(7, 1e-300),
    "tiny-mixed": np.array([1e-300, 3e-300, 0.0, 2e-310, 1e-300]),
    "unnormalised": np.array([3.0, 1e5, 7.0, 0.0, 2.5e4]),
    "huge": np.array([1e308, 1e308, 1e307, 0.0]),   # the row sum overflows a float
    "degenerate": np.r_[1.0 - 1e-12, np.full(99, 1e-14)],
    "one-hot": np.eye(1, 50, 17)[0],
    "single": np.array([0.3]),
}


@pytest.mark.parametrize("case", list(EDGE))
@pytest.mark.parametrize("scheme", SCHEMES)
def test_edge_weights_stay_in_range(scheme, case):
    w = EDGE[case]
    N = w.size
    rng = np.random.default_rng(7)
    c = resample_counts(np.tile(w, (200, 1)), rng, scheme)
    assert c.shape == (200, N) and c.dtype.kind == "i"
    np.testing.assert_array_equal(c.sum(axis=1), N)
    assert np.all(c >= 0)
    assert np.all(c[:, w == 0] == 0)
    idx = resample(np.tile(w, (200, 1)), rng, scheme)
    assert idx.shape == (200, N) and idx.min() >= 0 and idx.max() < N
    if case in ("degenerate", "one-hot"):
        heavy = int(np.argmax(w))
        assert np.mean(c[:, heavy] == N) > 0.95  # the dominant particle takes (almost) everything
    if case in ("tiny", "huge"):  # scale invariance: same as the normalised weights
        np.testing.assert_array_equal(
            resample_counts(np.tile(w, (200, 1)), np.random.default_rng(1), scheme),
            resample_counts(np.tile(w / w.max(), (200, 1)), np.random.default_rng(1), scheme))


# ---------------------------------------------------------------- properties (hypothesis) ----------
@st.composite
def weight_vectors(draw):
    n = draw(st.integers(1, 40))
    raw = draw(st.lists(st.one_of(st.just(0.0), st.floats(1e-12, 1.0), st.floats(0.0, 1.0)),
                        min_size=n, max_size=n))
    w = np.array(raw)
    if not np.any(w > 0):
        w[draw(st.integers(0, n - 1))] = 1.0
    scale = 10.0 ** draw(st.integers(-290, 290))
    return w * scale


PROP = settings(max_examples=150, derandomize=True, database=None, deadline=None,
                suppress_health_check=[HealthCheck.too_slow])


@PROP
@given(w=weight_vectors(), scheme=st.sampled_from(SCHEMES), seed=st.integers(0, 2**32 - 1))
def test_counts_and_indices_invariants(w, scheme, seed):
    if not np.any(w > 0):  # the scale underflowed every entry: a genuine collapse
        with pytest.raises(ValueError, match="positive sum"):
            resample_counts(w, np.random.default_rng(seed), scheme)
        return
    N = w.size
    W = np.tile(w, (5, 1))
    c = resample_counts(W, np.random.default_rng(seed), scheme)
    assert c.shape == (5, N)
    assert np.all(c.sum(axis=1) == N) and np.all(c >= 0)
    assert np.all(c[:, w == 0] == 0)
    idx = indices_from_counts(c)
    assert idx.shape == (5, N) and idx.min() >= 0 and idx.max() < N
    assert np.all(np.diff(idx, axis=1) >= 0)  # sorted by ancestor
    np.testing.assert_array_equal(offspring_counts(idx, N), c)
    Nw = N * normalize_weights(W)
    eps = 1e-9 * N  # cumulative-sum round-off
    if scheme == "systematic":
        assert np.all((c >= np.floor(Nw - eps)) & (c <= np.ceil(Nw + eps)))
    elif scheme == "stratified":
        assert np.all((c >= np.floor(Nw - eps) - 1) & (c <= np.ceil(Nw + eps) + 1))
    elif scheme == "residual":
        assert np.all(c >= np.floor(Nw - eps))


@PROP
@given(w=weight_vectors())
def test_normalize_weights_and_ess(w):
    if not np.any(w > 0):
        return
    nw = normalize_weights(w)
    assert nw.shape == (1, w.size) and np.all(np.isfinite(nw))
    np.testing.assert_allclose(nw.sum(), 1.0, rtol=1e-12)
    ess = effective_sample_size(w)
    assert 1.0 - 1e-9 <= ess[0] <= w.size * (1 + 1e-9)


def test_ess_values():
    np.testing.assert_allclose(effective_sample_size(np.ones((2, 8))), [8.0, 8.0])
    np.testing.assert_allclose(effective_sample_size([0.0, 5.0, 0.0]), [1.0])
    np.testing.assert_allclose(effective_sample_size([1.0, 1.0, 2.0]), [1 / (2 * 0.25**2 + 0.5**2)])


def test_named_wrappers_equal_resample():
    w = np.tile(WEIGHT_CASES["mixed"], (3, 1))
    for fn, name in [(multinomial_resample, "multinomial"), (stratified_resample, "stratified"),
                     (systematic_resample, "systematic"), (residual_resample, "residual")]:
        np.testing.assert_array_equal(fn(w, np.random.default_rng(0)),
                                      resample(w, np.random.default_rng(0), name))


def test_invalid_weights_and_scheme():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="unknown resampling scheme 'fancy'"):
        resample_counts([0.5, 0.5], rng, "fancy")
    with pytest.raises(ValueError, match="finite and non-negative"):
        resample_counts([0.5, np.nan], rng)
    with pytest.raises(ValueError, match="finite and non-negative"):
        resample_counts([0.5, -0.1, 0.6], rng)
    with pytest.raises(ValueError, match="finite and non-negative"):
        resample_counts([0.5, np.inf], rng)
    with pytest.raises(ValueError, match="positive sum"):
        resample_counts([[0.5, 0.5], [0.0, 0.0]], rng)
    with pytest.raises(ValueError, match="shape"):
        resample_counts(np.ones((2, 2, 2)), rng)
    with pytest.raises(ValueError, match="shape"):
        resample_counts(np.ones((3, 0)), rng)


class _FixedUniforms:
    """An rng stand-in whose ``random`` returns given uniforms (to pin the inverse-CDF map)."""

    def __init__(self, u):
        self.u = np.array(u, dtype=float)

    def random(self, size):
        assert tuple(size) == self.u.shape
        return self.u.copy()


def test_multinomial_counts_are_the_inverse_cdf_of_the_uniforms_including_ties():
    """Particle i receives the uniforms in [C_{i-1}, C_i): a uniform equal to C_i goes to i + 1,
    zero-weight particles get nothing, and the counts equal bincount(searchsorted(C, u, 'right'))."""
    from pfrepro.filters.resampling import resampling_counts_function

    counts_of = resampling_counts_function("multinomial")
    w = np.array([[0.25, 0.0, 0.25, 0.5], [0.5, 0.25, 0.25, 0.0]])
    u = np.array([[0.25, 0.0, 0.49, 0.75], [0.5, 0.75, 0.1, 0.99]])   # ties with C at 0.25, 0.5, 0.75
    got = counts_of(w, _FixedUniforms(u))
    np.testing.assert_array_equal(got, [[1, 0, 2, 1], [1, 1, 2, 0]])
    rng = np.random.default_rng(3)
    w = rng.random((5, 50)) ** 4
    w /= w.sum(axis=1, keepdims=True)
    u = rng.random((5, 50))
    c = np.cumsum(w, axis=1)
    c /= c[:, -1:]
    c[:, -1] = 1.0
    want = np.array([np.bincount(np.minimum(np.searchsorted(c[r], u[r], side="right"), 49), minlength=50)
                     for r in range(5)])
    np.testing.assert_array_equal(counts_of(w, _FixedUniforms(u)), want)
