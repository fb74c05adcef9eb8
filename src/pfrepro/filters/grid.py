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

import warnings

import numpy as np
from scipy import fft as sfft
from scipy import sparse

from ..noise import GaussianNoise
from ..validation import check_positive_int, check_probability
from .base import Filter, FilterResult

__all__ = ["GridFilter", "GridMassWarning", "LOST_MASS_TOL"]

#: default fraction of one step's predictive probability mass that may leave a grid's bounds before
#: the grid filters warn: a loss below it moves the posterior mean by less than 1e-4 of the grid's
#: width. (The book's grids lose round-off, and at most 7e-6 in the θ-grid reference of the dual
#: PF chapter, under θ values its data allow.)
LOST_MASS_TOL = 1e-4


class GridMassWarning(RuntimeWarning):
    """Probability mass left a grid filter's bounds: the posterior is not contained in the grid,
    so its mean and variance are those of the part inside (wrong, not merely inexact)."""


def lost_fraction(pred):
    """Fraction of a step's predictive mass pushed outside the grid, clipped to [0, 1].

    The masses entering a step sum to one, so ``1 - pred.sum()`` is that fraction; round-off
    makes it a few 1e-16 either side of zero, clipped to zero below."""
    return np.clip(1.0 - pred.sum(axis=-1), 0.0, 1.0)


def compound_lost(steps, axis):
    """Fraction of mass lost over a run from the per-step fractions ``steps``:
    1 - prod_k (1 - lost_k), in [0, 1] (about the sum of the steps' losses while they are small)."""
    return -np.expm1(np.log1p(-np.minimum(steps, 1.0)).sum(axis=axis))


def warn_lost_mass(who, lost, tol, bounds_name) -> None:
    """Warn (:class:`GridMassWarning`, one line) if the mass lost off a grid exceeded ``tol`` at
    some step: ``lost`` (runs, T) is the fraction lost per run and step. Shared by the grid
    filters; the warning points at the caller of the filter's ``filter``."""
    over = lost > tol
    if not over.any():
        return
    runs_lost = np.flatnonzero(over.any(axis=1))
    first_step = int(np.argmax(over.any(axis=0))) + 1
    shown = runs_lost[:10].tolist()
    warnings.warn(GridMassWarning(
        f"{who}: up to {float(lost.max()):.3g} of the predictive probability mass left the grid at one step "
        f"(first above the tolerance at step {first_step}) in {len(runs_lost)} of {lost.shape[0]} runs {shown}"
        f"{' ...' if len(runs_lost) > 10 else ''}; the posterior is not contained in the grid and "
        f"its estimates are wrong there: widen {bounds_name} (diagnostics['lost_mass_steps'])"), stacklevel=3)


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
        Mass pushed outside is lost and reported in ``diagnostics["lost_mass"]``; above
        ``lost_mass_tol`` a :class:`GridMassWarning` names the runs.
    n_grid : int
        Number of grid nodes M (>= 3).
    m0, P0 : array_like, optional
        Override the model's prior N(m0, P0); validated like the model's (finite m0;
        P0 > 0, a scalar or a 1x1 matrix).
    lost_mass_tol : float
        Largest fraction of one step's predictive mass that may leave the grid without a
        warning (default 1e-4).

    Model methods
    -------------
    ``dim_x == 1``, ``f``, a transition *density* (Gaussian ``process_noise`` with Q > 0:
    a singular/zero Q has none), ``log_likelihood`` (any measurement model, additive or
    not), ``m0``, ``P0``. Another model raises :class:`~pfrepro.models.ModelContractError`.

    Notes
    -----
    ``filter(y)``: ``y`` is ``(runs, T, dim_y)``, or ``(T,)`` for one scalar run, or
    ``(T, dim_y)`` for one run when ``dim_y > 1``.

    Diagnostics: ``lost_mass_steps`` (runs, T) the fraction of step k's predictive
    probability mass that the move and the kernel pushed outside the bounds, in [0, 1];
    ``lost_mass`` (runs,) the fraction lost over the run, 1 − Π_k (1 − lost_k), in [0, 1]
    (about the sum of the steps' fractions while they are small; round-off gives 0 to a
    few 1e-16); ``final_edge_mass`` (runs,) the posterior mass on the five outermost nodes at
    each end at the last step. If a step loses more than ``lost_mass_tol``, one
    :class:`GridMassWarning` names the runs: the posterior is then not contained in the grid
    and its mean is that of the part inside (with bounds (−1, 1) on UNGM it sticks near the
    edge, 10 or more away from the truth). A step whose predictive mass all left the grid
    raises ``FloatingPointError`` (nothing is left to estimate from). ``collapsed`` (runs, T) steps where the likelihood
    underflowed to zero (or was NaN) at every node with predictive mass, e.g. an outlier
    measurement: the measurement is then ignored (posterior = prediction), as the particle
    filters do on weight collapse; ``n_collapsed`` their number; ``log_domain_steps``
    (runs, T) steps normalised in the log domain because the direct product underflowed.
    """

    name = "Grid"
    model_requirements = ("scalar_state", "transition_density", "likelihood")

    def __init__(self, model, bounds=(-60.0, 60.0), n_grid: int = 6001, m0=None, P0=None,
                 lost_mass_tol: float = LOST_MASS_TOL):
        super().__init__(model, m0, P0)
        self.lost_mass_tol = check_probability(lost_mass_tol, "lost_mass_tol")
        if not isinstance(model.process_noise, GaussianNoise):
            raise TypeError("GridFilter needs Gaussian process noise")
        try:
            lo, hi = map(float, bounds)
        except (TypeError, ValueError):
            raise ValueError(f"bounds must be a pair (lo, hi) of numbers, got {bounds!r}") from None
        if not (np.isfinite(lo) and np.isfinite(hi)) or not hi > lo:
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
        logp0 = -0.5 * (g - self.m0[0]) ** 2 / self.P0[0, 0]
        p = np.exp(logp0 - logp0.max())
        p = np.broadcast_to(p / p.sum(), (runs, self.n_grid)).copy()
        means = np.empty((runs, T, 1))
        covs = np.empty((runs, T, 1, 1))
        lost = np.zeros((runs, T))
        collapsed = np.zeros((runs, T), dtype=bool)
        log_domain = np.zeros((runs, T), dtype=bool)
        gx = g[None, :, None]
        for k in range(1, T + 1):
            moved = p @ self._move_matrix(k).T
            pred = self._convolve(moved)
            lost[:, k - 1] = lost_fraction(pred)
            with np.errstate(over="ignore"):  # an outlier's -inf is handled below and reported
                loglik = self.model.log_likelihood(y[:, k - 1], np.broadcast_to(gx, (runs, self.n_grid, 1)))
            with np.errstate(invalid="ignore", over="ignore"):
                post = pred * np.exp(loglik - loglik.max(axis=1, keepdims=True))
                s = post.sum(axis=1, keepdims=True)
            bad = ~(s[:, 0] > 0) | ~np.isfinite(s[:, 0])   # catches NaN as well as 0
            if bad.any():
                post[bad], coll = self._log_domain_posterior(pred[bad], loglik[bad], k)
                s[bad] = 1.0
                log_domain[bad, k - 1] = True
                collapsed[np.flatnonzero(bad)[coll], k - 1] = True
            p = post / s
            # row-wise sums, not p @ g: a BLAS matrix-vector product's summation order
            # depends on how many rows it is given, so run i's mean would differ in the
            # last bits with the batch size (pfrepro.rng rule 3)
            mean = (p * g).sum(axis=1)
            means[:, k - 1, 0] = mean
            covs[:, k - 1, 0, 0] = (p * (g * g)).sum(axis=1) - mean**2
        if collapsed.any():
            # the same report as the particle filters' (one warning per call, with the count)
            from .particle import WeightCollapseWarning

            warnings.warn(WeightCollapseWarning(
                f"GridFilter: the likelihood vanished at every node with predictive mass in "
                f"{int(collapsed.sum())} of {collapsed.size} run-steps (an outlier measurement); those "
                f"measurements were ignored (diagnostics['collapsed'])"), stacklevel=2)
        warn_lost_mass("GridFilter", lost, self.lost_mass_tol, f"bounds ({self.grid[0]:g}, {self.grid[-1]:g})")
        edge = p[:, :5].sum(axis=1) + p[:, -5:].sum(axis=1)
        return FilterResult(means, covs, diagnostics={
            "lost_mass": compound_lost(lost, axis=1), "lost_mass_steps": lost,
            "final_edge_mass": edge, "collapsed": collapsed,
            "n_collapsed": int(collapsed.sum()), "log_domain_steps": log_domain})

    @staticmethod
    def _log_domain_posterior(pred, loglik, k):
        """Normalised posterior from predictive masses and log-likelihoods, in the log domain.

        Used for the rows where the direct product ``pred * exp(loglik - max)``
        underflowed or produced NaN (an outlier: the likelihood peaks where the
        prediction has no mass, or overflows to -inf everywhere). Returns
        ``(post, collapsed)``: a row whose likelihood is -inf/NaN at every node with
        predictive mass ignores the measurement (post = prediction) and is flagged.
        """
        ll = np.where(np.isnan(loglik), -np.inf, loglik)
        with np.errstate(divide="ignore"):
            lp = np.log(pred) + ll
        m = lp.max(axis=1, keepdims=True)
        collapsed = ~np.isfinite(m[:, 0])
        mass = pred.sum(axis=1)
        if np.any(~(mass > 0) & collapsed):
            raise FloatingPointError(f"grid predictive density vanished at step {k}: widen bounds or refine grid")
        with np.errstate(invalid="ignore"):
            post = np.exp(lp - m)
        post[collapsed] = pred[collapsed]
        return post / post.sum(axis=1, keepdims=True), collapsed
