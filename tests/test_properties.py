"""Property-based tests (hypothesis) over covariances and measurement shapes."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pfrepro.filters.sigma_points import safe_cholesky
from pfrepro.noise import GaussianNoise
from pfrepro.validation import as_covariance, as_measurements

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@st.composite
def factor(draw, max_n=5):
    """(n, rank, A) with A an n x rank matrix of moderate, well-scaled entries."""
    n = draw(st.integers(1, max_n))
    rank = draw(st.integers(0, n))
    seed = draw(st.integers(0, 2**32 - 1))
    scale = draw(st.sampled_from([1e-3, 1.0, 1e3]))
    A = np.random.default_rng(seed).standard_normal((n, rank)) * scale
    return n, rank, A


@SETTINGS
@given(factor())
def test_psd_of_any_rank_is_accepted_as_singular_and_sampled_in_its_range(f):
    n, rank, A = f
    C = A @ A.T
    out = as_covariance(C, "Q", n, allow_singular=True)
    np.testing.assert_allclose(out, C, rtol=0, atol=1e-12 * max(1.0, np.abs(C).max()))
    noise = GaussianNoise(C, allow_singular=True)
    assert noise.is_singular == (rank < n)
    w = noise.sample(np.random.default_rng(0), (64,))
    if rank == 0:
        assert not np.any(w)
    else:
        # component orthogonal to the column space of A is numerically zero
        Qb, _ = np.linalg.qr(A)
        off = w - (w @ Qb) @ Qb.T
        assert np.max(np.abs(off)) <= 1e-6 * np.sqrt(np.abs(C).max())
    if rank < n:
        with pytest.raises(ValueError, match="not positive definite"):
            as_covariance(C, "Q", n)
        with pytest.raises(ValueError, match="singular"):
            noise.logpdf(np.zeros(n))


@SETTINGS
@given(factor(), st.floats(0.1, 10.0))
def test_pd_is_accepted_everywhere(f, floor):
    n, _, A = f
    scale = max(1.0, np.abs(A @ A.T).max(initial=0.0))
    C = A @ A.T + floor * scale * np.eye(n)
    as_covariance(C, "P0", n)
    noise = GaussianNoise(C)
    assert not noise.is_singular
    L = safe_cholesky(C)
    np.testing.assert_allclose(L @ L.T, C, rtol=1e-10, atol=1e-10 * scale)


@SETTINGS
@given(st.integers(2, 5), st.integers(0, 2**32 - 1), st.floats(1e-6, 1.0))
def test_non_symmetric_is_refused(n, seed, asym):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    C = A @ A.T + np.eye(n)
    i, j = rng.choice(n, 2, replace=False)
    C[i, j] += asym * np.abs(C).max()
    for allow in (False, True):
        with pytest.raises(ValueError, match="not symmetric"):
            as_covariance(C, "R", n, allow_singular=allow)


@SETTINGS
@given(st.integers(1, 5), st.integers(0, 2**32 - 1), st.floats(1e-6, 10.0))
def test_indefinite_is_refused(n, seed, neg):
    rng = np.random.default_rng(seed)
    V, _ = np.linalg.qr(rng.standard_normal((n, n)))
    lam = rng.uniform(0.5, 2.0, n)
    lam[rng.integers(n)] = -neg
    C = (V * lam) @ V.T
    C = 0.5 * (C + C.T)
    for allow in (False, True):
        with pytest.raises(ValueError, match="not positive"):
            as_covariance(C, "R", n, allow_singular=allow)
    if neg > 1e-5 * np.abs(np.diag(C)).max():   # beyond what safe_cholesky's jitter (<= 1e-6) rescues
        with pytest.raises(np.linalg.LinAlgError, match="not positive semi-definite"):
            safe_cholesky(C)


@SETTINGS
@given(st.integers(1, 4), st.integers(1, 4), st.integers(1, 6))
def test_valid_measurement_shapes_are_accepted(dim_y, runs, T):
    y = np.random.default_rng(runs * 100 + T).standard_normal((runs, T, dim_y))
    np.testing.assert_array_equal(as_measurements(y, dim_y), y)
    np.testing.assert_array_equal(as_measurements(y[0], dim_y) if dim_y > 1 else as_measurements(y[0, :, 0], 1),
                                  y[:1])


@SETTINGS
@given(st.integers(1, 4), st.lists(st.integers(0, 6), min_size=0, max_size=4))
def test_measurement_shapes_outside_the_rule_are_refused(dim_y, shape):
    shape = tuple(shape)
    valid = ((len(shape) == 3 and shape[0] >= 1 and shape[1] >= 1 and shape[2] == dim_y)
             or (len(shape) == 1 and dim_y == 1 and shape[0] >= 1)
             or (len(shape) == 2 and dim_y > 1 and shape[0] >= 1 and shape[1] == dim_y))
    y = np.zeros(shape)
    if valid:
        out = as_measurements(y, dim_y)
        assert out.ndim == 3 and out.shape[2] == dim_y and out.size == y.size
    else:
        with pytest.raises(ValueError, match="y "):
            as_measurements(y, dim_y)


@SETTINGS
@given(st.integers(1, 3), st.integers(1, 3), st.integers(1, 5), st.sampled_from([np.nan, np.inf, -np.inf]))
def test_non_finite_measurements_are_refused_with_their_position(dim_y, runs, T, bad):
    y = np.zeros((runs, T, dim_y))
    y[runs - 1, T - 1, 0] = bad
    with pytest.raises(ValueError, match=f"first at run {runs - 1}, step {T - 1}"):
        as_measurements(y, dim_y)
