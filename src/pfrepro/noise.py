"""Additive noise distributions: Gaussian and Gaussian mixture.

Both expose the same small interface, used by the models for simulation and by
the particle filters for likelihoods:

* ``sample(rng, shape)`` -> array ``(*shape, dim)``
* ``logpdf(v)`` -> log density of the last axis of ``v``
* ``mean`` and ``cov`` -> first two moments (what a Gaussian filter is given)
"""
from __future__ import annotations

import numpy as np
from scipy.special import logsumexp

from .rng import RunStreams
from .validation import as_covariance, as_vector

__all__ = ["GaussianNoise", "GaussianMixtureNoise"]

_LOG_2PI = np.log(2.0 * np.pi)

#: rows x dim x dim of one BLAS product in ``_rows_times_transpose``: below OpenBLAS's
#: threshold for threading a GEMM, so no product waits for a second thread
_CHUNK_WORK = 65536


def _rows_times_transpose(a: np.ndarray, L: np.ndarray) -> np.ndarray:
    """``a @ L.T`` over the last axis of ``a`` (any leading shape), computed in row blocks.

    The result is bit for bit that of one 2-D product ``a.reshape(-1, d) @ L.T``: the BLAS
    rounds a row of a GEMM the same way whatever the row count, as long as a block has at
    least 2 rows (a lone row takes the matrix-vector kernel, which rounds differently, so the
    last block is never one row). The blocks keep every product below the size at which a
    threaded BLAS splits it over threads: on a machine whose cores other processes hold, a
    split product over the runs x N rows of a particle cloud waits for its threads (measured:
    a (10^5, 4) x (4, 4) product took 12.5 ms of CPU with 2 BLAS threads on a loaded 2-core
    machine, in blocks 0.47 ms, the single-thread time).
    """
    d = a.shape[-1]
    flat = a.reshape(-1, d)
    rows = flat.shape[0]
    chunk = max(3, _CHUNK_WORK // max(d * L.shape[0], 1))
    if rows <= chunk:
        return (flat @ L.T).reshape(a.shape[:-1] + (L.shape[0],))
    out = np.empty((rows, L.shape[0]), dtype=np.result_type(flat, L))
    starts = list(range(0, rows, chunk))
    if rows - starts[-1] < 2:     # never a one-row last block (see above)
        starts[-1] -= 1
    LT = L.T
    for lo, hi in zip(starts, starts[1:] + [rows]):
        np.matmul(flat[lo:hi], LT, out=out[lo:hi])
    return out.reshape(a.shape[:-1] + (L.shape[0],))


class GaussianNoise:
    """Zero-mean (or ``mean``) Gaussian noise ``N(mean, cov)``.

    ``allow_singular=True`` admits a positive *semi*-definite ``cov``, e.g. a
    discrete white-noise-acceleration process noise Q = G Qc G^T of lower rank, or
    Q = 0 (deterministic dynamics). Such noise can be sampled (through a symmetric
    square root, so draws stay in the range of ``cov``; zero noise draws nothing)
    but has no density: :meth:`logpdf` raises, so a filter that needs the
    transition density (the grid filter) refuses it instead of returning NaN.
    """

    def __init__(self, cov, mean=None, *, allow_singular: bool = False):
        self.cov = as_covariance(cov, "cov", allow_singular=allow_singular)
        self.dim = self.cov.shape[0]
        self.mean = np.zeros(self.dim) if mean is None else as_vector(mean, "mean", self.dim)
        self._nonzero_mean = bool(np.any(self.mean != 0))
        self.is_zero = not np.any(self.cov)
        # singular: as_covariance's own test (smallest eigenvalue <= 1e-14 of the largest
        # entry), or a Cholesky factor that fails or is numerically rank-deficient. A rank-1
        # G G^T often *has* a Cholesky factor with a 1e-8 pivot, whose draws would leave the
        # range of cov: the eigenvalue test catches it.
        scale = max(float(np.max(np.abs(self.cov))), np.finfo(float).tiny)
        try:
            self._chol = np.linalg.cholesky(self.cov)
            self.is_singular = bool(np.min(np.diag(self._chol)) <= 1e-12 * np.sqrt(np.max(np.diag(self.cov)))
                                    or np.linalg.eigvalsh(self.cov).min() <= 1e-14 * scale)
        except np.linalg.LinAlgError:
            self.is_singular = True
        if self.is_singular:
            if not allow_singular:  # as_covariance already refused it; keep the invariant explicit
                raise ValueError("cov is singular; pass allow_singular=True for degenerate noise")
            # symmetric square root V sqrt(lam) V^T: draws lie in the range of cov
            lam, V = np.linalg.eigh(self.cov)
            self._chol = (V * np.sqrt(np.clip(lam, 0.0, None))) @ V.T
            self._prec_chol = None
            self._log_norm = None
        else:
            self._prec_chol = np.linalg.inv(self._chol)  # L^{-1}: whitening transform
            self._log_norm = -0.5 * (self.dim * _LOG_2PI) - np.sum(np.log(np.diag(self._chol)))

    def sample(self, rng: np.random.Generator, shape=()) -> np.ndarray:
        """Draw noise vectors.

        Parameters
        ----------
        rng : numpy.random.Generator or pfrepro.rng.RunStreams
            The random source; with :class:`~pfrepro.rng.RunStreams`, ``shape`` must start
            with the number of runs.
        shape : tuple of int, optional
            Leading shape of the draw, e.g. ``(runs, N)``; ``()`` gives one vector.

        Returns
        -------
        ndarray
            Shape ``shape + (dim,)``: ``mean + L z`` with ``z`` standard normal and ``L`` the
            Cholesky factor of ``cov`` (the symmetric square root if ``cov`` is singular;
            no draw at all if ``cov`` is zero).
        """
        if type(shape) is not tuple:
            shape = tuple(np.atleast_1d(shape))
        if self.is_zero:  # deterministic: no draw at all (Q = 0)
            return np.broadcast_to(self.mean, shape + (self.dim,)).copy()
        z = rng.standard_normal(shape + (self.dim,))
        # hot path of every particle filter: in place, and 2-D GEMMs over row blocks rather
        # than a stack of tiny matmuls (bits of one GEMM, no wait for BLAS threads)
        if self.dim == 1:
            z *= self._chol[0, 0]
        else:
            z = _rows_times_transpose(z, self._chol)
        if self._nonzero_mean:
            z += self.mean
        return z

    def logpdf(self, v) -> np.ndarray:
        """Log density of noise values ``v``.

        Parameters
        ----------
        v : array_like
            Shape ``(..., dim)``.

        Returns
        -------
        ndarray
            Shape ``v.shape[:-1]``: log N(v; mean, cov).

        Raises
        ------
        ValueError
            If ``cov`` is singular (degenerate noise has no density).
        """
        if self.is_singular:
            raise ValueError(
                "this Gaussian noise has a singular covariance and no density; a method that needs "
                f"its logpdf cannot use it (smallest eigenvalue {np.linalg.eigvalsh(self.cov).min():.3g})")
        v = np.asarray(v, dtype=float)
        if self._nonzero_mean:
            v = v - self.mean
        if self.dim == 1:  # scalar fast path, in place on one temporary
            z2 = np.multiply(v[..., 0], v[..., 0])
            z2 *= -0.5 * self._prec_chol[0, 0] ** 2
            z2 += self._log_norm
            return z2
        z = _rows_times_transpose(v, self._prec_chol)
        z *= z
        out = z.sum(axis=-1)
        out *= -0.5
        out += self._log_norm
        return out

    def __repr__(self) -> str:
        return f"GaussianNoise(cov={self.cov.tolist()})"


class GaussianMixtureNoise:
    """Finite Gaussian mixture ``sum_j w_j N(mean_j, cov_j)``.

    ``cov`` is the mixture's own covariance (law of total variance), which is
    the natural covariance to hand a Gaussian filter.
    """

    def __init__(self, weights, covs, means=None):
        w = as_vector(weights, "weights")
        if np.any(w < 0) or not np.isclose(w.sum(), 1.0, rtol=0, atol=1e-12):
            raise ValueError(f"mixture weights must be non-negative and sum to 1, got {w}")
        self.weights = w
        self.components = [
            GaussianNoise(c, None if means is None else means[j]) for j, c in enumerate(covs)
        ]
        if len(self.components) != len(w):
            raise ValueError("one covariance per mixture weight is required")
        dims = {c.dim for c in self.components}
        if len(dims) != 1:
            raise ValueError("all mixture components must have the same dimension")
        self.dim = dims.pop()
        means_ = np.array([c.mean for c in self.components])
        self.mean = w @ means_
        second = sum(wj * (c.cov + np.outer(c.mean, c.mean)) for wj, c in zip(w, self.components))
        self.cov = second - np.outer(self.mean, self.mean)

    def sample(self, rng: np.random.Generator, shape=()) -> np.ndarray:
        """Draw noise vectors: a component j with probability ``weights[j]``, then its Gaussian.

        Parameters
        ----------
        rng : numpy.random.Generator or pfrepro.rng.RunStreams
            The random source; with :class:`~pfrepro.rng.RunStreams` each run draws its own
            slice from its own stream (``shape`` starts with the number of runs).
        shape : tuple of int, optional
            Leading shape of the draw; ``()`` gives one vector.

        Returns
        -------
        ndarray
            Shape ``shape + (dim,)``.
        """
        if type(shape) is not tuple:
            shape = tuple(np.atleast_1d(shape))
        if isinstance(rng, RunStreams):  # per-run streams: each run draws its own slice
            return np.stack([self.sample(g, shape[1:]) for g in rng])
        which = rng.choice(len(self.weights), size=shape, p=self.weights)
        out = np.empty(shape + (self.dim,))
        for j, comp in enumerate(self.components):
            mask = which == j
            out[mask] = comp.sample(rng, int(mask.sum()))
        return out

    def logpdf(self, v) -> np.ndarray:
        """Log density ``log sum_j w_j N(v; mean_j, cov_j)`` (log-sum-exp over components).

        Parameters
        ----------
        v : array_like
            Shape ``(..., dim)``.

        Returns
        -------
        ndarray
            Shape ``v.shape[:-1]``.
        """
        parts = [np.log(wj) + c.logpdf(v) for wj, c in zip(self.weights, self.components) if wj > 0]
        return logsumexp(np.stack(parts, axis=0), axis=0)

    def __repr__(self) -> str:
        return f"GaussianMixtureNoise(weights={self.weights.tolist()}, covs={[c.cov.tolist() for c in self.components]})"
