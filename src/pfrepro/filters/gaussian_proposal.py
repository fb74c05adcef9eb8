"""Particle filters with a Gaussian proposal from a local Kalman update of each particle.

The bootstrap PF proposes from the transition and ignores y_k until it weights; when the
likelihood is narrow compared with the prior (the bearings-only offset start), almost
every particle lands where y_k says it cannot be and the weights collapse. The optimal
proposal p(x_k | x_{k-1}, y_k) avoids that; for additive Gaussian noise it is Gaussian
when h is linear, and a local linearisation (Doucet, Godsill & Andrieu 2000, sec. II-D-2)
or an unscented transform (van der Merwe, Doucet, de Freitas & Wan 2000, the "UPF"
proposal, here around each particle's transition) gives a Gaussian approximation of it.
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
from .small_linalg import inv_small
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
        self.name = "EKF-proposal PF" if proposal == "linearized" else "UKF-proposal PF"
        self._Q = np.asarray(model.Q, float)
        self._LQ = np.linalg.cholesky(self._Q)
        self._R = np.asarray(model.R, float)
        n = model.dim_x
        lam = alpha ** 2 * (n + kappa) - n
        if n + lam <= 0:
            raise ValueError(f"unscented parameters give n + lambda = {n + lam} <= 0")
        self._ut = (lam, np.r_[lam / (n + lam), np.full(2 * n, 0.5 / (n + lam))],
                    np.r_[lam / (n + lam) + (1 - alpha ** 2 + beta), np.full(2 * n, 0.5 / (n + lam))])

    def local_update(self, mu, y):
        """Proposal mean, lower factor of its covariance, for transition means ``mu`` (runs, N, n)
        and measurements ``y`` (runs, m)."""
        model, Q, R = self.model, self._Q, self._R
        yb = y[:, None, :]
        if self.proposal == "linearized":
            H = model.jacobian_h(mu)                                  # (runs, N, m, n)
            y_hat = model.h(mu)
            QHt = Q @ _T(H)
            S = H @ QHt + R
            Pxy = QHt
        else:
            lam, wm, wc = self._ut
            n = mu.shape[-1]
            D = np.sqrt(n + lam) * self._LQ.T                         # rows: scaled columns of L_Q
            sig = np.concatenate([mu[..., None, :], mu[..., None, :] + D, mu[..., None, :] - D], axis=-2)
            hs = model.h(sig)                                         # (runs, N, 2n+1, m)
            y_hat = np.einsum("s,...sm->...m", wm, hs)
            dy = model.residual_y(hs, y_hat[..., None, :])
            dx = sig - mu[..., None, :]
            S = np.einsum("s,...si,...sj->...ij", wc, dy, dy) + R
            Pxy = np.einsum("s,...si,...sj->...ij", wc, dx, dy)
        K = Pxy @ inv_small(S)                                        # (runs, N, n, m)
        mean = mu + _mv(K, model.residual_y(yb, y_hat))
        cov = Q - K @ S @ _T(K)
        cov = 0.5 * (cov + _T(cov))
        return mean, np.linalg.cholesky(cov)

    def log_weight_increment(self, x_new, mu, mean, L, y):
        """log [p(y | x_new) N(x_new; mu, Q) / N(x_new; mean, L L^T)] per particle."""
        return (self.model.log_likelihood(y, x_new) + _log_normal(x_new, mu, self._LQ)
                - _log_normal(x_new, mean, L))

    def _move(self, k, x, logw, yk, rng, state):
        n = x.shape[-1]
        mu = self.model.f(x, k)
        mean, L = self.local_update(mu, yk)
        z = rng.standard_normal(x.shape)
        x = mean + _mv(L, z)
        # log N(x; mean, L L^T) from the draw z itself (no per-particle solve)
        log_q = (-0.5 * np.einsum("...i,...i->...", z, z)
                 - np.log(np.diagonal(L, axis1=-2, axis2=-1)).sum(axis=-1) - 0.5 * n * np.log(2 * np.pi))
        return x, self.model.log_likelihood(yk, x) + _log_normal(x, mu, self._LQ) - log_q

    def __repr__(self) -> str:
        return (f"GaussianProposalParticleFilter(N={self.n_particles}, proposal={self.proposal!r}, "
                f"resampling={self.resampling!r})")
