"""Bootstrap particle filter (Gordon, Salmond & Smith 1993), batched over runs and particles.

Particles are ``(runs, N, dim_x)``; log-weights ``(runs, N)``. One call runs all
Monte Carlo runs; the only Python loop is over time.
"""
from __future__ import annotations

import numpy as np

from ..validation import check_positive_int, check_probability
from ..rng import take_runs
from .base import Filter, FilterResult
from .resampling import check_scheme, resample_counts

__all__ = ["BootstrapParticleFilter", "normalize_log_weights"]


def normalize_log_weights(logw):
    """Normalised weights and log-normaliser from log-weights ``(runs, N)`` (log-sum-exp).

    Returns ``(w, log_sum, collapsed)``; a run whose log-weights are all -inf
    or NaN (weight collapse) gets uniform weights and ``collapsed = True``.
    """
    m = logw.max(axis=1, keepdims=True)
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
        runs, T, _ = y.shape
        N, n = self.n_particles, self.model.dim_x
        x = self.sample_prior(rng, (runs, N))
        logw = np.full((runs, N), -np.log(N))
        xs = np.empty((runs, T, n))
        Ps = np.empty((runs, T, n, n)) if self.return_cov else None
        ess = np.empty((runs, T))
        resampled = np.zeros((runs, T), dtype=bool)
        collapsed = np.zeros((runs, T), dtype=bool)
        log_evidence = np.zeros(runs)
        for k in range(1, T + 1):
            if not np.all(np.isfinite(x)):
                from .base import FilterDivergenceError

                raise FilterDivergenceError(f"PF particles became non-finite at step {k}")
            x = self.model.sample_transition(x, k, rng)
            # log p(y_k | y_1:k-1) ≈ log sum_i w_{k-1}^i p(y_k | x_k^i) with normalised w_{k-1}
            logw = logw + self.model.log_likelihood(y[:, k - 1], x)
            w, log_sum, coll = normalize_log_weights(logw)
            log_evidence += log_sum
            collapsed[:, k - 1] = coll
            # einsum, not w @ x: a single-run (1, 1, N) @ (1, N, n) matmul goes to a threaded
            # OpenBLAS call that stalls for milliseconds when the cores are busy
            xs[:, k - 1] = np.einsum("rn,rni->ri", w, x)
            if Ps is not None:
                d = x - xs[:, k - 1, None, :]
                Ps[:, k - 1] = np.einsum("rn,rni,rnj->rij", w, d, d)
            ess_k = 1.0 / np.sum(w * w, axis=1)
            ess[:, k - 1] = ess_k
            do = np.ones(runs, bool) if self.ess_threshold is None else ess_k < self.ess_threshold * N
            if do.all():
                # offspring counts + one repeat: no index gather over (runs, N, n)
                counts = resample_counts(w, rng, self.resampling)
                x = np.repeat(x.reshape(runs * N, n), counts.ravel(), axis=0).reshape(runs, N, n)
                logw = np.full((runs, N), -np.log(N))
            elif do.any():
                sel = np.flatnonzero(do)
                counts = resample_counts(w[sel], take_runs(rng, sel), self.resampling)
                x[sel] = np.repeat(x[sel].reshape(-1, n), counts.ravel(), axis=0).reshape(len(sel), N, n)
                with np.errstate(divide="ignore"):
                    logw = np.log(w)
                logw[sel] = -np.log(N)
            else:
                with np.errstate(divide="ignore"):
                    logw = np.log(w)
            resampled[:, k - 1] = do
        return FilterResult(xs, Ps, diagnostics={
            "ess": ess, "resampled": resampled, "log_evidence": log_evidence, "collapsed": collapsed,
            "n_collapsed": int(collapsed.sum()),
        })

    def __repr__(self) -> str:
        return (f"BootstrapParticleFilter(N={self.n_particles}, resampling={self.resampling!r}, "
                f"ess_threshold={self.ess_threshold})")
