"""Exact posterior of a scalar static parameter θ for a scalar model: θ grid × point-mass filter.

For every θ_j of a grid on [r_l, r_u] a point-mass filter over x (the method of
:class:`~pfrepro.filters.grid.GridFilter`: move the masses to f(g_i, k, θ_j), split linearly
between neighbouring nodes, convolve with the Gaussian transition kernel by FFT, multiply
by p(y_k | g_i)) gives the one-step evidences p(y_k | θ_j, y_1:k-1), hence

    log p(y_1:k | θ_j) = Σ_{s ≤ k} log p(y_s | θ_j, y_1:s-1),
    p(θ_j | y_1:k) ∝ p(θ_j) p(y_1:k | θ_j)    (uniform prior on [r_l, r_u]),

and E[x_k | y_1:k] = Σ_j p(θ_j | y_1:k) E[x_k | θ_j, y_1:k]. The whole computation is one
array (runs, N_θ, M): batched over runs and θ, the only Python loop is over time.

The log-evidence is smooth in θ, so the posterior's moments and quantiles are computed
after interpolating it (cubic spline) onto ``n_fine`` points: the θ grid may then be
coarser than the posterior's width (the tests and the chapter check a refinement).
"""
from __future__ import annotations

import numpy as np
from scipy import fft as sfft
from scipy import sparse
from scipy.interpolate import CubicSpline

import warnings

from ..validation import check_positive_int, check_probability, check_quantile_levels
from .base import Filter, FilterResult
from .grid import LOST_MASS_TOL, compound_lost, lost_fraction, warn_lost_mass
from .particle import WeightCollapseWarning
from .parameter_learning import ParameterLearningFilter

__all__ = ["ThetaGridReference", "posterior_summary"]


def posterior_summary(theta_grid, log_post, q=(0.025, 0.975), n_fine: int = 2001):
    """Mean, variance and quantiles of p(θ | ·) from log-posterior values on a grid.

    ``log_post`` (..., N_θ) (unnormalised) is interpolated by a cubic spline in θ onto
    ``n_fine`` points, exponentiated and integrated by the trapezoid rule.
    Returns ``(mean, var, quantiles (len(q), ...))``.
    """
    g = np.asarray(theta_grid, float)
    lp = np.asarray(log_post, float)
    lp = lp - lp.max(axis=-1, keepdims=True)
    lp = np.maximum(lp, -745.0)  # exp underflow floor; keeps the spline finite
    fine = np.linspace(g[0], g[-1], n_fine)
    lf = CubicSpline(g, lp, axis=-1)(fine)
    lf -= lf.max(axis=-1, keepdims=True)
    p = np.exp(lf)
    dx = fine[1] - fine[0]
    cdf = np.concatenate([np.zeros(p.shape[:-1] + (1,)), np.cumsum(0.5 * (p[..., 1:] + p[..., :-1]) * dx, -1)], -1)
    Z = cdf[..., -1:].copy()
    cdf /= Z
    pn = p / Z
    mean = np.trapezoid(pn * fine, fine, axis=-1) if hasattr(np, "trapezoid") else np.trapz(pn * fine, fine, axis=-1)
    sec = np.trapezoid(pn * fine**2, fine, axis=-1) if hasattr(np, "trapezoid") else np.trapz(pn * fine**2, fine, axis=-1)
    flat = cdf.reshape(-1, n_fine)
    qs = np.stack([np.array([np.interp(qq, c, fine) for c in flat]).reshape(cdf.shape[:-1]) for qq in q])
    return mean, np.maximum(sec - mean**2, 0.0), qs


class ThetaGridReference(ParameterLearningFilter):
    """Exact θ posterior (and θ-marginal state mean) for a scalar model (module docstring).

    Parameters
    ----------
    model : ParameterizedModel
        A scalar :class:`~pfrepro.models.parameterized.ParameterizedModel` (dim_x = dim_y = 1)
        with Gaussian process noise (Q > 0).
    n_theta : int
        Number of θ grid nodes on [r_l, r_u] (endpoints included).
    x_bounds, n_grid : tuple of float, int
        The x grid; mass pushed outside is lost (reported, see below).
    lost_mass_tol : float
        Largest posterior-weighted fraction of one step's predictive mass that may leave the x
        grid without a :class:`~pfrepro.filters.grid.GridMassWarning` (default 1e-4).

    Notes
    -----
    Diagnostics, besides the θ posterior's ``theta``, ``theta_var``, ``theta_quantiles``
    (runs, T, 3) and ``log_evidence`` (runs, T, N_θ): ``lost_mass`` (runs, N_θ) the fraction
    of probability mass that left the x grid over the run given θ_j, 1 − Π_k (1 − lost_k,j),
    in [0, 1]; ``lost_mass_steps`` (runs, T) the fraction of step k's predictive mass that
    left the x grid, averaged over θ with the θ posterior entering the step (mass lost
    under a θ the data have ruled out does not count). Above ``lost_mass_tol`` one
    ``GridMassWarning`` names the runs: the x posterior then sticks to the grid's edge and
    drags the θ posterior with it (with x_bounds (−3, 3) on the sec 5.1 model θ̂ ends near
    0 for a true 0.5). ``theta_edge_mass`` (runs, T) is the θ posterior's mass on the two
    end nodes of the θ grid: large where the posterior is cut by the prior range [r_l, r_u].
    """

    name = "exact θ posterior (grid)"

    def __init__(self, model, n_theta: int = 101, x_bounds=(-40.0, 40.0), n_grid: int = 321, n_fine: int = 2001,
                 lost_mass_tol: float = LOST_MASS_TOL):
        super().__init__(model)
        self.lost_mass_tol = check_probability(lost_mass_tol, "lost_mass_tol")
        if model.dim_x != 1 or model.dim_y != 1:
            raise ValueError("ThetaGridReference is for scalar models (dim_x = dim_y = 1)")
        q = float(np.sqrt(model.Q[0, 0]))
        if not q > 0:
            raise ValueError("ThetaGridReference needs process noise (Q > 0)")
        self.n_theta = check_positive_int(n_theta, "n_theta")
        if self.n_theta < 4:
            raise ValueError("n_theta must be >= 4 (cubic interpolation of the log-evidence)")
        self.theta = np.linspace(*model.bounds, self.n_theta)
        lo, hi = map(float, x_bounds)
        if not hi > lo:
            raise ValueError(f"x_bounds must satisfy lo < hi, got {x_bounds}")
        self.n_grid = check_positive_int(n_grid, "n_grid")
        self.grid = np.linspace(lo, hi, self.n_grid)
        self.dx = self.grid[1] - self.grid[0]
        if self.dx > 0.5 * q:
            raise ValueError(f"x grid spacing {self.dx:.3g} too coarse for process noise std {q:.3g}; raise n_grid")
        half = int(np.ceil(8 * q / self.dx))
        offs = np.arange(-half, half + 1) * self.dx
        kern = np.exp(-0.5 * (offs / q) ** 2)
        self._half = half
        self._nfft = sfft.next_fast_len(self.n_grid + 2 * half, real=True)
        self._kernel_f = sfft.rfft(kern / kern.sum(), n=self._nfft)
        self.n_fine = check_positive_int(n_fine, "n_fine")

    def _move_matrix(self, k):
        """Block-diagonal sparse (N_θ M, N_θ M) matrix moving mass at g_i to f(g_i, k, θ_j)."""
        M, lo = self.n_grid, self.grid[0]
        z = self.model.f(self.grid[None, :, None], k, self.theta[:, None, None])[..., 0]  # (Nθ, M)
        pos = (z - lo) / self.dx
        inside = (pos >= 0) & (pos <= M - 1)
        j = np.clip(np.floor(pos), 0, M - 2).astype(np.intp)
        t = np.clip(pos - j, 0.0, 1.0)
        base = (np.arange(self.n_theta) * M)[:, None]
        src = (base + np.arange(M)[None, :])[inside]
        dst = (base + j)[inside]
        tt = t[inside]
        rows = np.concatenate([dst, dst + 1])
        cols = np.concatenate([src, src])
        vals = np.concatenate([1.0 - tt, tt])
        size = self.n_theta * M
        return sparse.csr_matrix((vals, (rows, cols)), shape=(size, size))

    def filter(self, y, rng=None) -> FilterResult:
        y = self._prepare(y, rng)
        runs, T, _ = y.shape
        Nt, M, g = self.n_theta, self.n_grid, self.grid
        m0, P0 = float(self.m0[0]), float(self.P0[0, 0])
        lp0 = -0.5 * (g - m0) ** 2 / P0
        p0 = np.exp(lp0 - lp0.max())
        p = np.broadcast_to(p0 / p0.sum(), (runs, Nt, M)).copy()
        logev = np.zeros((runs, T, Nt))   # cumulative log p(y_1:k | θ_j)
        xmean_theta = np.empty((runs, T, Nt))
        lost = np.zeros((runs, T, Nt))
        lost_w = np.zeros((runs, T))
        cum = np.zeros((runs, Nt))
        collapsed = np.zeros((runs, T), dtype=bool)
        for k in range(1, T + 1):
            A = self._move_matrix(k)
            moved = (A @ p.reshape(runs, Nt * M).T).T.reshape(runs, Nt, M)
            spec = sfft.rfft(moved, n=self._nfft, axis=-1)
            spec *= self._kernel_f
            pred = sfft.irfft(spec, n=self._nfft, axis=-1)[..., self._half:self._half + M]
            np.maximum(pred, 0.0, out=pred)
            lost[:, k - 1] = lost_fraction(pred)
            # weighted by the θ posterior entering the step (uniform at k = 1)
            w_in = np.exp(cum - cum.max(axis=1, keepdims=True))
            lost_w[:, k - 1] = (w_in * lost[:, k - 1]).sum(axis=1) / w_in.sum(axis=1)
            with np.errstate(over="ignore", invalid="ignore"):
                ll = self.model.log_likelihood(y[:, k - 1], g[None, :, None])  # (runs, M)
            ll = np.where(np.isnan(ll), -np.inf, ll)
            llmax = ll.max(axis=1, keepdims=True)
            # an outlier (y = 1e200): the likelihood is -inf at every node, or zero wherever
            # any theta has predictive mass. As the grid filter and the particle filters do,
            # the measurement is then ignored for that run (posterior = prediction, no
            # evidence term), the step flagged in diagnostics["collapsed"] and one
            # WeightCollapseWarning given per call.
            coll = ~np.isfinite(llmax[:, 0])
            llmax[coll], ll[coll] = 0.0, 0.0
            with np.errstate(under="ignore"):
                lik = np.exp(ll - llmax)[:, None, :]
            post = pred * lik
            s = post.sum(-1)                                                   # (runs, Nt)
            coll |= ~np.any(s > 0, axis=1)
            if coll.any():
                post[coll], llmax[coll] = pred[coll], 0.0
                s[coll] = pred[coll].sum(-1)
                if not np.all(np.any(s[coll] > 0, axis=-1)):
                    # no predictive mass left on the x grid for any θ (as in GridFilter)
                    raise FloatingPointError(f"ThetaGridReference: the predictive density left the x grid for "
                                             f"every θ at step {k}: widen x_bounds")
                collapsed[coll, k - 1] = True
            with np.errstate(divide="ignore"):
                cum += np.log(s) + llmax
            logev[:, k - 1] = cum
            s = np.where(s > 0, s, 1.0)
            p = post / s[..., None]
            xmean_theta[:, k - 1] = p @ g
        if collapsed.any():
            warnings.warn(WeightCollapseWarning(
                f"ThetaGridReference: the likelihood vanished at every grid node in {int(collapsed.sum())} of "
                f"{collapsed.size} run-steps (an outlier measurement); those measurements were ignored "
                f"(diagnostics['collapsed'])"), stacklevel=2)
        warn_lost_mass("ThetaGridReference", lost_w, self.lost_mass_tol, f"x_bounds ({g[0]:g}, {g[-1]:g})")
        # posterior of θ at every k (uniform prior on the grid range)
        mean, var, qs = posterior_summary(self.theta, logev, (0.025, 0.5, 0.975), self.n_fine)
        lw = logev - logev.max(-1, keepdims=True)
        wpost = np.exp(lw)
        wpost /= wpost.sum(-1, keepdims=True)
        x_mean = np.einsum("rtj,rtj->rt", wpost, xmean_theta)[..., None]
        return FilterResult(x_mean, None, diagnostics={
            "theta": mean, "theta_var": var, "theta_quantiles": np.moveaxis(qs, 0, -1),  # (runs, T, 3)
            "log_evidence": logev, "lost_mass": compound_lost(lost, axis=1), "lost_mass_steps": lost_w,
            "theta_edge_mass": wpost[..., 0] + wpost[..., -1], "x_mean_given_theta": xmean_theta,
            "collapsed": collapsed, "n_collapsed": int(collapsed.sum()),
        })

    quantile_levels = (0.025, 0.5, 0.975)

    def theta_quantiles(self, result: FilterResult, q=None):
        """The exact posterior's 2.5 / 50 / 97.5 % quantiles of θ: (3, runs, T)."""
        if q is not None and check_quantile_levels(q, "q") != self.quantile_levels:
            raise ValueError(f"the reference stores the quantiles {self.quantile_levels}; got q = {q}")
        return np.moveaxis(result.diagnostics["theta_quantiles"], -1, 0)
