"""SMC² (Chopin, Jacob & Papaspiliopoulos 2013) for a static parameter, batched over runs.

The dual PF (Hou 2008) and Liu–West (2001) move the parameter with an artificial kernel, so
their θ-posterior is not the exact one. SMC² is exact as the particle counts grow: M
θ-particles, each carrying its own bootstrap PF of N_x state particles; the θ-weights are
multiplied by each PF's unbiased estimate of the incremental likelihood
p̂(y_k | y_1:k-1, θ^m) (Chopin et al. 2013, Algorithm 1, step (b)). When the θ-weights'
ESS falls below ``ess_threshold`` · M, the θ-particles are resampled and each is moved by a
particle-marginal Metropolis–Hastings step (step (c)): a Gaussian random-walk proposal
θ' ~ N(θ^m, (c · sd_ω(θ))²) scaled by the weighted cloud's spread, a fresh PF for θ' over
y_1:k, and acceptance with probability min{1, p̂(y_1:k | θ') π(θ') / p̂(y_1:k | θ) π(θ)}
(π: the uniform prior on the model's ``bounds``). Because p̂ is unbiased this move leaves
the exact joint posterior invariant (Andrieu, Doucet & Holenstein 2010).

Arrays: state particles ``(runs, M, N_x, dim_x)``, θ ``(runs, M)``. Every draw has the runs
axis first; a rejuvenation for the runs that need it draws from their own streams
(:func:`pfrepro.rng.take_runs`), so run i is the same in any batch. Cost: the PMMH reruns
make it O(T² · M · N_x) in the worst case (``pmmh`` counts them in the diagnostics).
"""
from __future__ import annotations

import numpy as np

from ..rng import take_runs
from ..validation import as_finite_float, check_positive_int, check_probability
from .base import Filter, FilterResult
from .parameter_learning import ParameterLearningFilter
from .particle import normalize_log_weights
from .resampling import check_scheme, resampling_counts_function
from .smc_steps import repeat_rows

__all__ = ["SMC2"]


def _systematic_counts_nd(w, u):
    """Systematic offspring counts along the last axis of normalised weights ``w`` (..., N)
    with one uniform ``u`` (..., 1) per cloud: counts_i = ceil(N C_i - u) - ceil(N C_{i-1} - u)
    (as :mod:`pfrepro.filters.resampling`, for clouds that sit on more than one leading axis)."""
    N = w.shape[-1]
    c = np.cumsum(w, axis=-1)
    c *= N / c[..., -1:]
    c[..., -1] = N
    below = np.ceil(c - u).astype(np.intp)
    return np.diff(below, axis=-1, prepend=0)


class SMC2(ParameterLearningFilter):
    """SMC² for a scalar static parameter of a :class:`~pfrepro.models.parameterized.ParameterizedModel`.

    Parameters
    ----------
    model : ParameterizedModel
        With scalar θ, a uniform prior on ``model.bounds``.
    n_theta : int
        M, the θ-particles (>= 2).
    n_x : int
        N_x, the state particles of each θ-particle's PF (>= 1).
    ess_threshold : float
        Resample-and-move when ESS(θ-weights) < ess_threshold · M (default 0.5).
    rw_scale : float
        c, the random-walk scale relative to the weighted θ spread (default 1.0).
    n_moves : int
        PMMH moves per rejuvenation (default 1).
    resampling : str
        Scheme of the θ-level resampling (default ``"systematic"``); the state PFs resample
        systematically at every step.

    Notes
    -----
    Diagnostics: ``theta`` (runs, T) the posterior mean of θ, ``theta_var`` (runs, T),
    ``log_evidence`` (runs,) the estimate of log p(y_1:T), ``theta_ess`` (runs, T),
    ``rejuvenated`` (runs, T), ``acceptance`` (runs, T) the PMMH acceptance rate where a move
    took place (NaN elsewhere), ``pmmh_steps`` (runs,) PF steps spent in the moves.
    """

    name = "SMC²"
    needs_rng = True

    def __init__(self, model, n_theta: int = 200, n_x: int = 100, ess_threshold: float = 0.5,
                 rw_scale: float = 1.0, n_moves: int = 1, resampling: str = "systematic"):
        super().__init__(model)
        self.n_theta = check_positive_int(n_theta, "n_theta")
        if self.n_theta < 2:
            raise ValueError("n_theta must be >= 2 (the random walk is scaled by the θ-cloud's spread)")
        self.n_x = check_positive_int(n_x, "n_x")
        self.ess_threshold = check_probability(ess_threshold, "ess_threshold")
        self.rw_scale = as_finite_float(rw_scale, "rw_scale", positive=True)
        self.n_moves = check_positive_int(n_moves, "n_moves")
        self.resampling = check_scheme(resampling)
        self._counts = resampling_counts_function(self.resampling)

    # -- one bootstrap-PF step for every (run, θ-particle) -------------------------------------
    def _pf_step(self, x, theta, yk, k, rng):
        """Propagate, weight and resample the state clouds ``x`` (r, M, N_x, dx) under ``theta``
        (r, M); returns the new clouds and log p̂(y_k | y_1:k-1, θ) (r, M)."""
        r, M, N, dx = x.shape
        x = self.model.sample_transition(x, k, theta[..., None, None], rng)
        ll = self.model.log_likelihood(yk, x)                                # (r, M, N)
        w, log_sum, _ = normalize_log_weights(ll.reshape(r * M, N))
        counts = _systematic_counts_nd(w.reshape(r, M, N), rng.random((r, M, 1)))
        x = np.repeat(x.reshape(r * M * N, dx), counts.ravel(), axis=0).reshape(r, M, N, dx)
        return x, log_sum.reshape(r, M) - np.log(N)

    def _run_pf(self, theta, y, rng):
        """A fresh PF per (run, θ) over all of ``y`` (r, k, dy): final clouds and log p̂(y_1:k | θ)."""
        r, M = theta.shape
        x = self.model.sample_initial(rng, (r, M, self.n_x))
        total = np.zeros((r, M))
        for j in range(y.shape[1]):
            x, inc = self._pf_step(x, theta, y[:, j], j + 1, rng)
            total += inc
        return x, total

    def _rejuvenate(self, x, theta, loglik, w_theta, y, rng):
        """Resample the θ-particles of these runs, then PMMH moves; returns x, theta, loglik, acceptance."""
        r, M = theta.shape
        lo, hi = self.model.bounds
        counts = self._counts(w_theta, rng)
        x, theta, loglik = repeat_rows(counts, x, theta, loglik)
        accepted = np.zeros(r)
        for _ in range(self.n_moves):
            mean = theta.mean(axis=1, keepdims=True)
            sd = np.sqrt(np.mean((theta - mean) ** 2, axis=1, keepdims=True))
            sd = np.maximum(sd, 1e-6 * (hi - lo))                              # a collapsed cloud still moves
            prop = theta + self.rw_scale * sd * rng.standard_normal((r, M))
            inside = (prop > lo) & (prop < hi)
            x_new, ll_new = self._run_pf(np.clip(prop, lo, hi), y, rng)
            log_u = np.log(rng.random((r, M)))
            acc = inside & (log_u < ll_new - loglik)
            theta = np.where(acc, prop, theta)
            loglik = np.where(acc, ll_new, loglik)
            x = np.where(acc[..., None, None], x_new, x)
            accepted += acc.mean(axis=1)
        return x, theta, loglik, accepted / self.n_moves

    def filter(self, y, rng=None) -> FilterResult:
        y = self._prepare(y, rng)
        runs, T, _ = y.shape
        M, N = self.n_theta, self.n_x
        lo, hi = self.model.bounds
        theta = lo + (hi - lo) * rng.random((runs, M))                         # uniform prior
        x = self.model.sample_initial(rng, (runs, M, N))
        loglik = np.zeros((runs, M))                                           # log p̂(y_1:k | θ^m)
        logw = np.full((runs, M), -np.log(M))                                  # normalised θ log-weights
        th, th_var, ess = np.empty((runs, T)), np.empty((runs, T)), np.empty((runs, T))
        rejuv = np.zeros((runs, T), dtype=bool)
        acc = np.full((runs, T), np.nan)
        log_ev = np.zeros(runs)
        pmmh = np.zeros(runs, dtype=np.int64)
        xs = np.empty((runs, T, self.model.dim_x))
        with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
            for k in range(1, T + 1):
                x, inc = self._pf_step(x, theta, y[:, k - 1], k, rng)
                loglik += inc
                w, log_sum, _ = normalize_log_weights(logw + inc)             # (b): reweight θ
                log_ev += log_sum
                th[:, k - 1] = np.einsum("rm,rm->r", w, theta)
                th_var[:, k - 1] = np.einsum("rm,rm->r", w, (theta - th[:, k - 1, None]) ** 2)
                xs[:, k - 1] = np.einsum("rm,rmni->ri", w, x) / N
                e = 1.0 / np.einsum("rm,rm->r", w, w)
                ess[:, k - 1] = e
                logw = np.log(w)
                do = e < self.ess_threshold * M
                if do.any():                                                   # (c): resample-move
                    sel = np.flatnonzero(do)
                    xr, tr, lr, a = self._rejuvenate(x[sel], theta[sel], loglik[sel], w[sel],
                                                     y[sel, :k], take_runs(rng, sel) if not do.all() else rng)
                    x[sel], theta[sel], loglik[sel] = xr, tr, lr
                    logw[sel] = -np.log(M)
                    rejuv[sel, k - 1] = True
                    acc[sel, k - 1] = a
                    pmmh[sel] += self.n_moves * k
        return FilterResult(xs, None, diagnostics={
            "theta": th, "theta_var": th_var, "log_evidence": log_ev, "theta_ess": ess,
            "rejuvenated": rejuv, "acceptance": acc, "pmmh_steps": pmmh})

    def __repr__(self) -> str:
        return f"SMC2(n_theta={self.n_theta}, n_x={self.n_x}, ess_threshold={self.ess_threshold})"
