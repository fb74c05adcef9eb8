"""Steps every particle filter of the "today's methods" family shares.

The auxiliary, regularised, Gaussian-proposal, particle-flow and jump-Markov particle filters
differ in how they propose and weight; they resample (every step, or where the effective
sample size is low) and report their results the same way, and do it here, once: each is a
:class:`ParticleLoop` that supplies its proposal and weight.
"""
from __future__ import annotations

import numpy as np

from ..rng import take_runs
from .base import Filter, FilterResult
from .particle import normalize_log_weights, warn_collapse
from .resampling import resampling_counts_function

__all__ = ["repeat_rows", "resample_runs", "particle_result", "ParticleLoop"]


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
        every = sel.size == len(do)
        counts = counts_of(w[sel], rng if every else take_runs(rng, sel))
        if every:
            # every run resamples: the arrays themselves, no gather of their rows and a plain
            # copy back instead of a fancy-index scatter (the same numbers)
            for a, new in zip(arrays, repeat_rows(counts, *arrays)):
                a[...] = new
        else:
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


class ParticleLoop(Filter):
    """The time loop every particle filter of the "today's methods" family shares, written once.

    As N. Chopin's ``particles`` separates a Feynman–Kac model (what moves the particles and
    what weights them) from the SMC algorithm that runs it, a filter here supplies only its
    steps and this loop does the rest: the prior draw, the weights' normalisation (log domain),
    the estimate, the effective sample size, the resampling decision, the resampling of every
    per-particle array and the result. A speed-up or a fix of any of those lands in every
    filter at once. The steps, in the order of one time step k:

    * ``_start`` ``(y, rng, runs, N)``: the initial particles and the filter's own state
      (a dict; default: a draw from N(m0, P0) and nothing else);
    * ``_move`` ``(k, x, logw, yk, rng, state)``: propose the new particles and return
      ``(x, lw)`` with ``lw`` the log of their incremental (unnormalised) weights;
    * ``_combine`` ``(logw, lw, state)``: the log-weights to normalise (default ``logw + lw``);
    * ``_increment`` ``(log_sum, collapsed, state)``: the step's log-evidence increment and
      collapse flag from the normaliser (default: as they are);
    * ``_after_weight`` ``(k, w, x, x_hat, state)``: the filter's own per-step diagnostics;
    * ``_resample`` ``(do, w, logw, rng, x, state)``: resample the runs in ``do`` (default:
      ``resample_runs`` on ``x`` and the arrays named in ``state["carried"]``).

    Subclasses set ``n_particles``, ``resampling`` and ``ess_threshold`` (None: resample every
    step; ``resamples_after_weighting`` False: never at the end of a step, as the auxiliary
    PF, whose resampling is in its first stage) and may add diagnostics to ``state["diag"]``
    (arrays ``(runs, T, ...)`` filled by their steps). Every draw has the runs axis first and
    every array operation here treats each run on its own, so a run's numbers do not depend on
    the other runs of the batch.
    """

    needs_rng = True
    #: whether the loop resamples at the end of a step (by the ESS rule); the auxiliary PF does not
    resamples_after_weighting = True

    # -- the filter's steps (override) ---------------------------------------------------------
    def _start(self, y, rng, runs, N):
        return self.sample_prior(rng, (runs, N)), {}

    def _move(self, k, x, logw, yk, rng, state):
        raise NotImplementedError

    def _combine(self, logw, lw, state):
        return logw + lw

    def _increment(self, log_sum, collapsed, state):
        return log_sum, collapsed

    def _after_weight(self, k, w, x, x_hat, state):
        pass

    def _resample(self, do, w, logw, rng, x, state):
        resample_runs(do, w, logw, rng, self._counts_of, x, *state.get("carried", ()))
        return x

    def _result(self, xs, log_inc, collapsed, diag, state):
        return particle_result(self.name, xs, log_inc, collapsed, **diag)

    # -- the loop ------------------------------------------------------------------------------
    def filter(self, y, rng: np.random.Generator | None = None) -> FilterResult:
        y = self._prepare(y, rng)
        runs, T, _ = y.shape
        N, n = self.n_particles, self.model.dim_x
        self._counts_of = resampling_counts_function(self.resampling)
        x, state = self._start(y, rng, runs, N)
        state.setdefault("diag", {})
        state["T"] = T
        logw = np.full((runs, N), -np.log(N))
        xs = np.empty((runs, T, n))
        ess = np.empty((runs, T))
        log_inc = np.empty((runs, T))
        collapsed = np.zeros((runs, T), dtype=bool)
        resampled = np.zeros((runs, T), dtype=bool) if self.resamples_after_weighting else None
        threshold = self.ess_threshold
        with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
            for k in range(1, T + 1):
                x, lw = self._move(k, x, logw, y[:, k - 1], rng, state)
                w, log_sum, coll = normalize_log_weights(self._combine(logw, lw, state))
                log_inc[:, k - 1], collapsed[:, k - 1] = self._increment(log_sum, coll, state)
                x_hat = np.einsum("rn,rni->ri", w, x, out=xs[:, k - 1])
                self._after_weight(k, w, x, x_hat, state)
                e = np.reciprocal(np.einsum("rn,rn->r", w, w), out=ess[:, k - 1])
                logw = np.log(w)
                if resampled is None:
                    continue
                do = np.ones(runs, dtype=bool) if threshold is None else e < threshold * N
                resampled[:, k - 1] = do
                x = self._resample(do, w, logw, rng, x, state)
        diag = dict(state["diag"], ess=ess)
        if resampled is not None:
            diag["resampled"] = resampled
        return self._result(xs, log_inc, collapsed, diag, state)
