"""Jump-Markov particle filter: the mode sampled per particle (Boers & Driessen 2005 style).

IMMPF and IMMPFOR (Zhou 2017) keep one particle cloud per mode and mix them through the
IMM interaction step. The direct alternative treats the mode as part of the state: each
particle carries (x, r), its mode jumps with the Markov chain and its state moves with
that mode's dynamics, and the bootstrap weights do the rest (McGinnity & Irwin 2000;
Boers & Driessen 2005, the "multiple model PF"):

    r_k^i ~ Pi[r_{k-1}^i, :]                  (mode jump)
    x_k^i ~ p_{r_k^i}(x_k | x_{k-1}^i)         (that mode's transition)
    w_k^i ∝ w_{k-1}^i p(y_k | x_k^i)           (the shared measurement model)

Mode probabilities are the weight sums per mode; the estimate is the weighted mean. The
transitions are drawn as in ``JumpMarkovSystem.simulate``: one
standard-normal draw per particle, mapped through the active mode's square root of Q, so
every draw has the runs axis first and run i is the same in any batch.
"""
from __future__ import annotations

import numpy as np

from ..validation import check_positive_int, check_probability
from .base import Filter, FilterResult
from .particle import normalize_log_weights
from .resampling import check_scheme, resampling_counts_function
from .smc_steps import particle_result, resample_runs

__all__ = ["JumpMarkovParticleFilter"]


class JumpMarkovParticleFilter(Filter):
    """Bootstrap particle filter on the joint (state, mode) of a jump-Markov system.

    Parameters
    ----------
    system : JumpMarkovSystem
        Mode models with additive Gaussian process noise (``f`` and ``Q``) and a shared
        measurement model.
    n_particles : int
        N >= 1 (in total, not per mode).
    resampling : str
        ``"systematic"`` (default), ``"stratified"``, ``"multinomial"`` or ``"residual"``.
    ess_threshold : float or None
        None (resample every step) or a fraction in [0, 1].
    m0, P0 : array_like, optional
        Override the system's initial distribution N(m0, P0).

    Notes
    -----
    Diagnostics: ``mode_probs`` (runs, T, r), ``ess`` (runs, T), ``resampled`` (runs, T),
    ``log_evidence`` (runs,), ``collapsed``, ``n_collapsed``.
    """

    name = "JMPF"
    needs_rng = True
    model_requirements = ()

    def __init__(self, system, n_particles: int, resampling: str = "systematic",
                 ess_threshold: float | None = None, m0=None, P0=None):
        if not hasattr(system, "models") or not hasattr(system, "Pi"):
            raise TypeError(f"JumpMarkovParticleFilter needs a JumpMarkovSystem, got {type(system).__name__}")
        super().__init__(system, m0, P0)
        self.system = system
        self.n_particles = check_positive_int(n_particles, "n_particles")
        self.resampling = check_scheme(resampling)
        self.ess_threshold = None if ess_threshold is None else check_probability(ess_threshold, "ess_threshold")
        self._roots = np.stack([m.process_noise._chol for m in system.models])   # (r, n, n)
        self._cum_Pi = np.cumsum(system.Pi, axis=1)
        self._cum_init = np.cumsum(system.initial_probs)

    @staticmethod
    def _draw_modes(cum, u):
        """Inverse-CDF mode draws: the first j with u < cum[..., j] (cum (..., r), u (...))."""
        return np.minimum((u[..., None] >= cum).sum(axis=-1), cum.shape[-1] - 1)

    def filter(self, y, rng: np.random.Generator | None = None) -> FilterResult:
        y = self._prepare(y, rng)
        runs, T, _ = y.shape
        # self.model (the system): a cost count's proxy sees the mode models' and the likelihood's calls
        sysm, N, n, r = self.model, self.n_particles, self.system.dim_x, self.system.r
        counts_of = resampling_counts_function(self.resampling)
        x = self.sample_prior(rng, (runs, N))
        mode = self._draw_modes(self._cum_init, rng.random((runs, N)))
        logw = np.full((runs, N), -np.log(N))
        xs = np.empty((runs, T, n))
        probs = np.empty((runs, T, r))
        ess = np.empty((runs, T))
        resampled = np.zeros((runs, T), dtype=bool)
        log_inc = np.empty((runs, T))
        collapsed = np.zeros((runs, T), dtype=bool)
        with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
            for k in range(1, T + 1):
                mode = self._draw_modes(self._cum_Pi[mode], rng.random((runs, N)))
                z = rng.standard_normal((runs, N, n))
                nxt = np.empty_like(x)
                for j, m in enumerate(sysm.models):
                    sel = mode == j
                    if sel.any():
                        # einsum on the selected rows: row i's arithmetic does not depend on the batch
                        nxt[sel] = m.f(x[sel], k) + np.einsum("ij,pj->pi", self._roots[j], z[sel])
                x = nxt
                w, log_inc[:, k - 1], collapsed[:, k - 1] = normalize_log_weights(
                    logw + sysm.log_likelihood(y[:, k - 1], x))
                xs[:, k - 1] = np.einsum("rn,rni->ri", w, x)
                probs[:, k - 1] = np.stack([np.where(mode == j, w, 0.0).sum(axis=1) for j in range(r)], axis=-1)
                e = 1.0 / np.einsum("rn,rn->r", w, w)
                ess[:, k - 1] = e
                logw = np.log(w)
                do = np.ones(runs, dtype=bool) if self.ess_threshold is None else e < self.ess_threshold * N
                resampled[:, k - 1] = do
                resample_runs(do, w, logw, rng, counts_of, x, mode)
        return particle_result(self.name, xs, log_inc, collapsed, mode_probs=probs, ess=ess, resampled=resampled)

    def __repr__(self) -> str:
        return (f"JumpMarkovParticleFilter(N={self.n_particles}, r={self.system.r}, "
                f"resampling={self.resampling!r}, ess_threshold={self.ess_threshold})")
