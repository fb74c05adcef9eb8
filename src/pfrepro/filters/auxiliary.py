"""Auxiliary particle filter (Pitt & Shephard 1999), batched over runs and particles.

The bootstrap PF resamples on the weights of step k-1 and only then looks at y_k; the
auxiliary PF looks ahead: each particle's first-stage weight is its old weight times the
likelihood of y_k at a point prediction of where it goes, mu_k^i = f(x_{k-1}^i, k)
(Pitt & Shephard 1999, sec. 3.2, the "auxiliary variable" form), so that particles the
new measurement makes unlikely are dropped *before* they are propagated. The second-stage
weight corrects for the look-ahead:

    first stage    lambda^i  ∝ w_{k-1}^i p(y_k | mu_k^i)
    ancestors      a^j ~ lambda                     (resampling, any scheme)
    propagate      x_k^j ~ p(x_k | x_{k-1}^{a^j})
    second stage   w_k^j    ∝ p(y_k | x_k^j) / p(y_k | mu_k^{a^j})

The evidence estimate p̂(y_k | y_1:k-1) = [sum_i w_{k-1}^i p(y_k | mu^i)] ·
[1/N sum_j p(y_k | x_k^j) / p(y_k | mu^{a^j})] is unbiased (Pitt 2002; Johansen & Doucet
2008, eq. 9), as the bootstrap PF's is: a test checks it against the Kalman evidence.
"""
from __future__ import annotations

import numpy as np

from ..validation import check_positive_int
from .base import Filter, FilterResult
from .particle import normalize_log_weights
from .resampling import check_scheme, resampling_counts_function
from .smc_steps import particle_result, repeat_rows

__all__ = ["AuxiliaryParticleFilter"]


class AuxiliaryParticleFilter(Filter):
    """Auxiliary particle filter with the point-prediction look-ahead of Pitt & Shephard (1999).

    Parameters
    ----------
    model : StateSpaceModel
        A model with a transition mean ``f`` (the look-ahead point), a transition sampler
        and a likelihood.
    n_particles : int
        N >= 1.
    resampling : str
        Scheme of the first-stage draw: ``"systematic"`` (default), ``"stratified"``,
        ``"multinomial"`` or ``"residual"``.
    m0, P0 : array_like, optional
        Override the model's initial distribution N(m0, P0).

    Notes
    -----
    Diagnostics: ``ess`` (runs, T) of the second-stage weights, ``first_stage_ess`` (runs, T),
    ``log_evidence`` (runs,), ``collapsed`` (runs, T) and ``n_collapsed``. A step at which no
    look-ahead point explains the measurement (every first-stage weight zero) is flagged collapsed
    and, in that run, taken as a bootstrap step (ancestors from the previous weights, second-stage
    weight p(y_k | x_k)) instead of dividing by a zero look-ahead likelihood. Every draw has the
    runs axis first, so run i is bit-identical in any batch of runs.
    """

    name = "APF"
    needs_rng = True
    model_requirements = ("f", "transition_sampler", "likelihood")

    def __init__(self, model, n_particles: int, resampling: str = "systematic", m0=None, P0=None):
        super().__init__(model, m0, P0)
        self.n_particles = check_positive_int(n_particles, "n_particles")
        self.resampling = check_scheme(resampling)

    def filter(self, y, rng: np.random.Generator | None = None) -> FilterResult:
        y = self._prepare(y, rng)
        runs, T, _ = y.shape
        N, n, model = self.n_particles, self.model.dim_x, self.model
        counts_of = resampling_counts_function(self.resampling)
        x = self.sample_prior(rng, (runs, N))
        logw = np.full((runs, N), -np.log(N))
        xs = np.empty((runs, T, n))
        ess = np.empty((runs, T))
        ess1 = np.empty((runs, T))
        log_inc = np.empty((runs, T))
        collapsed = np.zeros((runs, T), dtype=bool)
        with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
            for k in range(1, T + 1):
                mu = model.f(x, k)
                ll_mu = model.log_likelihood(y[:, k - 1], mu)                  # log p(y_k | mu^i)
                lam, log_a, coll1 = normalize_log_weights(logw + ll_mu)        # first stage
                if coll1.any():
                    # no look-ahead point explains y_k (every p(y_k | mu^i) = 0; flagged): those runs take
                    # a bootstrap step instead -- ancestors from w_{k-1}, second-stage weight p(y_k | x),
                    # evidence (1/N) sum p(y_k | x) -- where p(y|x) / p(y|mu) would be x / 0
                    lam, ll_mu, log_a = lam.copy(), ll_mu.copy(), log_a.copy()
                    lam[coll1], ll_mu[coll1], log_a[coll1] = np.exp(logw[coll1]), 0.0, 0.0
                ess1[:, k - 1] = 1.0 / np.einsum("rn,rn->r", lam, lam)
                x, ll_mu = repeat_rows(counts_of(lam, rng), x, ll_mu)
                x = model.sample_transition(x, k, rng)
                second = model.log_likelihood(y[:, k - 1], x) - ll_mu          # second stage
                second = np.where(np.isnan(second), -np.inf, second)
                w, log_b, coll2 = normalize_log_weights(second)
                collapsed[:, k - 1] = coll1 | coll2
                log_inc[:, k - 1] = log_a + log_b - np.log(N)
                xs[:, k - 1] = np.einsum("rn,rni->ri", w, x)
                ess[:, k - 1] = 1.0 / np.einsum("rn,rn->r", w, w)
                logw = np.log(w)
        return particle_result(self.name, xs, log_inc, collapsed, ess=ess, first_stage_ess=ess1)

    def __repr__(self) -> str:
        return f"AuxiliaryParticleFilter(N={self.n_particles}, resampling={self.resampling!r})"
