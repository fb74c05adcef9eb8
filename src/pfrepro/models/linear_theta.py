"""Scalar linear-Gaussian model with an unknown coefficient θ: the case where everything is exact.

    x_k = θ x_{k-1} + c + w_k,   w_k ~ N(0, Q);      y_k = x_k + v_k,   v_k ~ N(0, R)

For each fixed θ the Kalman filter gives the exact evidence p(y_1:k | θ) and the exact
one-step predictive density p(y_k | θ, y_1:k-1) = N(y_k; θ m_{k-1} + c, θ² P_{k-1} + Q + R):
the reference against which the θ-grid filter and the marginal-likelihood step of
Hou & Yin's eq (11) are checked.
"""
from __future__ import annotations

import numpy as np

from .parameterized import ParameterizedModel

__all__ = ["LinearTheta"]


class LinearTheta(ParameterizedModel):
    """x_k = θ x_{k-1} + c + w, y_k = x_k + v (module docstring)."""

    name = "linear AR(1) (θ)"

    def __init__(self, theta_true=0.7, bounds=(0.0, 1.0), Q=1.0, R=1.0, m0=0.0, P0=1.0, c=0.0):
        self.c = float(c)
        super().__init__(1, 1, 1, Q, R, [m0], [m0], P0, [theta_true], bounds, truth_init="prior")

    def f(self, x, k, theta):
        return theta * x + self.c

    def jacobian_f(self, x, k, theta):
        return np.broadcast_to(theta, np.broadcast_shapes(np.shape(x), np.shape(theta)))[..., None].copy()

    def jacobian_f_theta(self, x, k, theta):
        return np.broadcast_to(x, np.broadcast_shapes(np.shape(x), np.shape(theta)))[..., None].copy()

    def h(self, x):
        return x

    def jacobian_h(self, x):
        return np.ones(np.shape(x) + (1,))
