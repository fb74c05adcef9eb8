"""Continuous-time dynamics dx/dt = a(x, t, θ), sampled every ``dt`` by fixed-step RK4.

The discrete transition of a :class:`ContinuousParameterizedModel` is the classical
fourth-order Runge–Kutta map Φ_θ with ``n_substeps`` equal steps of size
``dt / n_substeps`` between samples,

    x_k = Φ_θ(x_{k-1}, t_{k-1}) (+ w_{k-1}),    t_k = k dt,

vectorised over every leading axis (runs, particles, parameter values): one RK4 stage
is one call of ``a`` on the whole batch.

**Jacobian.** The EKF and the dual EKF need ∂Φ/∂x and ∂Φ/∂θ. We integrate the
*variational equations*

    dΦ_x/dt = A_x Φ_x,   Φ_x(0) = I;      dS/dt = A_x S + A_θ,   S(0) = 0,

(A_x = ∂a/∂x, A_θ = ∂a/∂θ) with the same RK4 steps, stage by stage, alongside x.
Because Runge–Kutta methods commute with linearisation, this is *exactly* the
derivative of the discrete RK4 map (not an approximation of the flow's derivative),
so the EKF linearises the very map the filter propagates; the tests check it against
central finite differences of :func:`rk4_integrate`.
"""
from __future__ import annotations

import numpy as np

from ..validation import check_positive_int
from .parameterized import ParameterizedModel

__all__ = ["rk4_integrate", "rk4_integrate_variational", "ContinuousParameterizedModel"]


def rk4_integrate(a, x, t0: float, dt: float, n_substeps: int, theta):
    """Integrate dx/dt = a(x, t, θ) from t0 to t0 + dt by ``n_substeps`` classical RK4 steps.

    ``x`` (..., dim_x) and ``theta`` (..., dim_theta) broadcast; returns the state at t0 + dt.
    """
    n = check_positive_int(n_substeps, "n_substeps")
    hstep = float(dt) / n
    t = float(t0)
    x = np.asarray(x, dtype=float)
    for _ in range(n):
        k1 = a(x, t, theta)
        k2 = a(x + 0.5 * hstep * k1, t + 0.5 * hstep, theta)
        k3 = a(x + 0.5 * hstep * k2, t + 0.5 * hstep, theta)
        k4 = a(x + hstep * k3, t + hstep, theta)
        x = x + (hstep / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        t += hstep
    return x


def rk4_integrate_variational(a, a_x, a_theta, x, t0: float, dt: float, n_substeps: int, theta):
    """RK4 for x together with its sensitivities (module docstring).

    Returns ``(x1, Fx, Ftheta)``: the state at t0 + dt, ∂x1/∂x0 ``(..., dim_x, dim_x)`` and
    ∂x1/∂θ ``(..., dim_x, dim_theta)`` — the exact derivatives of the RK4 map.
    """
    n = check_positive_int(n_substeps, "n_substeps")
    hstep = float(dt) / n
    t = float(t0)
    x = np.asarray(x, dtype=float)
    theta = np.asarray(theta, dtype=float)
    shape = np.broadcast_shapes(x.shape[:-1], theta.shape[:-1])
    x = np.broadcast_to(x, shape + x.shape[-1:]).copy()
    dx, dp = x.shape[-1], theta.shape[-1]
    # J = [Φ_x | S], (..., dim_x, dim_x + dim_theta)
    J = np.zeros(shape + (dx, dx + dp))
    J[..., :dx, :dx] = np.eye(dx)

    def stage(xs, Js, ts):
        ax = a_x(xs, ts, theta)
        dJ = ax @ Js
        dJ[..., dx:] += np.broadcast_to(a_theta(xs, ts, theta), shape + (dx, dp))
        return a(xs, ts, theta), dJ

    for _ in range(n):
        k1, j1 = stage(x, J, t)
        k2, j2 = stage(x + 0.5 * hstep * k1, J + 0.5 * hstep * j1, t + 0.5 * hstep)
        k3, j3 = stage(x + 0.5 * hstep * k2, J + 0.5 * hstep * j2, t + 0.5 * hstep)
        k4, j4 = stage(x + hstep * k3, J + hstep * j3, t + hstep)
        x = x + (hstep / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        J = J + (hstep / 6.0) * (j1 + 2.0 * j2 + 2.0 * j3 + j4)
        t += hstep
    return x, J[..., :dx], J[..., dx:]


class ContinuousParameterizedModel(ParameterizedModel):
    """A :class:`~pfrepro.models.parameterized.ParameterizedModel` whose transition is RK4 of dx/dt = a(x, t, θ) (module docstring).

    Subclasses implement :meth:`a`, :meth:`a_x` (∂a/∂x) and :meth:`a_theta` (∂a/∂θ).

    Parameters
    ----------
    dt : float
        Sampling interval.
    n_substeps : int
        RK4 steps per sampling interval.
    **kwargs
        Other parameters as :class:`~pfrepro.models.parameterized.ParameterizedModel`.
    """

    def __init__(self, *args, dt: float = 1.0, n_substeps: int = 64, **kwargs):
        super().__init__(*args, **kwargs)
        self.dt = float(dt)
        if not self.dt > 0:
            raise ValueError(f"dt must be > 0, got {dt}")
        self.n_substeps = check_positive_int(n_substeps, "n_substeps")

    def a(self, x, t, theta):
        """The drift a(x, t, θ) of dx/dt = a(x, t, θ), batched over leading axes."""
        raise NotImplementedError

    def a_x(self, x, t, theta):
        """The drift's Jacobian ∂a/∂x, ``(..., dim_x, dim_x)``."""
        raise NotImplementedError

    def a_theta(self, x, t, theta):
        """The drift's Jacobian ∂a/∂θ, ``(..., dim_x, dim_theta)``."""
        raise NotImplementedError

    def f(self, x, k, theta):
        return rk4_integrate(self.a, x, (k - 1) * self.dt, self.dt, self.n_substeps, theta)

    def f_and_jacobians(self, x, k, theta):
        """(f, ∂f/∂x, ∂f/∂θ) in one variational integration."""
        return rk4_integrate_variational(self.a, self.a_x, self.a_theta, x, (k - 1) * self.dt, self.dt,
                                         self.n_substeps, theta)

    def jacobian_f(self, x, k, theta):
        return self.f_and_jacobians(x, k, theta)[1]

    def jacobian_f_theta(self, x, k, theta):
        return self.f_and_jacobians(x, k, theta)[2]
