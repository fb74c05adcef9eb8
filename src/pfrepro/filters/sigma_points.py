"""Scaled unscented transform (Julier 2002; Wan & van der Merwe 2000).

Same parameterisation and point ordering as filterpy's
``MerweScaledSigmaPoints``: lambda = alpha^2 (n + kappa) - n, points
x, x + col_i(sqrt((n + lambda) P)), x - col_i(...), with the lower Cholesky
factor as the matrix square root, and weights

    Wm_0 = lambda / (n + lambda),  Wc_0 = Wm_0 + 1 - alpha^2 + beta,
    Wm_i = Wc_i = 1 / (2 (n + lambda)),  i = 1..2n.
"""
from __future__ import annotations

import numpy as np

__all__ = ["ScaledSigmaPoints", "unscented_transform", "safe_cholesky"]


def safe_cholesky(A, name="covariance", on_error="raise"):
    """Batched matrix square root L with L L^T = A; robust to singular A.

    The lower Cholesky factor (symmetrised A), with a small jitter if needed. A
    covariance that is positive *semi*-definite but still not factorisable after a
    jitter of 1e-6 of its scale (rank-deficient, e.g. zero) gets the symmetric
    square root V sqrt(max(lam, 0)) V^T, which is as good for sigma points. One with
    an eigenvalue below -1e-8 of its scale (or NaN) raises
    ``numpy.linalg.LinAlgError`` naming it.

    Each matrix of a batch is treated on its own (pfrepro.rng rule 3): when one matrix
    needs the jitter, the others keep their plain Cholesky factor (the batch is tried
    first; on failure every matrix is factorised alone). ``on_error="nan"``: a matrix
    that cannot be factorised (NaN/inf, indefinite) gets a NaN factor in its own slot
    instead of raising for the whole batch (the GPFF then marks that run diverged).
    """
    if on_error not in ("raise", "nan"):
        raise ValueError(f"on_error must be 'raise' or 'nan', got {on_error!r}")
    A = 0.5 * (A + np.swapaxes(A, -1, -2))
    try:
        return np.linalg.cholesky(A)
    except np.linalg.LinAlgError:
        pass
    out = np.empty_like(A)
    for idx in np.ndindex(*A.shape[:-2]):
        try:
            out[idx] = _safe_cholesky_one(A[idx], name)
        except np.linalg.LinAlgError:
            if on_error == "raise":
                raise
            out[idx] = np.nan
    return out


def _safe_cholesky_one(A, name):
    """:func:`safe_cholesky` of one symmetric (n, n) matrix."""
    try:
        return np.linalg.cholesky(A)
    except np.linalg.LinAlgError:
        pass
    if not np.all(np.isfinite(A)):
        raise np.linalg.LinAlgError(f"{name} contains NaN or infinite entries")
    scale = np.max(np.abs(np.diagonal(A)))
    eye = np.eye(A.shape[-1])
    for rel in (1e-12, 1e-10, 1e-8, 1e-6):
        try:
            return np.linalg.cholesky(A + rel * scale * eye)
        except np.linalg.LinAlgError:
            continue
    lam, V = np.linalg.eigh(A)
    tol = 1e-8 * max(scale, np.finfo(float).tiny)
    if lam.min() < -tol:
        raise np.linalg.LinAlgError(f"{name} is not positive semi-definite (smallest eigenvalue "
                                    f"{lam.min():.3g})")
    return (V * np.sqrt(np.clip(lam, 0.0, None))) @ V.T


class ScaledSigmaPoints:
    """2n + 1 scaled sigma points with explicit ``alpha``, ``beta``, ``kappa``."""

    def __init__(self, n: int, alpha: float, beta: float, kappa: float):
        if n < 1:
            raise ValueError("n must be >= 1")
        self.n, self.alpha, self.beta, self.kappa = int(n), float(alpha), float(beta), float(kappa)
        lam = alpha**2 * (n + kappa) - n
        if n + lam <= 0:
            raise ValueError(f"n + lambda = {n + lam} must be positive (alpha={alpha}, kappa={kappa})")
        self.lam = lam
        c = 0.5 / (n + lam)
        self.Wm = np.full(2 * n + 1, c)
        self.Wc = np.full(2 * n + 1, c)
        self.Wm[0] = lam / (n + lam)
        self.Wc[0] = lam / (n + lam) + 1.0 - alpha**2 + beta

    @property
    def num_points(self) -> int:
        """Number of sigma points, 2n + 1."""
        return 2 * self.n + 1

    def sigma_points(self, x, P, on_error="raise"):
        """Points for batched ``x`` (..., n), ``P`` (..., n, n) -> (..., 2n + 1, n).

        ``on_error="nan"``: a ``P`` without a square root gives NaN points for its own
        batch entry only (see ``safe_cholesky``)."""
        L = safe_cholesky((self.n + self.lam) * P, on_error=on_error)
        offsets = np.swapaxes(L, -1, -2)  # rows = columns of L
        x = x[..., None, :]
        return np.concatenate([x, x + offsets, x - offsets], axis=-2)

    def __repr__(self) -> str:
        return f"ScaledSigmaPoints(n={self.n}, alpha={self.alpha}, beta={self.beta}, kappa={self.kappa})"


def unscented_transform(sigmas, Wm, Wc, noise_cov=None, residual=None):
    """Weighted mean and covariance of transformed sigma points ``(..., 2n+1, m)``."""
    mean = np.einsum("i,...ij->...j", Wm, sigmas)
    d = sigmas - mean[..., None, :] if residual is None else residual(sigmas, mean[..., None, :])
    cov = np.einsum("i,...ij,...ik->...jk", Wc, d, d)
    if noise_cov is not None:
        cov = cov + noise_cov
    return mean, cov, d
