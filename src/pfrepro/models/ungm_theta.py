"""UNGM with an unknown linear coefficient θ (Hou & Yin 2008, sec 5.1, eqs 12–13).

    x_k = θ x_{k-1} + 25 x_{k-1} / (1 + x_{k-1}^2) + 8 cos(1.2 k) + v_k,   v_k ~ N(0, 1)   (12)
    y_k = x_k^2 / 20 + w_k,                                                 w_k ~ N(0, 1)   (13)

with x_0 ~ N(0, 5) (the paper writes N(μ, σ²), so 5 is the variance) for the truth of every
run and for the filters' prior, and the true θ = 0.5 (the classic value of the benchmark).
The paper leaves the prior range [r_l, r_u] of θ unstated; the default ``bounds = (0, 1)``
is the interval on which sec 3.2 (eq 6) introduces the Beta law, and the range of
coefficients for which the linear part of (12) is stable and non-oscillating.
Note the forcing term cos(1.2 k) (not cos(1.2 (k − 1))), as printed in eq (12).

θ enters linearly, so ∂f/∂θ = x_{k-1} and the evaluation for N_θ parameter values costs
one broadcast multiply.
"""
from __future__ import annotations

import numpy as np

from .parameterized import ParameterizedModel
from ..validation import as_finite_float

__all__ = ["UNGMTheta"]


class UNGMTheta(ParameterizedModel):
    """Eqs (12)–(13) of Hou & Yin (2008) with θ unknown (module docstring)."""

    name = "UNGM(θ)"

    def __init__(self, theta_true=0.5, bounds=(0.0, 1.0), Q=1.0, R=1.0, P0=5.0, m0=0.0,
                 beta=25.0, gamma=8.0, omega=1.2):
        self.beta, self.gamma, self.omega = (as_finite_float(beta, "beta"), as_finite_float(gamma, "gamma"),
                                             as_finite_float(omega, "omega"))
        super().__init__(1, 1, 1, Q, R, [m0], [m0], P0, [theta_true], bounds, truth_init="prior")

    def forcing(self, k):
        """The forcing term gamma cos(omega k) of step ``k``."""
        return self.gamma * np.cos(self.omega * k)

    def f(self, x, k, theta):
        return theta * x + self.beta * x / (1.0 + x * x) + self.forcing(k)

    def jacobian_f(self, x, k, theta):
        x2 = x * x
        return (theta + self.beta * (1.0 - x2) / (1.0 + x2) ** 2)[..., None]

    def jacobian_f_theta(self, x, k, theta):
        return np.broadcast_to(x, np.broadcast_shapes(x.shape, np.shape(theta)))[..., None].copy()

    def h(self, x):
        return x * x / 20.0

    def jacobian_h(self, x):
        return (x / 10.0)[..., None]
