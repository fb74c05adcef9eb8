"""Regularised particle filter (Musso, Oudjane & Le Gland 2001), batched over runs and particles.

Resampling copies particles; with little process noise the copies stay together and the
cloud impoverishes (the problem CMS-PF and IMMPFOR address by other means). The
regularised PF resamples from a kernel density estimate of the weighted cloud instead of
its empirical measure (Musso et al. 2001, sec. 12.2.2, the post-RPF):

    x^j = x^{a^j} + h_opt L eps^j,   eps^j ~ N(0, I),   L L^T = weighted covariance of the cloud

with the bandwidth that is optimal for a Gaussian kernel and a Gaussian target
(eq. 12.6 there; Silverman 1986, eq. 4.14):

    h_opt = A N^{-1/(n+4)},   A = [4 / (n + 2)]^{1/(n+4)}.

``bandwidth_scale`` multiplies h_opt (1: the optimal value; 0: the bootstrap PF). Jitter
is applied only where the filter resamples (every step, or when the ESS falls below the
threshold).
"""
from __future__ import annotations

import numpy as np

from ..rng import take_runs
from ..validation import as_finite_float, check_positive_int, check_probability
from .base import Filter, FilterResult
from .particle import normalize_log_weights
from .resampling import check_scheme, resampling_counts_function
from .smc_steps import particle_result, resample_runs

__all__ = ["RegularizedParticleFilter", "optimal_bandwidth"]


def optimal_bandwidth(n_particles: int, dim: int) -> float:
    """h_opt = A N^{-1/(n+4)}, A = [4/(n+2)]^{1/(n+4)} (Musso et al. 2001, eq. 12.6)."""
    N = check_positive_int(n_particles, "n_particles")
    n = check_positive_int(dim, "dim")
    return (4.0 / (n + 2.0)) ** (1.0 / (n + 4.0)) * N ** (-1.0 / (n + 4.0))


def _weighted_cholesky(w, x):
    """Lower Cholesky factor of the weighted covariance of each run's cloud ``(runs, n, n)``.

    A degenerate cloud (fewer distinct particles than dimensions) gets a ridge of 1e-12 times
    its scale (the mean variance per dimension, floored at 1e-300 for a cloud without spread),
    so that the factor exists; the jitter is then (almost) zero, as it should be for a cloud
    with no spread.
    """
    m = np.einsum("rn,rni->ri", w, x)
    d = x - m[:, None, :]
    S = np.einsum("rn,rni,rnj->rij", w, d, d)
    scale = np.maximum(np.trace(S, axis1=-2, axis2=-1) / S.shape[-1], 1e-300)
    S = S + (1e-12 * scale)[:, None, None] * np.eye(S.shape[-1])
    return np.linalg.cholesky(S)


class RegularizedParticleFilter(Filter):
    """Post-regularised particle filter with a Gaussian kernel (Musso, Oudjane & Le Gland 2001).

    Parameters
    ----------
    model : StateSpaceModel
        Any model with a transition sampler and a likelihood.
    n_particles : int
        N >= 1.
    resampling : str
        ``"systematic"`` (default), ``"stratified"``, ``"multinomial"`` or ``"residual"``.
    ess_threshold : float or None
        None (resample and jitter every step) or a fraction in [0, 1].
    bandwidth_scale : float
        Multiplies the optimal bandwidth :func:`~pfrepro.filters.regularized.optimal_bandwidth` (default 1; >= 0).
    m0, P0 : array_like, optional
        Override the model's initial distribution N(m0, P0).

    Notes
    -----
    Diagnostics: ``ess`` (runs, T) before resampling, ``resampled`` (runs, T),
    ``log_evidence`` (runs,) (the bootstrap PF's estimator; the kernel step makes it
    biased by O(h^2)), ``collapsed`` and ``n_collapsed``.
    """

    name = "RPF"
    needs_rng = True

    def __init__(self, model, n_particles: int, resampling: str = "systematic",
                 ess_threshold: float | None = None, bandwidth_scale: float = 1.0, m0=None, P0=None):
        super().__init__(model, m0, P0)
        self.n_particles = check_positive_int(n_particles, "n_particles")
        self.resampling = check_scheme(resampling)
        self.ess_threshold = None if ess_threshold is None else check_probability(ess_threshold, "ess_threshold")
        self.bandwidth_scale = as_finite_float(bandwidth_scale, "bandwidth_scale", nonnegative=True)
        self.bandwidth = self.bandwidth_scale * optimal_bandwidth(self.n_particles, model.dim_x)

    def filter(self, y, rng: np.random.Generator | None = None) -> FilterResult:
        y = self._prepare(y, rng)
        runs, T, _ = y.shape
        N, n, model = self.n_particles, self.model.dim_x, self.model
        counts_of = resampling_counts_function(self.resampling)
        x = self.sample_prior(rng, (runs, N))
        logw = np.full((runs, N), -np.log(N))
        xs = np.empty((runs, T, n))
        ess = np.empty((runs, T))
        resampled = np.zeros((runs, T), dtype=bool)
        log_inc = np.empty((runs, T))
        collapsed = np.zeros((runs, T), dtype=bool)
        with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
            for k in range(1, T + 1):
                x = model.sample_transition(x, k, rng)
                w, log_inc[:, k - 1], collapsed[:, k - 1] = normalize_log_weights(
                    logw + model.log_likelihood(y[:, k - 1], x))
                xs[:, k - 1] = np.einsum("rn,rni->ri", w, x)
                e = 1.0 / np.einsum("rn,rn->r", w, w)
                ess[:, k - 1] = e
                do = np.ones(runs, dtype=bool) if self.ess_threshold is None else e < self.ess_threshold * N
                resampled[:, k - 1] = do
                logw = np.log(w)
                if do.any():
                    L = _weighted_cholesky(w[do], x[do])                # of the cloud before resampling
                    sel = resample_runs(do, w, logw, rng, counts_of, x)
                    eps = (rng if do.all() else take_runs(rng, sel)).standard_normal((len(sel), N, n))
                    x[sel] += self.bandwidth * (eps @ np.swapaxes(L, -1, -2))  # per-run (N, n) @ (n, n)
        return particle_result(self.name, xs, log_inc, collapsed, ess=ess, resampled=resampled)

    def __repr__(self) -> str:
        return (f"RegularizedParticleFilter(N={self.n_particles}, resampling={self.resampling!r}, "
                f"ess_threshold={self.ess_threshold}, bandwidth_scale={self.bandwidth_scale})")
