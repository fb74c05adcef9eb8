"""Stochastic volatility: a model whose measurement noise is *not* additive.

    x_k = phi x_{k-1} + w_{k-1},        w ~ N(0, sigma^2)
    y_k = beta exp(x_k / 2) e_k,        e ~ N(0, 1)

(the basic discrete-time SV model, e.g. Kim, Shephard & Chib 1998, eq 1 with
mu = 0 folded into beta). The log-volatility x_k is the state; y_k | x_k ~
N(0, beta^2 exp(x_k)), so

    log p(y | x) = -1/2 log(2 pi beta^2) - x/2 - y^2 / (2 beta^2 exp(x)).

It is the package's worked example of the model contract (see
:mod:`pfrepro.models.base`): ``additive_measurement_noise = False``,
:meth:`~pfrepro.models.StochasticVolatility.log_likelihood` and
:meth:`~pfrepro.models.StochasticVolatility.sample_measurement` overridden, no ``h``.
Particle filters and the grid filter run on it; the Kalman family and GPFF,
which need y = h(x) + v, refuse it with a :class:`~pfrepro.models.ModelContractError`.
"""
from __future__ import annotations

import numpy as np

from ..validation import as_finite_float
from .base import StateSpaceModel

__all__ = ["StochasticVolatility"]

_LOG_2PI = np.log(2.0 * np.pi)


class StochasticVolatility(StateSpaceModel):
    """Scalar SV model; see the module docstring.

    Parameters
    ----------
    phi : float
        AR(1) coefficient of the log-volatility (abs(phi) < 1 for stationarity; not enforced).
    sigma : float
        Standard deviation of the log-volatility innovation (> 0).
    beta : float
        Scale of the returns (> 0).
    x0 : float
        True initial log-volatility.
    m0, P0 : float
        The filters' prior; default the stationary N(0, sigma^2 / (1 - phi^2)) when abs(phi) < 1.
    """

    name = "SV"
    additive_measurement_noise = False

    def __init__(self, phi=0.95, sigma=0.25, beta=0.7, x0=0.0, m0=0.0, P0=None, truth_init="fixed"):
        self.phi = as_finite_float(phi, "phi")
        self.sigma = as_finite_float(sigma, "sigma", positive=True)
        self.beta = as_finite_float(beta, "beta", positive=True)
        if P0 is None:
            P0 = self.sigma**2 / (1.0 - self.phi**2) if abs(self.phi) < 1 else 1.0
        # measurement_noise is the e of y = beta exp(x/2) e (not an additive v)
        super().__init__(1, 1, self.sigma**2, 1.0, [x0], [m0], P0, truth_init=truth_init)

    def f(self, x, k):
        return self.phi * x

    def jacobian_f(self, x, k):
        return np.full(x.shape + (1,), self.phi)

    def log_likelihood(self, y, x):
        y = np.asarray(y, dtype=float)
        y = y.reshape(y.shape[:1] + (1,) * (x.ndim - 2) + y.shape[1:])
        xv = x[..., 0]
        return (-0.5 * (_LOG_2PI + np.log(self.beta**2)) - 0.5 * xv
                - 0.5 * y[..., 0] ** 2 / self.beta**2 * np.exp(-xv))

    def sample_measurement(self, x, rng):
        e = self.measurement_noise.sample(rng, x.shape[:-1])
        return self.beta * np.exp(0.5 * x) * e
