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
from .resampling import check_scheme
from .smc_steps import ParticleLoop, resample_runs

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


class RegularizedParticleFilter(ParticleLoop):
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

    def __init__(self, model, n_particles: int, resampling: str = "systematic",
                 ess_threshold: float | None = None, bandwidth_scale: float = 1.0, m0=None, P0=None):
        super().__init__(model, m0, P0)
        self.n_particles = check_positive_int(n_particles, "n_particles")
        self.resampling = check_scheme(resampling)
        self.ess_threshold = None if ess_threshold is None else check_probability(ess_threshold, "ess_threshold")
        self.bandwidth_scale = as_finite_float(bandwidth_scale, "bandwidth_scale", nonnegative=True)
        self.bandwidth = self.bandwidth_scale * optimal_bandwidth(self.n_particles, model.dim_x)

    def _move(self, k, x, logw, yk, rng, state):
        x = self.model.sample_transition(x, k, rng)
        return x, self.model.log_likelihood(yk, x)

    def _resample(self, do, w, logw, rng, x, state):
        """Resample the runs in ``do``, then jitter their particles with the kernel whose factor is
        the weighted covariance of the cloud before resampling (Musso et al. 2001, post-RPF)."""
        if not do.any():
            return x
        L = _weighted_cholesky(w[do], x[do])                    # of the cloud before resampling
        sel = resample_runs(do, w, logw, rng, self._counts_of, x)
        eps = (rng if do.all() else take_runs(rng, sel)).standard_normal((len(sel), x.shape[1], x.shape[2]))
        x[sel] += self.bandwidth * (eps @ np.swapaxes(L, -1, -2))  # per-run (N, n) @ (n, n)
        return x

    def __repr__(self) -> str:
        return (f"RegularizedParticleFilter(N={self.n_particles}, resampling={self.resampling!r}, "
                f"ess_threshold={self.ess_threshold}, bandwidth_scale={self.bandwidth_scale})")
