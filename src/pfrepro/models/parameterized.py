"""State-space models with an unknown static parameter θ, evaluated for many θ at once.

    x_k = f(x_{k-1}, k, θ) + w_{k-1},   w ~ N(0, Q)   (Q may be zero: deterministic dynamics)
    y_k = h(x_k) + v_k,                 v ~ N(0, R)

A parameter filter scores hundreds of θ values per step, so every function takes a
*parameter axis* next to the particle axis and broadcasts: ``x`` has shape
``(..., dim_x)`` and ``theta`` shape ``(..., dim_theta)`` with broadcast-compatible
leading axes, e.g. ``x (runs, 1, dim_x)`` (one state estimate per run) against
``theta (runs, N_theta, dim_theta)`` gives ``(runs, N_theta, dim_x)`` predictions in one
call, without a Python loop. The prior support of θ is the box ``bounds`` ([r_l, r_u] of
Hou & Yin 2008, sec 3.2).

:meth:`~pfrepro.models.ParameterizedModel.at` fixes θ and returns an ordinary
:class:`~pfrepro.models.base.StateSpaceModel`, so every existing filter (KF, EKF, PF,
grid filter) runs on the model with θ known.
"""
from __future__ import annotations

import numpy as np

from ..rng import check_rng
from ..validation import as_finite_float, check_positive_int
from .base import Simulation, StateSpaceModel, batch_matmul, draw_noise, init_noise_and_prior

__all__ = ["ParameterizedModel", "FixedParameterModel", "as_theta"]


def as_theta(theta, dim_theta: int, name: str = "theta") -> np.ndarray:
    """``theta`` as a float array with a trailing axis of length ``dim_theta``; finite values only."""
    if isinstance(theta, (str, bytes)):
        raise TypeError(f"{name} must be a number or an array of numbers, got the string {theta!r}")
    try:
        t = np.asarray(theta, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a number or an array of numbers, got {theta!r}") from None
    if t.ndim == 0:
        t = t[None]
    if t.shape[-1] != dim_theta:
        raise ValueError(f"{name} must have a trailing axis of length dim_theta = {dim_theta}, got shape {t.shape}")
    if not np.all(np.isfinite(t)):
        raise ValueError(f"{name} contains non-finite values")
    return t


class ParameterizedModel:
    """Additive-Gaussian model whose transition depends on a static parameter θ (module docstring).

    Subclasses implement :meth:`f`, :meth:`jacobian_f` (∂f/∂x, ``(..., dim_x, dim_x)``),
    :meth:`jacobian_f_theta` (∂f/∂θ, ``(..., dim_x, dim_theta)``), :meth:`h` and
    :meth:`jacobian_h`.

    Parameters
    ----------
    dim_x, dim_y, dim_theta : int
        Dimensions of the state, the measurement and the parameter.
    Q : ndarray
        Process-noise covariance; singular or zero allowed (zero: no noise is drawn).
    R : ndarray
        Measurement-noise covariance (positive definite).
    x0 : ndarray
        The truth's initial state (``truth_init="fixed"``) — ignored for ``"prior"``.
    m0, P0 : ndarray
        The filters' initial distribution N(m0, P0) (the truth's too for ``"prior"``).
    theta_true : float or ndarray
        The true parameter used by :meth:`simulate`.
    bounds : tuple of float
        (r_l, r_u), the prior support of θ (scalar θ) — required by the Beta filter.
    """

    name = "parameterised model"

    def __init__(self, dim_x, dim_y, dim_theta, Q, R, x0, m0, P0, theta_true, bounds, truth_init="fixed"):
        init_noise_and_prior(self, dim_x, dim_y, Q, R, x0, m0, P0, truth_init)
        self.dim_theta = check_positive_int(dim_theta, "dim_theta")
        self.theta_true = as_theta(theta_true, self.dim_theta, "theta_true")
        try:
            pair = tuple(bounds)
        except TypeError:
            raise TypeError(f"bounds must be a pair (r_l, r_u) of numbers, got {bounds!r}") from None
        if len(pair) != 2:
            raise ValueError(f"bounds must be a pair (r_l, r_u) of numbers, got {bounds!r}")
        lo, hi = as_finite_float(pair[0], "bounds[0]"), as_finite_float(pair[1], "bounds[1]")
        if not hi > lo:
            raise ValueError(f"bounds must be finite with r_l < r_u, got {bounds}")
        self.bounds = (lo, hi)
        if np.any(self.theta_true < lo) or np.any(self.theta_true > hi):
            raise ValueError(f"theta_true = {self.theta_true.tolist()} lies outside bounds = {self.bounds} "
                             "(the prior support of theta)")
        self.has_process_noise = bool(np.any(self.Q != 0.0))

    # the same covariances a Gaussian filter is given as StateSpaceModel's (set by init_noise_and_prior)
    Q = StateSpaceModel.Q
    R = StateSpaceModel.R

    # -- to be implemented ------------------------------------------------------------
    def f(self, x, k, theta):
        """Noise-free transition x_{k-1} -> x_k under θ, broadcast over leading axes."""
        raise NotImplementedError

    def jacobian_f(self, x, k, theta):
        """∂f/∂x, shape ``(..., dim_x, dim_x)``."""
        raise NotImplementedError

    def jacobian_f_theta(self, x, k, theta):
        """∂f/∂θ, shape ``(..., dim_x, dim_theta)``."""
        raise NotImplementedError

    def h(self, x):
        """Measurement function h(x), batched over leading axes."""
        raise NotImplementedError

    def jacobian_h(self, x):
        """Jacobian of h at ``x``, ``(..., dim_y, dim_x)``."""
        raise NotImplementedError

    def residual_y(self, y, y_pred):
        """Measurement residual y - y_pred."""
        return y - y_pred

    # -- derived ------------------------------------------------------------------------
    def sample_transition(self, x, k, theta, rng):
        """Draw x_k ~ p(x_k | x_{k-1} = x, θ); the runs axis of ``x`` comes first in every draw."""
        out = self.f(x, k, theta)
        if self.has_process_noise:
            out = out + draw_noise(self.process_noise, rng, out.shape[:-1])
        return out

    def log_likelihood(self, y, x):
        """log p(y | x) for ``y`` (runs, dim_y) broadcast over the particle axes of ``x`` (runs, ..., dim_x)."""
        y = np.asarray(y, dtype=float)
        y = y.reshape(y.shape[:1] + (1,) * (x.ndim - 2) + y.shape[1:])
        return self.measurement_noise.logpdf(self.residual_y(y, self.h(x)))

    def sample_initial(self, rng, shape):
        """Draws from N(m0, P0) of the given ``shape`` (trailing axis dim_x)."""
        shape = tuple(np.atleast_1d(shape))
        z = rng.standard_normal(shape + (self.dim_x,))
        return self.m0 + batch_matmul(z, np.linalg.cholesky(self.P0))

    def simulate(self, T: int, runs: int = 1, rng=None, theta=None) -> Simulation:
        """Simulate ``runs`` trajectories under ``theta`` (default ``theta_true``), all runs at once."""
        T = check_positive_int(T, "T")
        runs = check_positive_int(runs, "runs")
        check_rng(rng)
        theta = self.theta_true if theta is None else as_theta(theta, self.dim_theta)
        theta = np.broadcast_to(theta, (runs, self.dim_theta))
        x = np.empty((runs, T + 1, self.dim_x))
        y = np.empty((runs, T, self.dim_y))
        x[:, 0] = self.x0 if self.truth_init == "fixed" else self.sample_initial(rng, runs)
        for k in range(1, T + 1):
            x[:, k] = self.sample_transition(x[:, k - 1], k, theta, rng)
            y[:, k - 1] = self.h(x[:, k]) + draw_noise(self.measurement_noise, rng, runs)
        return Simulation(x=x, y=y)

    def at(self, theta) -> "FixedParameterModel":
        """This model with θ fixed, as an ordinary ``StateSpaceModel`` (for KF/EKF/PF/grid filters)."""
        return FixedParameterModel(self, theta)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(dim_x={self.dim_x}, dim_theta={self.dim_theta}, bounds={self.bounds})"


class FixedParameterModel(StateSpaceModel):
    """A :class:`ParameterizedModel` with θ fixed: the ordinary state-space model it defines."""

    def __init__(self, pmodel: ParameterizedModel, theta):
        self.pmodel = pmodel
        self.theta = as_theta(theta, pmodel.dim_theta)
        if self.theta.ndim != 1:
            raise ValueError("FixedParameterModel needs one parameter vector")
        self.name = f"{pmodel.name} (θ = {self.theta.tolist()})"
        super().__init__(pmodel.dim_x, pmodel.dim_y, pmodel.Q, pmodel.R, pmodel.x0, pmodel.m0, pmodel.P0,
                         truth_init=pmodel.truth_init)

    def f(self, x, k):
        return self.pmodel.f(x, k, self.theta)

    def jacobian_f(self, x, k):
        return self.pmodel.jacobian_f(x, k, self.theta)

    def h(self, x):
        return self.pmodel.h(x)

    def jacobian_h(self, x):
        return self.pmodel.jacobian_h(x)

    def sample_transition(self, x, k, rng):
        return self.pmodel.sample_transition(x, k, self.theta, rng)
