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
from .particle import normalize_log_weights
from .resampling import check_scheme
from .smc_steps import ParticleLoop, repeat_rows

__all__ = ["AuxiliaryParticleFilter"]


class AuxiliaryParticleFilter(ParticleLoop):
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
    model_requirements = ("f", "transition_sampler", "likelihood")

    def __init__(self, model, n_particles: int, resampling: str = "systematic", m0=None, P0=None):
        super().__init__(model, m0, P0)
        self.n_particles = check_positive_int(n_particles, "n_particles")
        self.resampling = check_scheme(resampling)

    #: False, the resampling is the first stage of the next step and never at the end of one
    resamples_after_weighting = False
    ess_threshold = None

    def _start(self, y, rng, runs, N):
        x, state = super()._start(y, rng, runs, N)
        state["diag"] = {"first_stage_ess": np.empty((runs, y.shape[1]))}
        return x, state

    def _move(self, k, x, logw, yk, rng, state):
        model = self.model
        mu = model.f(x, k)
        ll_mu = model.log_likelihood(yk, mu)                                   # log p(y_k | mu^i)
        lam, log_a, coll1 = normalize_log_weights(logw + ll_mu)                # first stage
        if coll1.any():
            # no look-ahead point explains y_k (every p(y_k | mu^i) = 0; flagged): those runs take
            # a bootstrap step instead -- ancestors from w_{k-1}, second-stage weight p(y_k | x),
            # evidence (1/N) sum p(y_k | x) -- where p(y|x) / p(y|mu) would be x / 0
            lam, ll_mu, log_a = lam.copy(), ll_mu.copy(), log_a.copy()
            lam[coll1], ll_mu[coll1], log_a[coll1] = np.exp(logw[coll1]), 0.0, 0.0
        state["diag"]["first_stage_ess"][:, k - 1] = 1.0 / np.einsum("rn,rn->r", lam, lam)
        x, ll_mu = repeat_rows(self._counts_of(lam, rng), x, ll_mu)
        x = model.sample_transition(x, k, rng)
        second = model.log_likelihood(yk, x) - ll_mu                           # second stage
        state["log_a"], state["coll1"] = log_a, coll1
        return x, np.where(np.isnan(second), -np.inf, second)

    def _combine(self, logw, lw, state):
        return lw            # the ancestors were drawn by the first-stage weights: uniform now

    def _increment(self, log_sum, collapsed, state):
        return state["log_a"] + log_sum - np.log(self.n_particles), state["coll1"] | collapsed

    def __repr__(self) -> str:
        return f"AuxiliaryParticleFilter(N={self.n_particles}, resampling={self.resampling!r})"
