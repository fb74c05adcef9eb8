"""Liu & West (2001) joint particle filter with kernel shrinkage, batched over runs.

Particles carry (x, θ). With discount factor δ, a = (3δ − 1)/(2δ) and h² = 1 − a², the
parameter cloud is moved by the shrunk kernel

    θ_i ← N(m_i, h² V),   m_i = a θ_i + (1 − a) θ̄,

where θ̄ and V are the cloud's weighted mean and variance. The mixture has the same mean
θ̄ and the same variance a²V + h²V = V as the cloud (:func:`shrinkage_kernel`; no
artificial variance inflation, unlike plain jittering). The step is Liu & West's auxiliary
form: first-stage weights g_i ∝ w_i p(z_k | μ_i) with μ_i = f(x_{k-1}^i, k, m_i), resample
ancestors j by g, draw θ ~ N(m_j, h²V), x_k ~ p(x_k | x_{k-1}^j, θ), and weight by
p(z_k | x_k) / p(z_k | μ_j). Two likelihood evaluations per particle per step.

Parameters
----------
model : ParameterizedModel
    A :class:`~pfrepro.models.parameterized.ParameterizedModel` with scalar θ.
n_particles : int
    N ≥ 1.
delta : float
    Discount factor δ in (1/3, 1] (default 0.99).
theta_prior : {"uniform"}
    θ_0 ~ U[r_l, r_u] (default) — the prior the DPF uses too.
"""
from __future__ import annotations

import numpy as np

from ..validation import as_finite_float, check_positive_int, check_quantile_levels
from .base import FilterDivergenceError, FilterResult
from .parameter_learning import ParameterLearningFilter
from .particle import normalize_log_weights
from .resampling import check_scheme, resample_counts

__all__ = ["LiuWestFilter", "shrinkage_kernel", "liu_west_a"]


def liu_west_a(delta: float) -> float:
    """Shrinkage factor a = (3δ − 1)/(2δ)."""
    delta = as_finite_float(delta, "delta")
    if not 1.0 / 3.0 < delta <= 1.0:
        raise ValueError(f"delta must lie in (1/3, 1], got {delta!r}")
    return (3.0 * delta - 1.0) / (2.0 * delta)


def shrinkage_kernel(w, theta, delta: float):
    """Kernel locations m_i and kernel variance h²V of Liu & West's shrinkage.

    ``w`` (runs, N) normalised weights, ``theta`` (runs, N). Returns ``(m, h2V)`` with m (runs, N)
    and h2V (runs,): the mixture Σ w_i N(m_i, h²V) keeps the cloud's mean and variance.
    """
    a = liu_west_a(delta)
    tbar = np.einsum("rn,rn->r", w, theta)
    d = theta - tbar[:, None]
    V = np.einsum("rn,rn->r", w, d * d)
    m = a * theta + (1.0 - a) * tbar[:, None]
    return m, (1.0 - a * a) * V


def weighted_quantiles(w, v, q):
    """Weighted quantiles per run: w, v (runs, N) -> (len(q), runs).

    The values sorted per run, the mid-point cumulative weights, and one ``np.interp`` per run
    for all levels at once (the same numbers as one call per level: interp computes each point
    on its own)."""
    order = np.argsort(v, axis=1)
    order += (np.arange(v.shape[0]) * v.shape[1])[:, None]     # flat indices: plain gathers
    vs = np.take(v, order)
    ws = np.take(w, order)
    cw = np.cumsum(ws, axis=1)
    cw -= 0.5 * ws
    levels = np.atleast_1d(np.asarray(q, float))
    out = np.empty((levels.size, v.shape[0]))
    for r in range(v.shape[0]):
        out[:, r] = np.interp(levels, cw[r], vs[r])
    return out


class LiuWestFilter(ParameterLearningFilter):
    """Liu & West's joint (x, θ) particle filter (module docstring)."""

    name = "Liu-West"
    needs_rng = True

    def __init__(self, model, n_particles: int, delta: float = 0.99, resampling: str = "systematic",
                 quantiles=(0.025, 0.5, 0.975)):
        """``quantiles``: levels of θ's weighted quantiles stored per step (diagnostics)."""
        super().__init__(model)
        self.n_particles = check_positive_int(n_particles, "n_particles")
        self.a = liu_west_a(delta)
        self.delta = float(delta)
        self.resampling = check_scheme(resampling)
        self.quantiles = check_quantile_levels(quantiles, "quantiles")

    def filter(self, y, rng=None) -> FilterResult:
        y = self._prepare(y, rng)
        mdl = self.model
        runs, T, _ = y.shape
        N, n = self.n_particles, mdl.dim_x
        lo, hi = mdl.bounds
        x = self.sample_prior(rng, (runs, N))
        theta = lo + (hi - lo) * rng.random((runs, N))
        logw = np.full((runs, N), -np.log(N))
        xs = np.empty((runs, T, n))
        th = np.empty((runs, T))
        th_var = np.empty((runs, T))
        thq = np.empty((runs, T, len(self.quantiles)))
        ess = np.empty((runs, T))
        n_unique = np.empty((runs, T))
        coll = np.zeros((runs, T), bool)
        flat = (np.arange(runs) * N)[:, None]
        for k in range(1, T + 1):
            z = y[:, k - 1]
            w, _, _ = normalize_log_weights(logw)
            m, h2V = shrinkage_kernel(w, theta, self.delta)
            mu = mdl.f(x, k, m[..., None])
            lg = mdl.log_likelihood(z, mu)
            g, _, _ = normalize_log_weights(np.log(np.maximum(w, 1e-300)) + lg)
            counts = resample_counts(g, rng, self.resampling)
            idx = np.repeat(np.arange(runs * N), counts.ravel()).reshape(runs, N)
            j = idx - flat
            mj = np.take(m, idx)                        # m[r, j]: idx is j's flat index in run r
            theta = mj + np.sqrt(h2V)[:, None] * rng.standard_normal((runs, N))
            xj = x.reshape(runs * N, n)[idx]
            x = mdl.sample_transition(xj, k, theta[..., None], rng)
            if not np.all(np.isfinite(x)):
                raise FilterDivergenceError(f"Liu-West particles became non-finite at step {k}")
            logw = mdl.log_likelihood(z, x) - np.take(lg, idx)
            w, _, c = normalize_log_weights(logw)
            coll[:, k - 1] = c
            xs[:, k - 1] = np.einsum("rn,rni->ri", w, x)
            th[:, k - 1] = np.einsum("rn,rn->r", w, theta)
            d = theta - th[:, k - 1, None]
            th_var[:, k - 1] = np.einsum("rn,rn->r", w, d * d)
            thq[:, k - 1] = weighted_quantiles(w, theta, self.quantiles).T
            ess[:, k - 1] = 1.0 / np.sum(w * w, axis=1)
            n_unique[:, k - 1] = 1 + np.count_nonzero(np.diff(j, axis=1), axis=1)  # j is sorted per run
        return FilterResult(xs, None, diagnostics={
            "theta": th, "theta_var": th_var, "theta_quantiles": thq,   # (runs, T, len(quantiles))
            "ess": ess, "n_unique_ancestors": n_unique, "collapsed": coll,
            "likelihood_evaluations_per_step": 2 * N,
        })

    def theta_quantiles(self, result: FilterResult, q=None):
        """Weighted quantiles of the θ particles at the levels given at construction: (len(q), runs, T)."""
        if q is not None and check_quantile_levels(q, "q") != self.quantiles:
            raise ValueError(f"this filter stored the quantiles {self.quantiles}; got q = {q}")
        return np.moveaxis(result.diagnostics["theta_quantiles"], -1, 0)
