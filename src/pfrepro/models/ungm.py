"""Univariate non-stationary growth model (UNGM) and the variants the papers use.

    x_k = alpha x_{k-1} + beta x_{k-1} / (1 + x_{k-1}^2)
          + gamma cos(omega (k - time_offset)) + w_{k-1},   w ~ N(0, Q)
    y_k = x_k^2 / 20 + v_k,                                 v ~ N(0, R)

The classic benchmark (Kitagawa 1996; Gordon et al. 1993) has alpha = 0.5,
beta = 25, gamma = 8, omega = 1.2. The papers differ in small ways:

* Zhang et al. 2016 (GPFF, eq 57-58): cos(1.2(k-1)), Q = R = 1, x0 = 0.1, P0 = 0.1.
* Li et al. 2012 model 1: cos(1.2(k-1)), Q = 10, R = 1, x0 = 0.1.
* Li et al. 2012 model 2: x_k = x_{k-1}/2 + 18 cos(1.2(k-1)) + w (beta = 0, gamma = 18).
* Ning et al. 2011 (CMS-PF, eq 5): cos(1.2k), sigma_w^2 = 1, p(x0) = N(0, 1).
"""
from __future__ import annotations

import numpy as np

from ..validation import as_finite_float
from .base import StateSpaceModel

__all__ = ["UNGM"]


class UNGM(StateSpaceModel):
    """UNGM with explicit coefficients; see the module docstring.

    ``time_offset = 1`` gives cos(omega (k - 1)), ``time_offset = 0`` gives
    cos(omega k). ``obs_coeff`` is the 1/20 of y = x^2/20.
    """

    name = "UNGM"

    def __init__(self, alpha=0.5, beta=25.0, gamma=8.0, omega=1.2, time_offset=1,
                 Q=1.0, R=1.0, x0=0.1, m0=None, P0=1.0, obs_coeff=1.0 / 20.0,
                 measurement_noise=None, truth_init="fixed"):
        self.alpha, self.beta = as_finite_float(alpha, "alpha"), as_finite_float(beta, "beta")
        self.gamma, self.omega = as_finite_float(gamma, "gamma"), as_finite_float(omega, "omega")
        off = as_finite_float(time_offset, "time_offset")
        if not off.is_integer():
            raise ValueError(f"time_offset must be an integer, got {time_offset!r}")
        self.time_offset = int(off)
        self.obs_coeff = as_finite_float(obs_coeff, "obs_coeff")
        m0 = x0 if m0 is None else m0
        super().__init__(1, 1, Q, R if measurement_noise is None else measurement_noise,
                         [x0], [m0], P0, truth_init=truth_init)

    # -- paper presets -----------------------------------------------------------------
    @classmethod
    def zhang2016(cls) -> "UNGM":
        """GPFF paper, sec 5.2, eqs (57)-(58): Q = R = 1, x0 = 0.1, filters N(x0, 0.1)."""
        return cls(time_offset=1, Q=1.0, R=1.0, x0=0.1, P0=0.1)

    @classmethod
    def li2012_model1(cls, P0: float = 1.0) -> "UNGM":
        """Li et al. 2012, model 1: Q = 10, R = 1, x0 = 0.1. P0 is not given in the paper."""
        return cls(time_offset=1, Q=10.0, R=1.0, x0=0.1, P0=P0)

    @classmethod
    def li2012_model2(cls, P0: float = 1.0) -> "UNGM":
        """Li et al. 2012, model 2 (weakly nonlinear): x_k = x/2 + 18 cos(1.2(k-1)) + w."""
        return cls(beta=0.0, gamma=18.0, time_offset=1, Q=10.0, R=1.0, x0=0.1, P0=P0)

    @classmethod
    def ning2011(cls, sigma_v: float = 1.0, x0: float = 0.1, P0: float = 1.0) -> "UNGM":
        """Ning et al. 2011, eq (5): cos(1.2k), sigma_w^2 = 1, p(x0) = N(0, 1), x0 = 0.1."""
        return cls(time_offset=0, Q=1.0, R=sigma_v**2, x0=x0, m0=0.0, P0=P0)

    # -- model functions -----------------------------------------------------------------
    def forcing(self, k: int) -> float:
        """The forcing term gamma cos(omega (k - time_offset)) of step ``k``."""
        return self.gamma * np.cos(self.omega * (k - self.time_offset))

    def f(self, x, k):
        # alpha x + beta x / (1 + x^2) + gamma cos(omega (k - offset)), with few temporaries
        t = np.multiply(x, x)
        t += 1.0
        np.divide(x, t, out=t)
        t *= self.beta
        t += self.alpha * x
        t += self.forcing(k)
        return t

    def jacobian_f(self, x, k):
        x2 = x * x
        return (self.alpha + self.beta * (1.0 - x2) / (1.0 + x2) ** 2)[..., None]

    def h(self, x):
        return self.obs_coeff * x * x

    def jacobian_h(self, x):
        return (2.0 * self.obs_coeff * x)[..., None]

    def __repr__(self) -> str:
        return (f"UNGM(alpha={self.alpha}, beta={self.beta}, gamma={self.gamma}, omega={self.omega}, "
                f"time_offset={self.time_offset}, Q={self.Q[0, 0]}, R={self.R[0, 0]}, x0={self.x0[0]}, "
                f"m0={self.m0[0]}, P0={self.P0[0, 0]})")
