"""Bootstrap particle filter (Gordon, Salmond & Smith 1993), batched over runs and particles.

Particles are ``(runs, N, dim_x)``; log-weights ``(runs, N)``. One call runs all
Monte Carlo runs; the only Python loop is over time.
"""
from __future__ import annotations

import warnings

import numpy as np

from ..validation import check_positive_int, check_probability
from ..rng import RunStreams, take_runs
from .base import Filter, FilterResult
from .resampling import check_scheme, resampling_counts_function

__all__ = ["BootstrapParticleFilter", "normalize_log_weights", "WeightCollapseWarning", "warn_collapse",
           "BLOCK_PARTICLES"]

#: the most particles (runs x N) one batched step moves at once — a larger batch drawing from
#: per-run streams is filtered in blocks of whole runs, so that a step's arrays (a few MB) stay in
#: cache -- at N = 10^5 ten runs in one block ran 8 % slower per run than one run alone. The
#: blocks change no number (each run draws from its own stream).
BLOCK_PARTICLES = 1 << 17


def normalize_log_weights(logw):
    """Normalised weights and log-normaliser from log-weights ``(runs, N)`` (log-sum-exp).

    Returns ``(w, log_sum, collapsed)``; a run whose log-weights are all -inf
    or NaN (weight collapse) gets uniform weights and ``collapsed = True``.
    A ``+inf`` log-weight is an error (no density is infinite), as is any shape but 2-D.
    """
    if type(logw) is not np.ndarray or logw.ndim != 2:
        logw = np.asarray(logw, dtype=float)
        if logw.ndim != 2:
            raise ValueError(f"logw must be a 2-D array (runs, N) of log-weights, got shape {logw.shape}")
    m = logw.max(axis=1, keepdims=True)
    if np.any(m == np.inf):
        raise ValueError(f"logw contains +inf log-weights (runs {np.flatnonzero(m[:, 0] == np.inf)[:10].tolist()}); "
                         "a likelihood cannot be infinite")
    if np.isnan(m).any():  # max propagates NaN: only then pay for a pass that removes them
        logw = np.where(np.isnan(logw), -np.inf, logw)
        m = logw.max(axis=1, keepdims=True)
    collapsed = ~np.isfinite(m[:, 0])
    if collapsed.any():
        logw = logw.copy()
        logw[collapsed] = 0.0
        m = np.where(collapsed[:, None], 0.0, m)
    w = logw - m
    np.exp(w, out=w)
    s = w.sum(axis=1, keepdims=True)
    w /= s
    log_sum = (m + np.log(s))[:, 0]
    log_sum[collapsed] = -np.inf
    return w, log_sum, collapsed


def _normalize_into(logw, w):
    """Normalise log-weights ``logw`` (runs, N) into ``w`` (in place); return log sum exp per run.

    The fast path (every run has a finite maximum) is five NumPy calls; a run whose
    log-weights are all -inf or NaN (weight collapse) gets uniform weights and
    log-sum -inf, NaN log-weights count as -inf, as in :func:`normalize_log_weights`.
    """
    m = logw.max(axis=1)
    if not np.isfinite(m).all():
        wn, log_sum, _ = normalize_log_weights(logw)
        w[...] = wn
        return log_sum
    np.subtract(logw, m[:, None], out=w)
    np.exp(w, out=w)
    s = w.sum(axis=1)
    w /= s[:, None]
    return m + np.log(s)


def warn_collapse(name: str, n_collapsed: int, runs: int, T: int) -> None:
    """One warning per filter call: how many (run, step) pairs had every weight underflow."""
    warnings.warn(
        f"{name}: weight collapse in {n_collapsed} of {runs * T} run-steps (every particle's likelihood "
        "underflowed; weights reset to uniform there). See diagnostics['collapsed'].",
        WeightCollapseWarning, stacklevel=3)


class WeightCollapseWarning(RuntimeWarning):
    """Every particle weight of a run underflowed at some step (recorded in ``diagnostics``)."""


class BootstrapParticleFilter(Filter):
    """Bootstrap particle filter: sequential importance resampling with the transition prior as proposal.

    Gordon, Salmond & Smith (1993); Li et al. 2012, sec 1.3.2 and eqs 12-16 (proposal
    q = p(x_k | x_{k-1}), eq 15, so the weight is w_k^i ∝ w_{k-1}^i p(y_k | x_k^i),
    eq 16); the PF of Zhang et al. 2016 (sec 5) and Ning et al. 2011 (eqs 3, 4).
    For k = 1..T: propagate x_k^i ~ p(x_k | x_{k-1}^i); weight in the log domain;
    estimate E[x_k | y_1:k] by the weighted mean (before resampling); resample when
    ESS < ``ess_threshold`` * N (``ess_threshold=None``: every step, as the papers'
    algorithms do).

    Parameters
    ----------
    model : StateSpaceModel
        Any model that can draw transitions and evaluate p(y | x), including models
        with non-additive measurement noise.
    n_particles : int
        N >= 1.
    resampling : str
        "systematic" (default), "stratified", "multinomial" or "residual".
    ess_threshold : float or None
        None (resample every step) or a fraction in [0, 1].
    return_cov : bool
        Also return the weighted covariance of the particles.
    m0, P0 : array_like, optional
        Override the model's initial distribution N(m0, P0).

    Model methods
    -------------
    ``sample_transition``, ``log_likelihood``, ``m0``, ``P0``.

    Notes
    -----
    A batch of more than ``BLOCK_PARTICLES`` particles (runs x N) drawing from per-run
    streams (:class:`pfrepro.rng.RunStreams`) is filtered in blocks of whole runs, which keeps
    each step's arrays in cache and changes no number.
    Diagnostics: ``ess`` (runs, T) before resampling, ``resampled`` (runs, T),
    ``log_evidence`` (runs,) — the estimate of log p(y_1:T) — and
    ``collapsed`` (runs, T): steps where every weight underflowed.
    """

    name = "PF"
    needs_rng = True

    def __init__(self, model, n_particles: int, resampling: str = "systematic",
                 ess_threshold: float | None = None, return_cov: bool = False, m0=None, P0=None):
        super().__init__(model, m0, P0)
        self.n_particles = check_positive_int(n_particles, "n_particles")
        self.resampling = check_scheme(resampling)
        self.ess_threshold = None if ess_threshold is None else check_probability(ess_threshold, "ess_threshold")
        self.return_cov = bool(return_cov)

    def filter(self, y, rng: np.random.Generator | None = None) -> FilterResult:
        y = self._prepare(y, rng)
        runs = y.shape[0]
        per_block = max(1, BLOCK_PARTICLES // self.n_particles)
        if runs <= per_block or not isinstance(rng, RunStreams):
            # one shared Generator: blocks would change the draws, so one batched call
            return self._filter_runs(y, rng)
        from ..montecarlo import _concat

        parts = [self._filter_runs(y[s:s + per_block], rng.subset(np.arange(s, min(s + per_block, runs))),
                                   warn=False, first_run=s) for s in range(0, runs, per_block)]
        res = _concat(parts)
        if res.diagnostics["n_collapsed"]:
            warn_collapse(self.name, res.diagnostics["n_collapsed"], runs, y.shape[1])
        return res

    def _filter_runs(self, y, rng, warn: bool = True, first_run: int = 0) -> FilterResult:
        """The filter on the runs of ``y`` in one batched call (``warn``: report weight collapse;
        ``first_run``: the number of run 0 of this block, for error messages)."""
        runs, T, _ = y.shape
        N, n = self.n_particles, self.model.dim_x
        model, scheme, log_n = self.model, self.resampling, np.log(N)
        every_step = self.ess_threshold is None
        counts_of = resampling_counts_function(scheme)
        x = self.sample_prior(rng, (runs, N))
        # None: uniform weights 1/N, used when every run resamples at every step
        logw = None if every_step else np.full((runs, N), -log_n)
        xs = np.empty((runs, T, n))
        Ps = np.empty((runs, T, n, n)) if self.return_cov else None
        ess = np.empty((runs, T))
        resampled = np.ones((runs, T), dtype=bool) if every_step else np.zeros((runs, T), dtype=bool)
        log_sums = np.empty((runs, T))
        w = np.empty((runs, N))          # normalised weights, reused every step
        # Overflow/underflow of a likelihood far out in the tails is expected and handled
        # (log domain; a run whose weights all vanish is a recorded collapse, reported once
        # below): numpy's RuntimeWarnings about it are silenced here, at the source.
        with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
            for k in range(1, T + 1):
                x = model.sample_transition(x, k, rng)
                # log p(y_k | y_1:k-1) ≈ log sum_i w_{k-1}^i p(y_k | x_k^i) with normalised w_{k-1};
                # after resampling w_{k-1} = 1/N, so the weights are the likelihoods themselves
                ll = model.log_likelihood(y[:, k - 1], x)
                if logw is not None:
                    ll += logw
                    log_sums[:, k - 1] = _normalize_into(ll, w)
                else:
                    log_sums[:, k - 1] = _normalize_into(ll, w) - log_n
                # einsum, not w @ x: a single-run (1, 1, N) @ (1, N, n) matmul goes to a threaded
                # OpenBLAS call that stalls for milliseconds when the cores are busy
                xk = np.einsum("rn,rni->ri", w, x, out=xs[:, k - 1])
                if Ps is not None:
                    d = x - xk[:, None, :]
                    Ps[:, k - 1] = np.einsum("rn,rni,rnj->rij", w, d, d)
                ess_k = np.reciprocal(np.einsum("rn,rn->r", w, w), out=ess[:, k - 1])
                if every_step:
                    # offspring counts + one repeat: no index gather over (runs, N, n)
                    counts = counts_of(w, rng)
                    x = np.repeat(x.reshape(runs * N, n), counts.ravel(), axis=0).reshape(runs, N, n)
                    continue
                do = ess_k < self.ess_threshold * N
                resampled[:, k - 1] = do
                # explicit log-weights in this mode, even when every run resamples: a run's
                # arithmetic must not depend on what the other runs of the batch do (rng rule 3)
                logw = np.log(w)
                if do.all():
                    counts = counts_of(w, rng)
                    x = np.repeat(x.reshape(runs * N, n), counts.ravel(), axis=0).reshape(runs, N, n)
                    logw.fill(-log_n)
                    continue
                if do.any():
                    sel = np.flatnonzero(do)
                    counts = counts_of(w[sel], take_runs(rng, sel))
                    x[sel] = np.repeat(x[sel].reshape(-1, n), counts.ravel(), axis=0).reshape(len(sel), N, n)
                    logw[sel] = -log_n
        # diagnostics from the stored per-step quantities, after the loop
        collapsed = np.isneginf(log_sums)    # every weight underflowed (log-sum -inf)
        bad = ~np.isfinite(xs).all(axis=2)
        if bad.any():
            from .base import FilterDivergenceError

            k_bad = int(np.flatnonzero(bad.any(axis=0))[0]) + 1
            raise FilterDivergenceError(f"PF particles became non-finite at step {k_bad} "
                                        f"in runs {(first_run + np.flatnonzero(bad[:, k_bad - 1]))[:10].tolist()}")
        n_collapsed = int(collapsed.sum())
        if n_collapsed and warn:
            warn_collapse(self.name, n_collapsed, runs, T)
        log_evidence = log_sums.sum(axis=1)
        return FilterResult(xs, Ps, diagnostics={
            "ess": ess, "resampled": resampled, "log_evidence": log_evidence, "collapsed": collapsed,
            "n_collapsed": n_collapsed,
        })

    def __repr__(self) -> str:
        return (f"BootstrapParticleFilter(N={self.n_particles}, resampling={self.resampling!r}, "
                f"ess_threshold={self.ess_threshold})")
