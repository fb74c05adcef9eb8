"""Resampling schemes, batched over runs (Douc et al. 2005; Hol et al. 2006).

Every scheme takes weights ``(runs, N)`` (non-negative, need not be normalised)
and produces offspring counts ``(runs, N)`` summing to N in every row; ancestor
indices follow from the counts. Stratified and systematic resampling are
computed in O(N) without any search: with cumulative weights C_i and points
u_j = (j + U_j)/N, the number of points below c is

    floor(Nc) + [U_floor(Nc) < frac(Nc)]   (stratified; U_j iid uniform)
    ceil(Nc - U)                           (systematic; U_j = U for all j),

so the counts are differences of a closed form. Resampled particles then come
from one ``np.repeat``, already sorted by ancestor (cache-friendly).
"""
from __future__ import annotations

import numpy as np

from ..rng import check_rng, run_stream

__all__ = ["resample", "resample_counts", "check_scheme", "multinomial_resample", "stratified_resample",
           "systematic_resample", "residual_resample", "offspring_counts", "effective_sample_size",
           "normalize_weights", "indices_from_counts", "resampling_counts_function", "RESAMPLING_SCHEMES"]


def normalize_weights(weights) -> np.ndarray:
    """Return weights ``(runs, N)`` divided by their row sums; validates them."""
    w = np.asarray(weights, dtype=float)
    if w.ndim == 1:
        w = w[None]
    if w.ndim != 2 or w.shape[1] < 1:
        raise ValueError(f"weights must have shape (runs, N) with N >= 1, got {w.shape}")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ValueError("weights must be finite and non-negative")
    with np.errstate(over="ignore"):
        s = w.sum(axis=1, keepdims=True)
    if np.any(s <= 0):
        raise ValueError("every row of weights needs a positive sum (all-zero weights: weight collapse)")
    if not np.all(np.isfinite(s)):  # huge finite weights whose sum overflows: rescale first
        w = w / w.max(axis=1, keepdims=True)
        s = w.sum(axis=1, keepdims=True)
    return w / s


def _scaled_cumulative(w):
    """N * C_i with the last entry exactly N (so every row closes)."""
    N = w.shape[1]
    c = w.cumsum(axis=1)
    c *= N / c[:, -1:]
    c[:, -1] = N
    return c


def _diff_rows(below):
    counts = np.empty(below.shape, dtype=np.intp)
    counts[:, 0] = below[:, 0]
    np.subtract(below[:, 1:], below[:, :-1], out=counts[:, 1:])
    return counts


def _systematic_counts(w, rng):
    Nc = _scaled_cumulative(w)
    Nc -= rng.random((w.shape[0], 1))
    np.ceil(Nc, out=Nc)   # N C_i >= 0 and U < 1, so ceil(N C_i - U) >= 0: no clipping needed
    return _diff_rows(Nc.astype(np.intp))


def _stratified_counts(w, rng):
    Nc = _scaled_cumulative(w)
    N = w.shape[1]
    U = rng.random(w.shape)
    m = np.floor(Nc)
    mi = np.minimum(m, N - 1).astype(np.intp)
    below = m.astype(np.intp) + (np.take_along_axis(U, mi, axis=1) < Nc - m)
    below[:, -1] = N
    return _diff_rows(below)


def _multinomial_counts(w, rng):
    runs, N = w.shape
    c = np.cumsum(w, axis=1)
    c /= c[:, -1:]
    c[:, -1] = 1.0
    u = rng.random((runs, N))
    # particle i gets the uniforms in [c_{i-1}, c_i): with the uniforms sorted, the count of
    # those below each c_i is one searchsorted of the (increasing) c_i into them -- the
    # same counts as bincount(searchsorted(c, u, "right")), without the scattered lookups
    u.sort(axis=1)
    below = np.empty((runs, N), dtype=np.intp)
    for r in range(runs):
        below[r] = np.searchsorted(u[r], c[r], side="left")
    below[:, -1] = N          # c_N = 1 > every uniform
    return _diff_rows(below)


def _residual_counts(w, rng):
    runs, N = w.shape
    Nw = N * w
    counts = np.floor(Nw).astype(np.intp)
    rest = N - counts.sum(axis=1)
    rows = np.flatnonzero(rest > 0)
    if not len(rows):
        return counts
    # the residual distributions of all drawing runs at once: a row's cumsum is a sequential
    # accumulate (the same sums as the 1-D cumsum of that row), divided by its last entry
    c = np.cumsum((Nw - counts)[rows], axis=1)
    c /= c[:, -1:]
    c[:, -1] = 1.0
    # each run's uniforms from its own stream, in run order; searched sorted (the counts do not
    # depend on the order of the draws, and sorted keys search several times faster: each search
    # starts where the last one ended); one bincount over all runs
    draws = np.empty(int(rest[rows].sum()), dtype=np.intp)
    start = 0
    for j, r in enumerate(rows.tolist()):
        stop = start + int(rest[r])
        u = run_stream(rng, r).random(stop - start)
        u.sort()
        draws[start:stop] = np.searchsorted(c[j], u, side="right")
        start = stop
    np.minimum(draws, N - 1, out=draws)
    draws += np.repeat(rows * N, rest[rows])
    counts += np.bincount(draws, minlength=runs * N).reshape(runs, N)
    return counts


_COUNTS = {
    "multinomial": _multinomial_counts,
    "stratified": _stratified_counts,
    "systematic": _systematic_counts,
    "residual": _residual_counts,
}

#: names of the available schemes
RESAMPLING_SCHEMES = tuple(sorted(_COUNTS))


def check_scheme(scheme: str) -> str:
    """Return ``scheme`` if it names a resampling scheme, else raise ``ValueError``."""
    if scheme not in _COUNTS:
        raise ValueError(f"unknown resampling scheme {scheme!r}; choose from {list(RESAMPLING_SCHEMES)}")
    return scheme


def resampling_counts_function(scheme: str):
    """The counts function ``f(w, rng)`` of the named scheme, for a filter's inner loop: ``w``
    must already be normalised, finite and non-negative (no validation is repeated per step)."""
    return _COUNTS[check_scheme(scheme)]


def resample_counts(weights, rng: np.random.Generator, scheme: str = "systematic") -> np.ndarray:
    """Offspring counts ``(runs, N)`` (each row sums to N) by the named scheme.

    ``rng`` must be a ``numpy.random.Generator`` or ``pfrepro.rng.RunStreams``
    (``TypeError`` otherwise: no implicit seed, no global state).
    """
    check_rng(rng)
    return _COUNTS[check_scheme(scheme)](normalize_weights(weights), rng)


def indices_from_counts(counts) -> np.ndarray:
    """Ancestor indices ``(runs, N)``, sorted within each run, from offspring counts."""
    counts = np.atleast_2d(counts)
    runs, N = counts.shape
    return np.repeat(np.tile(np.arange(N), runs), counts.ravel()).reshape(runs, -1)


def resample(weights, rng: np.random.Generator, scheme: str = "systematic") -> np.ndarray:
    """Ancestor indices ``(runs, N)`` by the named scheme."""
    return indices_from_counts(resample_counts(weights, rng, scheme))


def multinomial_resample(weights, rng):
    """N independent draws from the weights (the textbook scheme, highest variance)."""
    return resample(weights, rng, "multinomial")


def stratified_resample(weights, rng):
    """One uniform draw in each stratum [j/N, (j+1)/N)."""
    return resample(weights, rng, "stratified")


def systematic_resample(weights, rng):
    """One uniform draw shared by all strata: u_j = (j + U)/N."""
    return resample(weights, rng, "systematic")


def residual_resample(weights, rng):
    """floor(N w_i) copies of each particle; the remaining N - sum floor(N w) drawn multinomially."""
    return resample(weights, rng, "residual")


def offspring_counts(indices, N: int) -> np.ndarray:
    """Number of copies of each particle, ``(runs, N)``, from ancestor indices."""
    indices = np.atleast_2d(indices)
    runs = indices.shape[0]
    flat = indices + N * np.arange(runs)[:, None]
    return np.bincount(flat.ravel(), minlength=runs * N).reshape(runs, N)


def effective_sample_size(weights) -> np.ndarray:
    """ESS = 1 / sum w_i^2 of normalised weights, per run."""
    w = normalize_weights(weights)
    return 1.0 / np.sum(w * w, axis=1)
