"""Gaussian particle flow filter (Zhang, Zhou & Feng 2016), batched over runs and particles.

Per time step k (the paper's algorithm, sec 4):

1. propagate every particle through the dynamics, x^i ~ p(x_k | x_{k-1}^i)  (eq 1);
2. prior mean and covariance from the particles (eqs 51, 52; covariance with 1/(N-1));
3. unscented transform of N(mean, cov) through h: y_hat, Pyy, Pxy (eqs 47-50; no R in Pyy);
4. move the particles along dx/dlambda = f(x, lambda) for lambda in (0, 1] with the
   field of sec 4 (eqs 41, 46; corrected, see :func:`pfrepro.flow.gaussian_flow_field`),
   whose coefficients use only the prior statistics of step 2-3;
5. the estimate is the mean of the moved particles (eq 51 applied to them).

No weights, no resampling. The paper integrates with Euler steps Delta lambda = 0.05;
``schedule``/``n_steps``/``integrator`` make that a choice. For a linear model
``integrator="exact"`` applies the exact solution of the affine flow
(:func:`pfrepro.flow.exact_affine_map`) instead of stepping.

The eq-43 field is affine in the state, so the chosen integrator's map over the whole
lambda grid is an affine map, fixed by d + 1 probe points and applied to all particles.
With a plain measurement residual that map is computed in closed form for every lambda at
once (:class:`pfrepro.flow.AffineField`, :func:`pfrepro.flow.affine_flow_map`); with a
residual that wraps angles (bearings), Euler steps of the probes use precomputed step maps
and a check that no angle wrapped between them (a run where one did is integrated with the
wrapping field itself), and RK stages step the wrapping field. Each is the stepped probe
integration up to rounding. For a scalar state and measurement with a plain residual (the
UNGM) the filter loop runs the same arithmetic on (runs, N) and (runs,) arrays in fewer numpy
calls, bit for bit the general loop's numbers. With per-run random streams and a Gaussian
transition each run's normals are drawn in blocks of time steps (the same numbers, and every
generator left where step-by-step draws leave it).
"""
from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from .. import flow
from ..models.base import StateSpaceModel, require_capabilities
from ..noise import GaussianNoise
from ..rng import RunStreams, take_runs
import warnings

from ..validation import as_finite_float, check_positive_int
from .base import DIVERGENCE_POLICIES, Filter, FilterDivergenceError, FilterDivergenceWarning, FilterResult
from .sigma_points import ScaledSigmaPoints, unscented_transform

#: the package's own integrate_flow (a wrapper put in its place, as pfrepro.cost's counting one,
#: sends the scalar filter through the general loop, where the probes are integrated)
_INTEGRATE_FLOW = flow.integrate_flow

__all__ = ["GaussianParticleFlowFilter", "particle_moments"]


def _particle_mean(x):
    """``x.mean(axis=1)`` of particles (runs, N, d), bit for bit: for d >= 2 numpy sums the
    strided particle axis one particle after the other, as ``einsum("rni->ri")`` does in a
    quarter of the time (d = 1: the mean itself, a pairwise sum along a contiguous axis)."""
    if x.shape[-1] == 1:
        return x.mean(axis=1)
    return np.einsum("rni->ri", x) / x.shape[1]


def _posterior_moments(x, full_cov=True):
    """``(m, P, var)``: :func:`particle_moments` and its covariance's diagonal, or with
    ``full_cov=False`` the mean and the variances alone, ``P = None`` (the same numbers: the
    diagonal of ``einsum("rni,rnj->rij")`` is ``einsum("rni,rni->ri")``, and halving
    ``P + P^T`` leaves the diagonal as it is), at a cost of d instead of d^2 sums."""
    if full_cov:
        m, P = particle_moments(x)
        return m, P, np.diagonal(P, axis1=-2, axis2=-1)
    m = _particle_mean(x)
    dev = x - m[:, None, :]
    return m, None, np.einsum("rni,rni->ri", dev, dev) / (x.shape[1] - 1)


def particle_moments(x):
    """Sample mean and covariance (1/(N-1)) of particles ``(runs, N, d)`` (eqs 51, 52)."""
    return _moments_dev(x)[:2]


def _moments_dev(x):
    """:func:`particle_moments` and the deviations ``x - m`` it computes on the way (the
    filter's update starts from the same array)."""
    x = np.asarray(x, float)
    if x.ndim != 3:
        raise ValueError(f"particles must be (runs, N, d), got shape {x.shape}")
    N = x.shape[1]
    if N < 2:
        raise ValueError("need at least 2 particles for a sample covariance")
    m = _particle_mean(x)
    d = x - m[:, None, :]
    if x.shape[-1] == 1:
        P = np.einsum("rni,rnj->rij", d, d) / (N - 1)
    else:
        # d >= 2: one BLAS product per run (einsum's sum over a strided particle axis costs
        # ten times as much); stacked, so a run's numbers do not depend on the batch
        P = (np.swapaxes(d, -1, -2) @ d) / (N - 1)
    S = P + np.swapaxes(P, -1, -2)
    S *= 0.5
    return m, S, d


@contextmanager
def _settled(blocks):
    """Settle ``blocks`` (a :class:`_NormalBlocks` or ``None``) however the block exits."""
    try:
        yield
    finally:
        if blocks is not None:
            blocks.settle()


class _NormalBlocks:
    """Per-run standard normals of a GPFF run drawn in blocks of time steps (one generator call
    per run and block instead of one per run and step).

    A GPFF run's only draws are standard normals of one size a step (the prior cloud, then the
    Gaussian transition noise), and a Generator's normals come one after the other, so serving
    step k's ``standard_normal(size)`` from a block drawn ahead gives the numbers the per-step
    call would have drawn, bit for bit. :meth:`settle` leaves every generator where the per-step
    calls would have left it: a run that stopped drawing (diverged) is rewound to its last
    block's start and advanced by the normals it used.
    """

    #: normals per block (all runs), about 8 MB
    BUDGET = 1 << 20

    def __init__(self, streams, per_step, n_draws):
        self._gens = list(streams)
        self._per_step, self._left = per_step, n_draws
        self._steps = max(1, self.BUDGET // max(1, len(self._gens) * per_step))
        # blocks of 8, 16, 32, ... steps (up to the budget): a run that stops drawing early (a diverged
        # run; with eq 41 most runs of the growth model stop within 20 steps) draws at most about as
        # many normals ahead as it used (plus 8 steps), redrawn once by settle(). One block of every
        # step drew a whole horizon ahead and made the eq-41 filter 40 % slower than step-by-step
        # draws; blocks from 1 step took a generator-state snapshot per run and block, 5 % of eq 43
        self._next = 8
        self._used = np.zeros(len(self._gens), dtype=np.int64)
        self._drawn = np.zeros(len(self._gens), dtype=np.int64)
        self._snap = [None] * len(self._gens)
        self._snap_at = np.zeros(len(self._gens), dtype=np.int64)
        self._buf, self._slot, self._rows = None, 0, None

    def take(self, alive):
        """The source of the runs ``alive`` (indices, increasing) for the next draw."""
        self._rows = None if len(alive) == len(self._gens) else alive
        return self

    def standard_normal(self, size, dtype=np.float64):
        runs = range(len(self._gens)) if self._rows is None else self._rows
        n = int(np.prod(size[1:], dtype=np.int64))
        if dtype != np.float64 or n != self._per_step or len(size) < 1 or size[0] != len(runs):
            raise ValueError(f"unexpected draw of shape {size} ({dtype}) in a GPFF run")
        if self._buf is None or self._slot == self._buf.shape[1]:
            steps = min(self._next, self._steps, self._left)
            self._next = 2 * steps
            if steps < 1:
                raise ValueError("more draws than the GPFF run makes")
            self._buf = np.empty((len(self._gens), steps, n))
            self._slot = 0
            for i in runs:
                g = self._gens[i]
                self._snap[i], self._snap_at[i] = g.bit_generator.state, self._drawn[i]
                g.standard_normal(out=self._buf[i].reshape(-1))
                self._drawn[i] += steps * n
        rows = self._buf[:, self._slot] if self._rows is None else self._buf[self._rows, self._slot]
        out = rows.reshape(size) if self._rows is not None else rows.copy().reshape(size)
        self._slot += 1
        self._left -= 1
        if self._rows is None:
            self._used += n
        else:
            self._used[self._rows] += n
        return out

    def settle(self):
        """Leave every generator where per-step draws would have (see the class docstring)."""
        for i in np.flatnonzero(self._drawn > self._used):
            g = self._gens[i]
            g.bit_generator.state = self._snap[i]
            k = int(self._used[i] - self._snap_at[i])
            if k:
                g.standard_normal(k)


class _WrapCheckedEuler(flow.AffineField):
    """The eq-43 field of a model whose residual may wrap (GPFF, Euler): called, it is the exact
    field ``exact`` (what a counting wrapper of :func:`pfrepro.flow.integrate_flow` steps);
    integrated, it takes Euler steps u -> u (I + h A_j) + h b_j of the field with plain
    subtraction (precomputed maps, two calls a step instead of ten), records the points where
    the field was evaluated and sets ``failed`` (per run) where the model's residual was not
    plain subtraction at one of them (an angle wrapped), for the caller to redo those runs with
    ``exact``. Where no angle wraps the two fields are the same function of the state, so the
    result is the exact field's up to rounding."""

    def __init__(self, A, b, origin, grid, stages, exact, base, JT, plain):
        super().__init__(A, b, origin, grid, "euler", stages=stages)
        self._exact, self._base, self._JT, self._plain = exact, base, JT, plain
        self.failed = None

    def __call__(self, z, lam):
        return self._exact(z, lam)

    def integrate(self, z, grid, method):
        if method != "euler" or (grid is not self.grid and not np.array_equal(grid, self.grid)):
            raise ValueError("this field is tabulated for Euler steps on its own grid")
        lams, index, hs, cols, _ = flow._plan(self.grid, "euler")
        d = self.A.shape[-1]
        n = len(hs)
        h = hs[:, None, None, None]
        # I + h A_j: 1 added on the diagonal in place (np.eye(d) + h A broadcasts a 4 x 4 block,
        # ten times slower; the same sums, 0 + a = a off the diagonal)
        M = h * self.A[cols[0]]                                  # (n, runs, d, d)
        M.reshape(-1, d * d)[:, ::d + 1] += 1.0
        v = h * self.b[cols[0]][:, :, None, :]                   # (n, runs, 1, d)
        o = self.origin[:, None, :]
        u = np.asarray(z, float) - o                             # (runs, K, d)
        runs, K = u.shape[:2]
        U = np.empty((runs, n, K, d))                            # the points the field is evaluated at
        for j in range(n):
            U[:, j] = u
            u = u @ M[j]
            u += v[j]
        hz = self._base[:, None] + (U.reshape(runs, -1, d) @ self._JT).reshape(runs, n, K, -1)
        self.failed = ~self._plain(hz)
        return o + u


class GaussianParticleFlowFilter(Filter):
    """Gaussian particle flow filter (Zhang, Zhou & Feng 2016, sec 4): unweighted particles moved by a Gaussian flow.

    Per step: propagate the particles (eq 1), their mean and covariance (eqs 51, 52), the
    unscented transform of that Gaussian through h (eqs 47-50), then integrate the flow
    dx/dlambda = B(lambda) h(x) + u(lambda) over lambda in (0, 1] (eq 41 with the
    coefficients of eq 46, corrected: :func:`pfrepro.flow.nonlinear_coefficients`); the
    estimate is the moved particles' mean (eq 51). For a linear model the flow is the
    affine one of eqs 13-27, which moves the mean exactly as the Kalman update does.

    Parameters
    ----------
    model : StateSpaceModel
        A model with additive measurement noise.
    n_particles : int
        N >= 2 (the paper: 100, and 500/1000 in Table 1).
    n_steps : int
        Number of lambda steps (the paper: 20, i.e. Delta lambda = 0.05).
    schedule : str
        "uniform" (the paper) or "exponential" (step ratio ``ratio``).
    ratio : float
        Ratio of consecutive steps of the exponential schedule.
    integrator : str
        "euler" (the paper), "midpoint", "rk4", or "exact" (linear models only).
    alpha, beta, kappa : float
        Scaled-UT parameters (not given in the paper; default alpha = 1, beta = 2,
        kappa = 0, as our UKF; exact for linear h and, with beta = 2, exact for the mean
        and variance of x^2/20 under a Gaussian).
    field : str
        "eq43" (default): h(x) replaced by its statistical linearisation
        y_hat + Pxy^T P^{-1} (x - mean) about the prior (the first-order expansion
        (42)-(43) with J P = Pxy^T, eq 44), an affine field; or "eq41": f = B h(x) + u
        with h evaluated at every particle (eq 41, the literal reading; the field is then
        nonlinear in x and for a quadratic h such as the UNG's the exact flow can blow up
        in finite lambda: it diverges in every run on ``UNGM.zhang2016()``). The two are
        identical for linear h (up to rounding). The default is the field the GPFF chapter
        uses for a nonlinear h, so defaults work on every model the package ships.
    on_divergence : str
        What to do with a run that diverges (the test, on the size of one flow update: its
        particles become non-finite, or it grows a component's particle variance more than
        ``max_growth`` times or moves the mean more than ``max_shift`` prior standard
        deviations; see ``_diverged``). "warn" (default): stop that run (its estimates are NaN
        from that step on), record the step in ``diagnostics["diverged_at"]`` (0 = never)
        and the count in ``diagnostics["n_diverged"]``, and emit one
        :class:`~pfrepro.filters.FilterDivergenceWarning` per call naming the count; the
        other runs are untouched, bit for bit. "drop": the same without the warning (for a
        caller that reports the count itself). "raise": ``FilterDivergenceError``.
    max_growth : float
        Divergence threshold (> 1): the largest factor by which one flow update may grow a
        component's particle variance. A Bayesian update does not spread the cloud (in the
        chapter's configurations the largest factor seen is 1.0); a blow-up starts with a
        factor of hundreds and overflows a few steps later.
    max_shift : float
        The largest move of the cloud's mean in one flow update, in prior standard
        deviations per component (default 1000; the chapter's configurations reach ~11).
    m0, P0 : array_like, optional
        Override the model's initial distribution N(m0, P0).
    return_cov : bool
        Also return the particles' sample covariance.

    Model methods
    -------------
    ``sample_transition`` (``f`` and the process noise; Q may be singular or zero),
    ``h``, ``residual_y``, ``R``, ``m0``, ``P0``; additive measurement noise
    y = h(x) + v (the flow is derived for a Gaussian likelihood N(y; h(x), R));
    ``integrator="exact"`` also a matrix ``H``. Another model raises
    :class:`~pfrepro.models.ModelContractError`.

    Notes
    -----
    ``filter(y, rng)``: ``y`` is ``(runs, T, dim_y)``, or ``(T,)`` for one scalar run,
    or ``(T, dim_y)`` for one run when ``dim_y > 1``; ``rng`` a Generator or RunStreams.
    """

    name = "GPFF"
    needs_rng = True
    model_requirements = ("transition_sampler", "additive_measurement")

    def __init__(self, model, n_particles: int = 100, n_steps: int = 20, schedule: str = "uniform",
                 ratio: float = 1.2, integrator: str = "euler", alpha: float = 1.0, beta: float = 2.0,
                 kappa: float = 0.0, field: str = "eq43", on_divergence: str = "warn",
                 max_growth: float = 100.0, max_shift: float = 1e3, m0=None, P0=None, return_cov: bool = False):
        super().__init__(model, m0, P0)
        if field not in ("eq41", "eq43"):
            raise ValueError(f"field must be 'eq41' or 'eq43', got {field!r}")
        if on_divergence not in DIVERGENCE_POLICIES:
            raise ValueError(f"on_divergence must be one of {DIVERGENCE_POLICIES}, got {on_divergence!r}")
        self.max_growth = as_finite_float(max_growth, "max_growth")
        if not self.max_growth > 1.0:
            raise ValueError(f"max_growth must be > 1, got {max_growth!r}")
        self.max_shift = as_finite_float(max_shift, "max_shift", positive=True)
        self.field, self.on_divergence = field, on_divergence
        self.n_particles = check_positive_int(n_particles, "n_particles")
        if self.n_particles < 2:
            raise ValueError("GPFF needs n_particles >= 2 (eq 52 divides by N - 1)")
        if integrator not in (*flow.INTEGRATORS, "exact"):
            raise ValueError(f"unknown integrator {integrator!r}; choose from "
                             f"{sorted(flow.INTEGRATORS) + ['exact']}")
        if integrator == "exact":
            require_capabilities(model, ("measurement_matrix",), "GaussianParticleFlowFilter(integrator='exact')")
        self.integrator = integrator
        self.schedule = schedule
        self.ratio = float(ratio)
        self.n_steps = check_positive_int(n_steps, "n_steps")
        self.grid = flow.lambda_schedule(self.n_steps, schedule, ratio)
        if integrator != "exact":
            # the lambdas the integrator visits (grid points, RK midpoints computed as the
            # integrator computes them) and each step's stages among them
            self._stages = flow.stage_lambdas(self.grid, integrator)
            self._lams = self._stages[0]
            self._lam_index = flow._plan(self.grid, integrator)[4]
        # a residual that is plain subtraction makes the eq-43 field affine in the state
        # (an angle wrap is not: the bearings-only model keeps integrating probe points)
        self._plain_residual = getattr(type(model), "residual_y", None) is StateSpaceModel.residual_y
        # how update finds the eq-43 map: in closed form (plain residual), by checked Euler steps
        # of the probes, or by integrating them with the wrapping field
        self._mode = "closed" if self._plain_residual else ("checked" if integrator == "euler" else "probes")
        self.points = ScaledSigmaPoints(model.dim_x, alpha, beta, kappa)
        # the eq-43 probes m + s * row: the mean, then one step of one prior sd along each axis
        self._probe_pattern = np.concatenate([np.zeros((1, model.dim_x)), np.eye(model.dim_x)])[None]
        self.return_cov = bool(return_cov)
        # a scalar state and measurement with a plain residual (the UNGM): :meth:`filter` runs the
        # eq-43 step on (runs, N) arrays (``_filter_scalar``), the same arithmetic in fewer calls
        self._scalar = (field == "eq43" and integrator != "exact" and self._plain_residual
                        and model.dim_x == 1 and model.dim_y == 1)

    def prior_statistics(self, x, moments=None):
        """Eqs (47)-(52): particle mean/cov, then UT moments y_hat, Pyy, Pxy of h.

        ``moments``: ``particle_moments(x)`` if the caller has it already (not recomputed).
        """
        m, P = particle_moments(x) if moments is None else moments
        if P.shape[-1] == 1:
            # d = 1: the Cholesky factor of the symmetrised 1 x 1 (n + lambda) P is its square
            # root (LAPACK's potrf takes the IEEE sqrt; zero, negative and NaN give 0, NaN and
            # NaN as safe_cholesky(on_error="nan") does): the same points without the
            # factorisation's per-call cost
            a = (self.points.n + self.points.lam) * P
            L = np.sqrt(0.5 * (a + a))
            sig = np.concatenate([m[:, None, :], m[:, None, :] + L, m[:, None, :] - L], axis=-2)
        else:
            sig = self.points.sigma_points(m, P, on_error="nan")  # (runs, 2d+1, d)
        Y = self.model.h(sig)                                      # (runs, 2d+1, m)
        y_hat, Pyy, dy = unscented_transform(Y, self.points.Wm, self.points.Wc,
                                             residual=self.model.residual_y)
        Pxy = np.einsum("i,rij,rik->rjk", self.points.Wc, sig - m[:, None, :], dy)
        return m, P, y_hat, 0.5 * (Pyy + np.swapaxes(Pyy, -1, -2)), Pxy

    def update(self, x, y, moments=None):
        """Move prior particles ``x`` (runs, N, d) to the posterior given ``y`` (runs, m).

        ``moments``: ``particle_moments(x)`` if the caller has it already (not recomputed).
        """
        return self._update(x, y, moments, self._mode)

    def _update_probes(self, x, y, moments=None):
        """:meth:`update` with the eq-43 map always found by integrating d + 1 probe points
        (the reference for the closed form, and the path of a model whose residual wraps)."""
        return self._update(x, y, moments, "probes")

    def _update(self, x, y, moments, mode, dev=None):
        """The update in ``mode`` ("closed", "checked" or "probes"); ``dev``: ``x - m`` of the
        moments if the caller has it (the same array :func:`particle_moments` computed; it is
        overwritten)."""
        model = self.model
        if self.integrator == "exact":
            m, P = particle_moments(x) if moments is None else moments
            m1, Phi = flow.exact_affine_map(m, P, model.H, model.R, y, 1.0)
            return m1[:, None, :] + (x - m[:, None, :]) @ np.swapaxes(Phi, -1, -2)
        m, P, y_hat, Pyy, Pxy = self.prior_statistics(x, moments)
        R, res = model.R, model.residual_y
        r = (lambda a, b: a - b) if res is None else res
        # G(lam), c(lam) do not depend on the particles: all the lambdas the integrator
        # visits (grid points, and RK midpoints computed as the integrator computes them)
        # in one batched call instead of one call per field evaluation; each lambda's
        # values are bit-identical to flow.flow_field_coefficients(lam, ...) alone
        G_all, c_all = flow.flow_field_coefficients(self._lams[:, None, None, None], y, y_hat, Pxy, Pyy, R,
                                                    residual=res)
        GT_all = np.swapaxes(G_all, -1, -2)                           # (L, runs, m, d)
        cN_all = c_all[:, :, None, :]                                 # (L, runs, 1, m)
        yN = y[:, None, :]
        at = self._lam_index

        # f = 1/2 [r(y, h(z)) + c] G^T, flow.field_from_coefficients with the transposes hoisted
        if self.field == "eq41":
            def field(z, lam):
                i = at[lam]
                return 0.5 * (r(yN, model.h(z)) + cN_all[i]) @ GT_all[i]

            return flow.integrate_flow(x, field, self.grid, self.integrator)

        # h(z) ~ y_hat + J (z - m), J = Pxy^T P^{-1}; innovations r(y, y_hat) - J (z - m)
        mN = m[:, None, :]
        if mode == "closed":
            # Plain residual: the field is (z - m) A(lam) + b(lam) with A = -1/2 J^T G^T,
            # b = 1/2 [(y - y_hat) + c] G^T, and flow.integrate_flow computes the integrator's
            # map over the whole grid in closed form for every lambda at once
            # (flow.AffineField, flow.affine_flow_map) instead of stepping the probes through
            # 20-80 stages. With a scalar measurement (m = 1) the products over m are products
            # of scalars (the same numbers as a matmul with inner dimension 1); d = 1: P^{-1}
            # is a division.
            JT = flow._solve_sym(P, Pxy)                              # P^{-1} Pxy = J^T (runs, d, m)
            mm_y = np.multiply if Pxy.shape[-1] == 1 else np.matmul
            A_all = -0.5 * mm_y(JT, GT_all)                           # (L, runs, d, d)
            b_all = (0.5 * mm_y((yN - y_hat[:, None, :]) + cN_all, GT_all))[..., 0, :]   # (L, runs, d)
            field = flow.AffineField(A_all, b_all, m, self.grid, self.integrator, stages=self._stages)
        else:
            J = np.swapaxes(flow.solve_per_run(P, Pxy), -1, -2)       # (runs, m, d)
            JT = np.swapaxes(J, -1, -2)
            base = (y - model.residual_y(y, y_hat))[:, None, :]
            hGT_all = 0.5 * GT_all                                    # 1/2 G^T at every lambda

            def field(z, lam):
                i = at[lam]
                hz = base + (z - mN) @ JT
                # the model's residual (angles wrap) in every innovation term, as in eq 41
                return (r(yN, hz) + cN_all[i]) @ hGT_all[i]

            if mode == "checked":
                # Euler steps of the field with plain subtraction in place of the residual, the
                # steps' maps precomputed, then a check that the model's residual was plain
                # subtraction at every point the field was evaluated (no angle wrapped between
                # the probes); the runs where it was not are redone with ``field`` itself
                A_all = -(JT @ hGT_all)                                # (L, runs, d, d)
                b_all = (((yN - base) + cN_all) @ hGT_all)[..., 0, :]  # (L, runs, d)

                def plain(hz):
                    e = yN[:, None] - hz
                    dev = r(yN[:, None], hz)
                    dev -= e
                    np.abs(dev, out=dev)
                    if dev.max() <= 1e-9:     # within the tolerance everywhere (NaN fails this)
                        return np.ones(len(hz), dtype=bool)
                    return np.all(dev <= 1e-9 * (1.0 + np.abs(e)), axis=(1, 2, 3))

                field = _WrapCheckedEuler(A_all, b_all, m, self.grid, self._stages, field, base, JT, plain)

        # The field is affine in z (where an angle wrap does not act), so the integrator's map
        # over the whole grid is an affine map z -> c + M (z - m): move d + 1 probe points, not
        # N particles (identical to stepping every particle, up to rounding), and read it off.
        s = np.sqrt(np.diagonal(P, axis1=-2, axis2=-1))               # (runs, d)
        probes = mN + self._probe_pattern * s[:, None, :]             # (runs, d+1, d)
        out = flow.integrate_flow(probes, field, self.grid, self.integrator)
        c = out[:, 0]
        MT = (out[:, 1:] - c[:, None, :]) / s[:, :, None]             # M^T (runs, d, d)
        u = x - mN if dev is None else dev
        if MT.shape[-1] == 1:
            # d = 1: a product of scalars (numpy's multiply, the same number as the 1 x 1
            # matmul), in place, as is the shift (the same sum c + u M^T)
            u *= MT
        else:
            u = u @ MT
        u += c[:, None, :]
        redo = getattr(field, "failed", None)
        if redo is not None and redo.any():    # an angle wrapped between the probes: exactly
            u[redo] = self._update(x[redo], y[redo], (m[redo], P[redo]), "probes")
        return u

    def _diverged(self, x, m_prior, P_prior, full_cov=True):
        """Per-run divergence test on the flow's size (the one test, see the class docstring).

        A run has diverged when its moved particles are non-finite, when the flow grew a
        component's particle variance by more than ``max_growth`` times its prior value, or
        moved the cloud's mean by more than ``max_shift`` prior standard deviations. The
        measurement update of a Bayesian filter does not spread the cloud (for a linear
        Gaussian model the posterior covariance P - K S K^T never exceeds the prior), so a
        growth of 100x in one update is the flow running away, the step where a blow-up
        starts (then 1e4x, 1e11x, ... until overflow); a shift of 1000 prior standard
        deviations is an innovation the model gives no probability (an outlier such as
        y = 1e200), which would otherwise pass on a huge finite estimate. In the GPFF
        chapter's configurations the largest values are a growth of 1.0 and a shift of
        about 11 standard deviations. Each run is judged on its own values. Returns the
        per-run verdict and the moved particles' moments ``(m, P)`` computed on the way
        (``P`` is ``None`` unless ``full_cov``: the test needs only the variances).
        """
        m, P, var = _posterior_moments(x, full_cov)
        # non-finite particles make the mean or a variance non-finite (NaN or inf in a sum), and
        # finite particles whose mean or variance overflows are caught by the growth/shift tests
        # anyway: the verdict is that of testing every particle, without a pass over them all
        bad = ~np.isfinite(m).all(axis=1)
        bad |= ~np.isfinite(var).all(axis=1)
        prior = np.maximum(np.diagonal(P_prior, axis1=-2, axis2=-1), np.finfo(float).tiny)
        bad |= (var > self.max_growth * prior).any(axis=1)
        shift = m - m_prior
        shift *= shift
        bad |= (shift > self.max_shift**2 * prior).any(axis=1)
        return bad, (m, P)

    def _drop_diverged(self, k, alive, bad, x, diverged_at):
        """The runs still alive and their particles once the runs ``bad`` diverged at step ``k``
        (recorded in ``diverged_at``); with ``on_divergence='raise'`` the error instead."""
        if self.on_divergence == "raise":
            raise FilterDivergenceError(
                f"GPFF diverged at step {k} in runs {alive[bad][:10].tolist()} (particles "
                f"non-finite, or the flow grew a variance more than {self.max_growth:g}x or "
                f"moved the mean more than {self.max_shift:g} prior sd); "
                f"on_divergence='warn' keeps the other runs")
        diverged_at[alive[bad]] = k
        return alive[~bad], x[~bad]

    def filter(self, y, rng: np.random.Generator | None = None) -> FilterResult:
        y = self._prepare(y, rng)
        if self._scalar and flow.integrate_flow is _INTEGRATE_FLOW:
            # (a wrapped integrate_flow, e.g. pfrepro.cost counting the flow, sees the probe
            # integration of the general loop)
            return self._filter_scalar(y, rng)
        runs, T, _ = y.shape
        n = self.model.dim_x
        # per-run streams: the normals of a run drawn in blocks of steps (bit for bit the same)
        blocks = self._normal_blocks(rng, T)
        x = self.sample_prior(rng if blocks is None else blocks.take(np.arange(runs)), (runs, self.n_particles))
        xs = np.full((runs, T, n), np.nan)
        Ps = np.full((runs, T, n, n), np.nan) if self.return_cov else None
        alive = np.arange(runs)              # runs still being filtered
        diverged_at = np.zeros(runs, dtype=int)
        with np.errstate(all="ignore"), _settled(blocks):
            for k in range(1, T + 1):
                # runs that diverged no longer draw; the others keep their own streams
                x = self.model.sample_transition(x, k, blocks.take(alive) if blocks is not None else
                                                 take_runs(rng, alive) if len(alive) < runs else rng)
                # Each run's fate depends on its own particles only (pfrepro.rng rule 3), and
                # every batched linear-algebra call of the update works matrix by matrix
                # (flow.solve_per_run, safe_cholesky(on_error="nan")): a diverging run never
                # changes another run's numbers. A cloud whose covariance overflows cannot be
                # moved (eq 52): diverged in the prediction; then the flow's growth test.
                m_prior, P_prior, dev = _moments_dev(x)
                bad = ~np.isfinite(P_prior.reshape(len(alive), -1)).all(axis=1)
                if not bad.any():
                    # update(), starting from the deviations the moments computed
                    x_new = self._update(x, y[alive, k - 1], (m_prior, P_prior), self._mode, dev)
                else:
                    x_new = np.full_like(x, np.nan)
                    if (~bad).any():
                        x_new[~bad] = self.update(x[~bad], y[alive[~bad], k - 1])
                failed, post = self._diverged(x_new, m_prior, P_prior, full_cov=Ps is not None)
                bad |= failed
                x = x_new
                if bad.any():
                    alive, x = self._drop_diverged(k, alive, bad, x, diverged_at)
                    if alive.size == 0:
                        break
                if bad.any():    # the survivors' moments, recomputed on their own array
                    post = _posterior_moments(x, Ps is not None)[:2]
                # (the mean of particle_moments is x.mean(axis=1), the same call on the same array)
                xs[alive, k - 1] = post[0]
                if Ps is not None:
                    Ps[alive, k - 1] = post[1]
        return self._result(xs, Ps, diverged_at, runs, stacklevel=3)

    def _normal_blocks(self, rng, T):
        """A :class:`_NormalBlocks` for per-run streams when the run's draws are the prior's and
        the model's Gaussian transition noise only (else ``None``: the streams draw step by step)."""
        model = self.model
        noise = getattr(model, "process_noise", None)
        if (not isinstance(rng, RunStreams) or type(self).sample_prior is not Filter.sample_prior
                or getattr(type(model), "sample_transition", None) is not StateSpaceModel.sample_transition
                or type(noise) is not GaussianNoise or noise.is_zero or noise.dim != model.dim_x):
            return None
        return _NormalBlocks(rng, self.n_particles * model.dim_x, T + 1)

    def _filter_scalar(self, y, rng):
        """:meth:`filter` for d = m = 1 and a plain residual, bit for bit: the same numbers, each
        computed by the same numpy operation on the same values, on (runs, N) and (runs,) arrays
        instead of (runs, N, 1) and (runs, 1, 1) ones and with the flow's map written out for a
        scalar, so that a time step costs about half the calls (at N = 100 the calls on small
        per-run arrays, not the particles, are most of the time). Pinned against the general
        loop in ``tests/test_gpff_fast.py``."""
        model = self.model
        runs, T, _ = y.shape
        N = self.n_particles
        blocks = self._normal_blocks(rng, T)
        x = self.sample_prior(rng if blocks is None else blocks.take(np.arange(runs)), (runs, N))
        xs = np.full((runs, T, 1), np.nan)
        Ps = np.full((runs, T, 1, 1), np.nan) if self.return_cov else None
        alive = np.arange(runs)
        diverged_at = np.zeros(runs, dtype=int)
        pts = self.points
        R = model.R                               # (1, 1)
        lams, index, hs, cols, _ = flow._plan(self.grid, self.integrator)
        euler = self.integrator == "euler"
        # constants of _update_scalar: (n + lambda) of the sigma points, the UT weights, R, the
        # stage lambdas and steps as rows, the Euler steps times 1/2 and -1/2, the probe pattern
        sc = [pts.n + pts.lam, pts.Wm, pts.Wc, R[0], R[..., 0, :], self._lams[None, :], hs[None, :],
              0.5 * hs[None, :] if euler else None, -0.5 * hs[None, :] if euler else None, cols,
              self._probe_pattern[0, :, 0]]
        growth, shift2 = self.max_growth, self.max_shift**2
        tiny = np.finfo(float).tiny
        # a prior variance below p_fast keeps the divergence thresholds (and (n + lambda) P + itself)
        # finite
        big = np.finfo(float).max / 4
        p_fast = big / max(growth, shift2, 1.0)
        sc.append(pts.n + pts.lam <= 1.0 and p_fast <= big)   # (n + lambda) P + itself stays finite
        with np.errstate(all="ignore"), _settled(blocks):
            for k in range(1, T + 1):
                x = model.sample_transition(x, k, blocks.take(alive) if blocks is not None else
                                            take_runs(rng, alive) if len(alive) < runs else rng)
                xv = x[..., 0]
                # eqs 51, 52 (particle_moments): the mean, the deviations, 1/(N-1) sum of squares
                m = np.add.reduce(xv, 1) / N
                dev = xv - m[:, None]
                P = np.einsum("rn,rn->r", dev, dev) / (N - 1)
                P += P                          # the symmetrised 1 x 1 covariance: (P + P^T) / 2
                P *= 0.5
                yk = y[alive, k - 1, 0] if len(alive) < runs else y[:, k - 1, 0]
                if (P < p_fast).all():
                    # every prior variance finite and below p_fast, so growth * prior and
                    # shift^2 * prior are finite: then "not (value <= threshold)" is the test of
                    # _diverged (a NaN or infinite mean makes the squared shift NaN or infinite, a
                    # NaN or infinite variance fails its comparison), in a third of the calls
                    u = self._update_scalar(dev, m, P, yk, sc)
                    m1 = np.add.reduce(u, 1) / N
                    d1 = u - m1[:, None]
                    var = np.einsum("rn,rn->r", d1, d1) / (N - 1)
                    if Ps is not None:          # the full covariance's diagonal, symmetrised
                        var += var
                        var *= 0.5
                    prior = np.maximum(P, tiny)
                    good = var <= growth * prior
                    sh = m1 - m
                    sh *= sh
                    good &= sh <= shift2 * prior
                    bad = ~good
                else:
                    bad = ~np.isfinite(P)
                    x_new = np.full_like(x, np.nan)
                    if (~bad).any():
                        x_new[~bad] = self.update(x[~bad], y[alive[~bad], k - 1])
                    u = x_new[..., 0]
                    # the divergence test (_diverged) on the moved particles' mean and variances
                    m1 = np.add.reduce(u, 1) / N
                    d1 = u - m1[:, None]
                    var = np.einsum("rn,rn->r", d1, d1) / (N - 1)
                    if Ps is not None:
                        var += var
                        var *= 0.5
                    bad |= ~np.isfinite(m1)
                    bad |= ~np.isfinite(var)
                    prior = np.maximum(P, tiny)
                    bad |= var > growth * prior
                    sh = m1 - m
                    sh *= sh
                    bad |= sh > shift2 * prior
                x = u[..., None]
                if bad.any():
                    alive, x = self._drop_diverged(k, alive, bad, x, diverged_at)
                    if alive.size == 0:
                        break
                    m1, _, var = _posterior_moments(x, Ps is not None)
                    m1, var = m1[:, 0], var[:, 0]
                if len(alive) < runs:
                    xs[alive, k - 1, 0] = m1
                    if Ps is not None:
                        Ps[alive, k - 1, 0, 0] = var
                else:
                    xs[:, k - 1, 0] = m1
                    if Ps is not None:
                        Ps[:, k - 1, 0, 0] = var
        return self._result(xs, Ps, diverged_at, runs, stacklevel=4)

    def _update_scalar(self, dev, m, P, y, sc):
        """The eq-43 update of :meth:`update` for d = m = 1 and a plain residual (see
        :meth:`_filter_scalar`): ``dev`` (runs, N) the prior deviations x - m (overwritten and
        returned as the moved particles), ``m``, ``P``, ``y`` (runs,). Every number is the one
        the general path computes (same operation, same operands, same order), except that for
        Euler the factors 1/2 of A and b are moved onto the step h (a product with 1/2 is exact,
        so h (1/2 w) and (h/2) w are the same number for normal floats)."""
        c_sig, Wm, Wc, R0, Rr, lam_row, h_row, hh_row, hneg_row, cols, pat, sqrt_a = sc
        runs = m.shape[0]
        # sigma points m, m + L, m - L, L the square root of the symmetrised (n + lambda) P
        a = c_sig * P
        # (with P below p_fast and n + lambda <= 1, a + a cannot overflow: 0.5 (a + a) is a itself)
        L = np.sqrt(a) if sqrt_a else np.sqrt(0.5 * (a + a))
        sig = np.empty((runs, 3, 1))
        sv = sig[:, :, 0]
        sv[:, 0] = m
        np.add(m, L, out=sv[:, 1])
        np.subtract(m, L, out=sv[:, 2])
        Y = self.model.h(sig)                                       # (runs, 3, 1)
        # unscented_transform and the cross covariance (eqs 47-50), the same einsums
        y_hat = np.einsum("i,...ij->...j", Wm, Y)[:, 0]
        dy = Y - y_hat[:, None, None]
        Pyy = np.einsum("i,...ij,...ik->...jk", Wc, dy, dy)[:, 0, 0]
        Pxy = np.einsum("i,rij,rik->rjk", Wc, sig - m[:, None, None], dy)[:, 0, 0]
        Pyy = 0.5 * (Pyy + Pyy)
        # flow_field_coefficients at every stage lambda, laid out (runs, L): S = lam Pyy + R,
        # G = Pxy / S, c = R (y - y_hat) / S; A = -1/2 J^T G^T, b = 1/2 [(y - y_hat) + c] G^T
        S = Pyy[:, None] * lam_row
        S += R0
        G = Pxy[:, None] / S
        e = (y - y_hat)[:, None]
        w = e / S
        w *= Rr                                                     # c
        w += e                                                      # (y - y_hat) + c
        w *= G
        JT = Pxy / P
        if hneg_row is not None:
            # Euler: the steps' maps M_j = 1 + h A_j, v_j = h b_j (flow._step_maps), the 1/2 on h
            M = JT[:, None] * G
            M *= hneg_row
            M += 1.0
            v = w
            v *= hh_row
        else:
            A = JT[:, None] * G
            A *= -0.5
            w *= 0.5
            Mt, vt_ = flow._step_maps(A.T, w.T, h_row.T, cols, self.integrator, np.multiply, 1.0)
            M, v = Mt.T, vt_.T
        # flow.affine_flow_map for d = 1: suffix products, then the sum over the steps along a
        # contiguous axis (a fresh (runs, n - 1) array, as the general path's copy)
        Sfx = np.cumprod(M[:, ::-1], axis=1)[:, ::-1]
        vt = (v[:, :-1] * Sfx[:, 1:]).sum(axis=-1)
        vt += v[:, -1]
        # the two probes m + 0 s, m + s through the map (AffineField.integrate), and M^T, c read
        # off them as in update
        s = np.sqrt(P)
        mc = m[:, None]
        probes = mc + pat * s[:, None]                              # (runs, 2)
        probes -= mc
        probes *= Sfx[:, :1]
        probes += mc
        probes += vt[:, None]
        c0 = probes[:, 0]
        MT = probes[:, 1] - c0
        MT /= s
        dev *= MT[:, None]
        dev += c0[:, None]
        return dev

    def _result(self, xs, Ps, diverged_at, runs, stacklevel):
        """The filter's result, with the divergence warning (``on_divergence='warn'``) pointed at the
        caller of ``filter`` (``stacklevel`` counts from here)."""
        n_div = int((diverged_at > 0).sum())
        if n_div and self.on_divergence == "warn":
            warnings.warn(FilterDivergenceWarning(
                f"GPFF: {n_div} of {runs} runs diverged (first at step {int(diverged_at[diverged_at > 0].min())}); "
                f"their estimates are NaN from the step in diagnostics['diverged_at'] on. "
                f"Count them beside any error statistic (on_divergence='drop' silences this warning, "
                f"'raise' makes it an error)"), stacklevel=stacklevel)
        return FilterResult(xs, Ps, diagnostics={"diverged_at": diverged_at, "n_diverged": n_div})

    def __repr__(self) -> str:
        return (f"GaussianParticleFlowFilter(N={self.n_particles}, n_steps={self.n_steps}, "
                f"schedule={self.schedule!r}, integrator={self.integrator!r}, field={self.field!r})")
