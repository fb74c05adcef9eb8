"""Ballistic re-entry (falling body) with an unknown ballistic parameter θ (Hou & Yin 2008, sec 5.2).

The problem is Athans, Wishner & Bertolini (1968); its constants are in **feet**.

**Working reading** (``reading="feet"``, the classic problem as usually coded, e.g.
Nørgaard's KalmTool):

    dx1/dt = −x2,                            (altitude x1 [ft], downward speed x2 [ft/s])
    dx2/dt = −θ · x2² · exp(−γ x1),          γ = 5·10⁻⁵ ft⁻¹,  θ̇ = 0  (no gravity)
    z_k = √(M² + (x1 − H)²) + v_k,           M = H = 10⁵ ft,  var v = 10⁴ ft²

sampled every dt = 1 s, integrated by RK4 (``n_substeps`` per second; see
:mod:`pfrepro.models.continuous`, whose variational equations give the EKF Jacobian).
Truth: x_0 = (3·10⁵ ft, 2·10⁴ ft/s), θ = 10⁻³ ft⁻¹. Filters: N(x_0, P_0) with
P_0 = diag(10⁶ ft², 4·10⁶ ft²/s²); the paper's "process noise" variances 10⁶ and 4·10⁶
are read as this *initial covariance*, and there is **no process noise** (Q = 0), as in
the classic problem. θ's prior range is the paper's [0, 2·10⁻³].

Three departures from the printed text are part of this reading: the units (the paper's
metric altitudes 91.5 km, 6.1 km/s, 30.5 km are the foot values converted, but γ, the
noise variances and θ were left in feet), the square on x2 (eq 16 prints θ x2 e^{−γx1}),
and the noise (eqs 15–16 put 10⁶, 4·10⁶ on the dynamics).

**Literal reading** (``reading="literal"``): the printed equations — metric state
x_0 = (91 500 m, 6 100 m/s), M = H = 30 500 m, γ = 5·10⁻⁵ *per metre*, no square
(dx2/dt = −θ x2 e^{−γ x1}), var v = 10⁴ m² — with the same θ, θ range and P_0 values.
Process noise is kept off in both readings so that the two differ only in units and
the square; ``Q`` may be passed to put the printed noise on the dynamics.
"""
from __future__ import annotations

import numpy as np

from .continuous import ContinuousParameterizedModel

__all__ = ["Reentry", "FT"]

#: metres per foot
FT = 0.3048


class Reentry(ContinuousParameterizedModel):
    """Athans falling body with unknown θ (module docstring).

    Parameters
    ----------
    reading : {"feet", "literal"}
        "feet" (working reading, default) or "literal" (printed, mixed units, no square).
    theta_true : float
        True ballistic parameter (10⁻³).
    bounds : tuple of float
        Prior range of θ, default (0, 2·10⁻³).
    P0 : ndarray
        Filters' initial covariance of (x1, x2), default diag(10⁶, 4·10⁶).
    Q : ndarray or float
        Process-noise covariance per sample (default 0).
    dt, n_substeps : float, int
        Sampling interval and RK4 steps per interval.
    """

    name = "re-entry (θ)"

    def __init__(self, reading: str = "feet", theta_true=1e-3, bounds=(0.0, 2e-3), P0=None, Q=None,
                 dt: float = 1.0, n_substeps: int = 64):
        if reading not in ("feet", "literal"):
            raise ValueError(f"reading must be 'feet' or 'literal', got {reading!r}")
        self.reading = reading
        self.gamma = 5e-5
        self.square = reading == "feet"
        if reading == "feet":
            self.M = self.H = 1e5
            x0 = [3e5, 2e4]
        else:
            self.M = self.H = 30.5e3
            x0 = [91.5e3, 6.1e3]
        P0 = np.diag([1e6, 4e6]) if P0 is None else P0
        Q = np.zeros((2, 2)) if Q is None else Q
        super().__init__(2, 1, 1, Q, 1e4, x0, x0, P0, [theta_true], bounds, truth_init="fixed",
                         dt=dt, n_substeps=n_substeps)

    # dynamics -----------------------------------------------------------------------
    def a(self, x, t, theta):
        x1, x2 = x[..., 0], x[..., 1]
        e = np.exp(-self.gamma * x1)
        drag = theta[..., 0] * (x2 * x2 if self.square else x2) * e
        return np.stack(np.broadcast_arrays(-x2, -drag), axis=-1)

    def a_x(self, x, t, theta):
        x1, x2 = x[..., 0], x[..., 1]
        th = theta[..., 0]
        e = np.exp(-self.gamma * x1)
        g = x2 * x2 if self.square else x2
        dg = 2.0 * x2 if self.square else np.ones_like(x2)
        shape = np.broadcast_shapes(x1.shape, th.shape)
        J = np.zeros(shape + (2, 2))
        J[..., 0, 1] = -1.0
        J[..., 1, 0] = th * g * e * self.gamma
        J[..., 1, 1] = -th * dg * e
        return J

    def a_theta(self, x, t, theta):
        x1, x2 = x[..., 0], x[..., 1]
        e = np.exp(-self.gamma * x1)
        g = x2 * x2 if self.square else x2
        shape = np.broadcast_shapes(x1.shape, theta[..., 0].shape)
        out = np.zeros(shape + (2, 1))
        out[..., 1, 0] = -g * e
        return out

    def f(self, x, k, theta):
        """RK4 map of :meth:`a`, written on the two components in place (the hot path of both
        particle filters); the same scheme as :func:`~pfrepro.models.continuous.rk4_integrate`,
        to which the tests compare it."""
        x = np.asarray(x, dtype=float)
        th = np.asarray(theta, dtype=float)[..., 0]
        shape = np.broadcast_shapes(x.shape[:-1], th.shape)
        x1 = np.broadcast_to(x[..., 0], shape).copy()
        x2 = np.broadcast_to(x[..., 1], shape).copy()
        hs = self.dt / self.n_substeps
        g, sq = -self.gamma, self.square

        def acc(p1, p2):  # dx2/dt = -θ p2^s e^{-γ p1}
            e = np.exp(g * p1)
            e *= p2
            if sq:
                e *= p2
            e *= th
            np.negative(e, out=e)
            return e

        for _ in range(self.n_substeps):
            v1 = x2                       # dx1/dt = -x2: stage slopes of x1 are -v_i
            a1 = acc(x1, x2)
            v2 = x2 + (0.5 * hs) * a1
            a2 = acc(x1 - (0.5 * hs) * v1, v2)
            v3 = x2 + (0.5 * hs) * a2
            a3 = acc(x1 - (0.5 * hs) * v2, v3)
            v4 = x2 + hs * a3
            a4 = acc(x1 - hs * v3, v4)
            x1 = x1 - (hs / 6.0) * (v1 + 2.0 * v2 + 2.0 * v3 + v4)
            x2 = x2 + (hs / 6.0) * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        return np.stack((x1, x2), axis=-1)

    # measurement ----------------------------------------------------------------------
    def h(self, x):
        d = x[..., 0:1] - self.H
        return np.sqrt(self.M**2 + d * d)

    def jacobian_h(self, x):
        d = x[..., 0] - self.H
        r = np.sqrt(self.M**2 + d * d)
        J = np.zeros(x.shape[:-1] + (1, 2))
        J[..., 0, 0] = d / r
        return J
