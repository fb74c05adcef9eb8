"""Particle filters with a Gaussian proposal from a local Kalman update of each particle.

The bootstrap PF proposes from the transition and ignores y_k until it weights; when the
likelihood is narrow compared with the prior (the bearings-only offset start), almost
every particle lands where y_k says it cannot be and the weights collapse. The optimal
proposal p(x_k | x_{k-1}, y_k) avoids that; for additive Gaussian noise it is Gaussian
when h is linear, and a local linearisation (Doucet, Godsill & Andrieu 2000, sec. II-D-2)
or an unscented transform of the transition around each particle gives a Gaussian
approximation of it. The unscented variant is *not* van der Merwe, Doucet, de Freitas & Wan's
(2000) unscented particle filter: the UPF propagates a covariance per particle from step to
step, while this proposal starts every step from N(f(x_{k-1}^i), Q) and carries no covariance
(hence its name, "UT-proposal PF").
For particle i, with mu = f(x_{k-1}^i, k)::

    prior            N(mu, Q)
    local update     m_i = mu + K_i r(y_k, y_hat_i),  Sigma_i = Q - K_i S_i K_i^T
      linearised     H_i = dh/dx(mu), y_hat_i = h(mu), S_i = H_i Q H_i^T + R, K_i = Q H_i^T S_i^{-1}
      unscented      sigma points of N(mu, Q): y_hat_i, S_i = Pyy + R, K_i = Pxy S_i^{-1}
    draw             x_k^i ~ N(m_i, Sigma_i)
    weight           w_k^i ∝ w_{k-1}^i p(y_k | x_k^i) N(x_k^i; mu, Q) / N(x_k^i; m_i, Sigma_i)

For a linear-Gaussian model the linearised proposal *is* the optimal proposal and the
weight is p(y_k | x_{k-1}^i) = N(y_k; H F x_{k-1}^i, H Q H^T + R), whatever x_k^i is drawn
(a test checks it). The evidence estimate is unbiased (proper importance weights).
"""
from __future__ import annotations

import numpy as np

from ..validation import check_positive_int, check_probability
from .resampling import check_scheme
from .small_linalg import cholesky_components, inv_components, mm_components
from .smc_steps import ParticleLoop

__all__ = ["GaussianProposalParticleFilter", "PROPOSALS"]

#: the local updates that build the proposal
PROPOSALS = ("linearized", "unscented")


def _T(a):
    return np.swapaxes(a, -1, -2)


def _mv(A, v):
    return np.einsum("...ij,...j->...i", A, v)


def _log_normal(x, mean, chol):
    """log N(x; mean, L L^T) for batched x, mean (..., n) and lower factors L (..., n, n) or (n, n)."""
    n = x.shape[-1]
    d = x - mean
    if chol.ndim == 2:
        # einsum with L^{-1}, not one solve with all particles as right-hand sides: a
        # multi-column LAPACK solve picks its kernel by the column count (batch-dependent bits)
        z = np.einsum("ij,...j->...i", np.linalg.inv(chol), d)
        logdet = np.log(np.diag(chol)).sum()
    else:
        z = np.linalg.solve(chol, d[..., None])[..., 0]
        logdet = np.log(np.diagonal(chol, axis1=-2, axis2=-1)).sum(axis=-1)
    return -0.5 * np.einsum("...i,...i->...", z, z) - logdet - 0.5 * n * np.log(2 * np.pi)


class GaussianProposalParticleFilter(ParticleLoop):
    """PF whose proposal is a local EKF or UKF update of each particle's transition.

    Parameters
    ----------
    model : StateSpaceModel
        Additive Gaussian noise on both equations, ``f``, ``h`` (``jacobian_h`` for the
        linearised proposal) and a non-singular ``Q``.
    n_particles : int
        N >= 1.
    proposal : {"linearized", "unscented"}
        Doucet et al. (2000)'s linearised optimal proposal, or the unscented one
        (van der Merwe et al. 2000) with sigma points of N(f(x), Q).
    alpha, beta, kappa : float
        Unscented-transform parameters (``proposal="unscented"``; defaults 1, 2, 0).
    resampling : str
        ``"systematic"`` (default), ``"stratified"``, ``"multinomial"`` or ``"residual"``.
    ess_threshold : float or None
        None (resample every step) or a fraction in [0, 1].
    m0, P0 : array_like, optional
        Override the model's initial distribution N(m0, P0).

    Notes
    -----
    Diagnostics: ``ess`` (runs, T), ``resampled`` (runs, T), ``log_evidence`` (runs,),
    ``collapsed``, ``n_collapsed``.
    """

    def __init__(self, model, n_particles: int, proposal: str = "linearized", alpha: float = 1.0,
                 beta: float = 2.0, kappa: float = 0.0, resampling: str = "systematic",
                 ess_threshold: float | None = None, m0=None, P0=None):
        if proposal not in PROPOSALS:
            raise ValueError(f"proposal must be one of {PROPOSALS}, got {proposal!r}")
        self.model_requirements = ("f", "h", "additive_measurement", "transition_density") + (
            ("jacobian_h",) if proposal == "linearized" else ())
        super().__init__(model, m0, P0)
        self.proposal = proposal
        self.n_particles = check_positive_int(n_particles, "n_particles")
        self.resampling = check_scheme(resampling)
        self.ess_threshold = None if ess_threshold is None else check_probability(ess_threshold, "ess_threshold")
        self.name = "EKF-proposal PF" if proposal == "linearized" else "UT-proposal PF"
        self._Q = np.asarray(model.Q, float)
        self._LQ = np.linalg.cholesky(self._Q)
        self._R = np.asarray(model.R, float)
        self._Qc, self._Rc = self._Q[:, :, None, None], self._R[:, :, None, None]   # small axes first
        n = model.dim_x
        lam = alpha ** 2 * (n + kappa) - n
        if n + lam <= 0:
            raise ValueError(f"unscented parameters give n + lambda = {n + lam} <= 0")
        self._ut = (lam, np.r_[lam / (n + lam), np.full(2 * n, 0.5 / (n + lam))],
                    np.r_[lam / (n + lam) + (1 - alpha ** 2 + beta), np.full(2 * n, 0.5 / (n + lam))])

    def local_update(self, mu, y):
        """Proposal mean, lower factor of its covariance, for transition means ``mu`` (runs, N, n)
        and measurements ``y`` (runs, m); see :meth:`local_update_components`."""
        mean, L = self.local_update_components(mu, y)
        return np.moveaxis(mean, 0, -1), np.moveaxis(L, (0, 1), (-2, -1))

    def local_update_components(self, mu, y):
        """:meth:`local_update` with the results stored small axes first: mean (n, runs, N) and
        the lower factor (n, n, runs, N).

        The per-particle gains, inverse and Cholesky factor are written out over the small state
        and measurement axes, each term one vector operation over all particles
        (``pfrepro.filters.small_linalg``): a stack of 10^5 tiny matrix products or LAPACK
        calls costs far more than the same arithmetic as a few dozen vector operations, and each
        particle's numbers do not depend on the other particles or runs."""
        model, Q, R = self.model, self._Qc, self._Rc
        n = mu.shape[-1]
        yb = y[:, None, :]
        if self.proposal == "linearized":
            # small axes first and contiguous (a moved-axis view hands its strides on to every result)
            Hc = np.ascontiguousarray(np.moveaxis(model.jacobian_h(mu), (-2, -1), (0, 1)))   # (m, n, runs, N)
            y_hat = model.h(mu)
            Pxy = mm_components(Q, np.swapaxes(Hc, 0, 1))               # Q H^T (n, m, runs, N)
            S = mm_components(Hc, Pxy) + R
        else:
            lam, wm, wc = self._ut
            D = np.sqrt(n + lam) * self._LQ.T                         # rows: scaled columns of L_Q
            sig = np.concatenate([mu[..., None, :], mu[..., None, :] + D, mu[..., None, :] - D], axis=-2)
            hs = model.h(sig)                                         # (runs, N, 2n+1, m)
            y_hat = np.einsum("s,...sm->...m", wm, hs)
            dy = np.ascontiguousarray(np.moveaxis(model.residual_y(hs, y_hat[..., None, :]), (-2, -1), (0, 1)))
            S = mm_components((wc[:, None, None, None] * dy).swapaxes(0, 1), dy) + R
            # sigma point s deviates from mu by 0 (s = 0) or +-D[j] (s = 1 + j, 1 + n + j): the
            # cross covariance is sum_j wc_j D[j] (dy_+j - dy_-j), no (2n+1) x n deviations needed
            Pxy = mm_components((wc[1:n + 1, None] * D).T[:, :, None, None], dy[1:n + 1] - dy[n + 1:])
        K = mm_components(Pxy, inv_components(S))                    # (n, m, runs, N)
        r = np.ascontiguousarray(np.moveaxis(model.residual_y(yb, y_hat), -1, 0))   # (m, runs, N)
        mean = np.moveaxis(mu, -1, 0) + mm_components(K, r[:, None])[:, 0]
        cov = Q - mm_components(mm_components(K, S), np.swapaxes(K, 0, 1))
        cov = 0.5 * (cov + np.swapaxes(cov, 0, 1))
        return mean, cholesky_components(cov)

    def log_weight_increment(self, x_new, mu, mean, L, y):
        """log [p(y | x_new) N(x_new; mu, Q) / N(x_new; mean, L L^T)] per particle."""
        return (self.model.log_likelihood(y, x_new) + _log_normal(x_new, mu, self._LQ)
                - _log_normal(x_new, mean, L))

    def _move(self, k, x, logw, yk, rng, state):
        n = x.shape[-1]
        mu = self.model.f(x, k)
        mean, L = self.local_update_components(mu, yk)               # (n, runs, N), (n, n, runs, N)
        z = rng.standard_normal(x.shape)
        zc = np.moveaxis(z, -1, 0)
        x = np.moveaxis(mean + mm_components(L, zc[:, None])[:, 0], 0, -1)
        # log N(x; mean, L L^T) from the draw z itself (no per-particle solve)
        log_q = -0.5 * np.einsum("...i,...i->...", z, z)
        for i in range(n):
            log_q -= np.log(L[i, i])
        log_q -= 0.5 * n * np.log(2 * np.pi)
        return x, self.model.log_likelihood(yk, x) + _log_normal(x, mu, self._LQ) - log_q

    def __repr__(self) -> str:
        return (f"GaussianProposalParticleFilter(N={self.n_particles}, proposal={self.proposal!r}, "
                f"resampling={self.resampling!r})")
