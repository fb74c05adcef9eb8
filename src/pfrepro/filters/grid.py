"""Point-mass (grid) filter for scalar models: the exact posterior up to grid error.

For a scalar model x_k = f(x_{k-1}, k) + w, w ~ N(0, Q), the filtering density
is carried as probability masses on a uniform grid g_0..g_{M-1}. Prediction
moves each mass to f(g_i, k) (split linearly between the two neighbouring
nodes, which preserves mass and mean) and convolves with the Gaussian
transition kernel (an FFT convolution, exact for the discretised kernel);
the update multiplies by p(y_k | g_i) in the log domain and renormalises.
The error is O(dx^2) for smooth densities, so with dx well below sqrt(Q) the
posterior mean is exact to the precision any filter comparison needs. It is
the accuracy reference: its MSE is the lowest achievable by any filter.
"""
from __future__ import annotations

import numpy as np
from scipy import fft as sfft
from scipy import sparse

from ..noise import GaussianNoise
from ..validation import check_positive_int
from .base import Filter, FilterResult

__all__ = ["GridFilter"]


class GridFilter(Filter):
    """Exact-reference point-mass filter for a scalar model with Gaussian process noise.

    Not from a paper: the accuracy reference of the book. It carries p(x_k | y_1:k) on a
    uniform grid (see the module docstring): prediction moves the masses by f and
    convolves with the Gaussian transition kernel, the update multiplies by p(y_k | x):
    the Bayesian recursion of Li et al. 2012, eqs 3-5, on a grid. Its posterior mean
    is the minimum-MSE estimate up to grid error.

    Parameters
    ----------
    model : StateSpaceModel
        A scalar model (dim_x == 1) with Gaussian process noise; any measurement model.
    bounds : tuple of float
        (lo, hi) of the grid; must contain essentially all posterior mass.
        Mass pushed outside is lost and reported in ``diagnostics["lost_mass"]``.
    n_grid : int
        Number of grid nodes M (>= 3).
    m0, P0 : array_like, optional
        Override the model's initial distribution N(m0, P0).

    Model methods
    -------------
    ``f``, ``Q`` (Gaussian ``process_noise``), ``log_likelihood``, ``m0``, ``P0``.
    """

    name = "Grid"

    def __init__(self, model, bounds=(-60.0, 60.0), n_grid: int = 6001, m0=None, P0=None):
        super().__init__(model)
        if model.dim_x != 1:
            raise ValueError("GridFilter is for scalar models (dim_x == 1)")
        if not isinstance(model.process_noise, GaussianNoise):
            raise TypeError("GridFilter needs Gaussian process noise")
        lo, hi = map(float, bounds)
        if not hi > lo:
            raise ValueError(f"bounds must satisfy lo < hi, got {bounds}")
        self.n_grid = check_positive_int(n_grid, "n_grid")
        if self.n_grid < 3:
            raise ValueError("n_grid must be >= 3")
        self.grid = np.linspace(lo, hi, self.n_grid)
        self.dx = self.grid[1] - self.grid[0]
        q = float(np.sqrt(model.Q[0, 0]))
        if self.dx > 0.25 * q:
            raise ValueError(f"grid spacing {self.dx:.3g} is too coarse for process noise std {q:.3g}; raise n_grid")
        half = int(np.ceil(8 * q / self.dx))
        offs = np.arange(-half, half + 1) * self.dx
        kern = np.exp(-0.5 * (offs / q) ** 2)
        self.kernel = kern / kern.sum()
        # the kernel never changes: transform it once, convolve by rfft/irfft per step
        self._half = half
        self._nfft = sfft.next_fast_len(self.n_grid + 2 * half, real=True)
        self._kernel_f = sfft.rfft(self.kernel, n=self._nfft)
        self.m0 = float(model.m0[0] if m0 is None else m0)
        self.P0 = float(model.P0[0, 0] if P0 is None else P0)

    def _move_matrix(self, k):
        """Sparse (M, M) matrix sending the mass at g_i to f(g_i, k), split linearly."""
        M, lo = self.n_grid, self.grid[0]
        z = self.model.f(self.grid[:, None], k)[:, 0]
        pos = (z - lo) / self.dx
        inside = (pos >= 0) & (pos <= M - 1)
        j = np.clip(np.floor(pos), 0, M - 2).astype(np.intp)
        t = np.clip(pos - j, 0.0, 1.0)
        src = np.arange(M)
        rows = np.concatenate([j[inside], j[inside] + 1])
        cols = np.concatenate([src[inside], src[inside]])
        vals = np.concatenate([1.0 - t[inside], t[inside]])
        return sparse.csr_matrix((vals, (rows, cols)), shape=(M, M))

    def _convolve(self, moved):
        """Linear convolution with the transition kernel, cropped to the grid ('same')."""
        spec = sfft.rfft(moved, n=self._nfft, axis=1, workers=-1)
        spec *= self._kernel_f
        full = sfft.irfft(spec, n=self._nfft, axis=1, workers=-1)
        pred = full[:, self._half : self._half + self.n_grid]
        return np.maximum(pred, 0.0)  # FFT round-off can leave -1e-17

    def filter(self, y, rng=None) -> FilterResult:
        y = self._prepare(y, rng)
        runs, T, _ = y.shape
        g = self.grid
        logp0 = -0.5 * (g - self.m0) ** 2 / self.P0
        p = np.exp(logp0 - logp0.max())
        p = np.broadcast_to(p / p.sum(), (runs, self.n_grid)).copy()
        means = np.empty((runs, T, 1))
        covs = np.empty((runs, T, 1, 1))
        lost = np.zeros(runs)
        gx = g[None, :, None]
        for k in range(1, T + 1):
            moved = p @ self._move_matrix(k).T
            pred = self._convolve(moved)
            lost += 1.0 - pred.sum(axis=1)
            loglik = self.model.log_likelihood(y[:, k - 1], np.broadcast_to(gx, (runs, self.n_grid, 1)))
            loglik -= loglik.max(axis=1, keepdims=True)
            post = pred * np.exp(loglik)
            s = post.sum(axis=1, keepdims=True)
            if np.any(s <= 0):
                raise FloatingPointError(f"grid posterior vanished at step {k}: widen bounds or refine grid")
            p = post / s
            mean = p @ g
            means[:, k - 1, 0] = mean
            covs[:, k - 1, 0, 0] = p @ (g * g) - mean**2
        edge = p[:, :5].sum(axis=1) + p[:, -5:].sum(axis=1)
        return FilterResult(means, covs, diagnostics={"lost_mass": lost, "final_edge_mass": edge})
