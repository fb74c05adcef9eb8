"""Residual resampling: the vectorised counts are those of the per-run loop, draw for draw."""
import numpy as np
import pytest

from pfrepro.filters import BootstrapParticleFilter
from pfrepro.filters import resampling as R
from pfrepro.models import UNGM
from pfrepro.rng import RunStreams, run_stream


def residual_counts_reference(w, rng):
    """The residual scheme as first written (a loop over runs): the tests' reference."""
    runs, N = w.shape
    counts = np.floor(N * w).astype(np.intp)
    rest = N - counts.sum(axis=1)
    resid = N * w - counts
    for r in np.flatnonzero(rest > 0):
        c = np.cumsum(resid[r])
        c /= c[-1]
        c[-1] = 1.0
        draws = np.minimum(np.searchsorted(c, run_stream(rng, r).random(rest[r]), side="right"), N - 1)
        counts[r] += np.bincount(draws, minlength=N)
    return counts


def _weights(rng, runs, N, kind):
    w = rng.random((runs, N)) ** rng.integers(1, 8)
    if kind == "zeros":
        w[:, : N // 2] = 0.0
    elif kind == "uniform":
        w = np.ones((runs, N))                 # N w integer: nothing left to draw
    elif kind == "one":
        w = np.zeros((runs, N))
        w[:, -1] = 1.0
    return w / w.sum(axis=1, keepdims=True)


@pytest.mark.parametrize("kind", ["random", "zeros", "uniform", "one"])
@pytest.mark.parametrize("streams", [True, False])
def test_residual_counts_equal_the_per_run_loop(kind, streams):
    gen = np.random.default_rng(0)
    for trial in range(40):
        runs, N = int(gen.integers(1, 9)), int(gen.integers(1, 80))
        w = _weights(gen, runs, N, kind)
        make = (lambda: RunStreams.from_entropy(trial, runs)) if streams else (lambda: np.random.default_rng(trial))
        a, b = make(), make()
        got, want = R._residual_counts(w, a), residual_counts_reference(w, b)
        assert np.array_equal(got, want) and got.dtype == want.dtype
        assert np.all(got.sum(axis=1) == N)
        assert np.array_equal(a.random((runs, 2)), b.random((runs, 2)))   # the same draws consumed


def test_residual_pf_bit_identical(monkeypatch):
    m = UNGM.zhang2016()
    sim = m.simulate(30, 5, np.random.default_rng(1))
    new = BootstrapParticleFilter(m, 300, resampling="residual").filter(sim.y, RunStreams.from_entropy(2, 5))
    monkeypatch.setitem(R._COUNTS, "residual", residual_counts_reference)
    ref = BootstrapParticleFilter(m, 300, resampling="residual").filter(sim.y, RunStreams.from_entropy(2, 5))
    assert new.x.tobytes() == ref.x.tobytes()
    assert new.diagnostics["log_evidence"].tobytes() == ref.diagnostics["log_evidence"].tobytes()
