"""Steps every particle filter of the "today's methods" family shares.

The auxiliary, regularised, Gaussian-proposal, particle-flow and jump-Markov particle filters
differ in how they propose and weight; they resample (every step, or where the effective
sample size is low) and report their results the same way, and do it here, once.
"""
from __future__ import annotations

import numpy as np

from ..rng import take_runs
from .base import FilterResult
from .particle import warn_collapse

__all__ = ["repeat_rows", "resample_runs", "particle_result"]


def repeat_rows(counts, *arrays):
    """Each array ``(runs, N, ...)`` with row i of run r repeated ``counts[r, i]`` times
    (counts sum to N in every run): the resampled arrays, ancestors in order."""
    runs, N = counts.shape
    c = counts.ravel()
    return [np.repeat(a.reshape((runs * N,) + a.shape[2:]), c, axis=0).reshape(a.shape) for a in arrays]


def resample_runs(do, w, logw, rng, counts_of, *arrays):
    """Resample, in place, the particle arrays ``(runs, N, ...)`` of the runs where ``do`` is True
    (offspring counts from ``counts_of(w[sel], rng)``) and reset their log-weights to -log N.

    The runs that resample draw from their own streams (:func:`pfrepro.rng.take_runs`; the whole
    ``rng`` when every run resamples), so run i's numbers do not depend on the other runs.
    Returns the indices of the resampled runs.
    """
    sel = np.flatnonzero(do)
    if sel.size:
        counts = counts_of(w[sel], rng if sel.size == len(do) else take_runs(rng, sel))
        for a, new in zip(arrays, repeat_rows(counts, *(a[sel] for a in arrays))):
            a[sel] = new
        logw[sel] = -np.log(w.shape[1])
    return sel


def particle_result(name, xs, log_inc, collapsed, **diagnostics) -> FilterResult:
    """The :class:`FilterResult` of a particle filter: estimates ``xs``, ``log_evidence`` (the
    sum of the per-step log increments ``log_inc``), ``collapsed``/``n_collapsed`` (warned once,
    as the bootstrap PF does) and the filter's own ``diagnostics``."""
    n_collapsed = int(collapsed.sum())
    if n_collapsed:
        warn_collapse(name, n_collapsed, *collapsed.shape)
    return FilterResult(xs, None, diagnostics={**diagnostics, "log_evidence": log_inc.sum(axis=1),
                                               "collapsed": collapsed, "n_collapsed": n_collapsed})
