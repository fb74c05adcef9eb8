"""Linear-Gaussian models: a generic one, and the 6-D CWPA model (Zhang et al. 2016, sec 5.1).

    x_k = F x_{k-1} + w_{k-1},  w ~ N(0, Q)
    y_k = H x_k + v_k,          v ~ measurement_noise (Gaussian or mixture)
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import expm

from ..noise import GaussianMixtureNoise
from ..validation import as_finite_float, as_matrix
from .base import StateSpaceModel, batch_matmul

__all__ = ["LinearGaussianModel", "CWPA", "van_loan_discretize"]


def van_loan_discretize(F_c, L, Qc, dt):
    """Exact discretisation of dx = F_c x dt + L dW, E[dW dW^T] = Qc dt (Van Loan 1978).

    Returns ``(F, Q)`` with ``F = expm(F_c dt)`` and
    ``Q = int_0^dt expm(F_c s) L Qc L^T expm(F_c s)^T ds``.
    The block-matrix exponential gives both in one call:
    ``expm([[-F_c, L Qc L^T], [0, F_c^T]] dt) = [[., G12], [0, G22]]``,
    ``F = G22^T``, ``Q = G22^T G12``.
    """
    F_c = np.asarray(F_c, float)
    n = F_c.shape[0]
    G = np.asarray(L, float) @ np.asarray(Qc, float) @ np.asarray(L, float).T
    M = np.zeros((2 * n, 2 * n))
    M[:n, :n] = -F_c
    M[:n, n:] = G
    M[n:, n:] = F_c.T
    E = expm(M * dt)
    F = E[n:, n:].T
    Q = F @ E[:n, n:]
    return F, 0.5 * (Q + Q.T)


class LinearGaussianModel(StateSpaceModel):
    """Linear dynamics and measurements; the Kalman filter is exact when the noise is Gaussian."""

    name = "linear-Gaussian"

    def __init__(self, F, H, Q, R, x0, m0=None, P0=None, truth_init="fixed"):
        self.F = as_matrix(F, "F")
        nx = self.F.shape[0]
        if self.F.shape != (nx, nx):
            raise ValueError(f"F must be square, got shape {self.F.shape}")
        self.H = as_matrix(H, "H", (None, nx))
        m0 = x0 if m0 is None else m0
        P0 = np.eye(nx) if P0 is None else P0
        super().__init__(nx, self.H.shape[0], Q, R, x0, m0, P0, truth_init=truth_init)

    def f(self, x, k):
        # batch_matmul, not x @ F.T: a 2-D (runs, n) product rounds a lone run differently
        return batch_matmul(x, self.F)

    def jacobian_f(self, x, k):
        return np.broadcast_to(self.F, x.shape[:-1] + self.F.shape)

    def h(self, x):
        return batch_matmul(x, self.H)

    def jacobian_h(self, x):
        return np.broadcast_to(self.H, x.shape[:-1] + self.H.shape)


class CWPA(LinearGaussianModel):
    """Planar continuous Wiener-process-acceleration model, discretised exactly.

    State (x, y, vx, vy, ax, ay); dx/dt = F_c x + L w, w white with spectral
    density Qc I_2 (eq 53); position measured (eq 55). Discretised by the
    matrix exponential and Van Loan's method (eq 54; the printed Q integral
    lacks the transpose on its second exponential).
    """

    name = "CWPA"

    def __init__(self, dt=0.1, qc=0.1, R=None, measurement_noise=None, x0=None,
                 P0=None, m0=None, truth_init="fixed"):
        dt = as_finite_float(dt, "dt", positive=True)
        qc = as_finite_float(qc, "qc", nonnegative=True)
        F_c = np.zeros((6, 6))
        F_c[:4, 2:] = np.eye(4)
        L = np.zeros((6, 2))
        L[4:, :] = np.eye(2)
        F, Q = van_loan_discretize(F_c, L, qc * np.eye(2), dt)
        H = np.hstack([np.eye(2), np.zeros((2, 4))])
        self.dt, self.qc = float(dt), float(qc)
        x0 = np.zeros(6) if x0 is None else x0
        P0 = np.diag([0.1, 0.1, 0.1, 0.1, 0.5, 0.5]) if P0 is None else P0
        noise = measurement_noise if measurement_noise is not None else (0.014 * np.eye(2) if R is None else R)
        super().__init__(F, H, Q, noise, x0, m0, P0, truth_init=truth_init)

    @classmethod
    def zhang2016(cls, noise: str = "gaussian") -> "CWPA":
        """Sec 5.1 settings: dt = 0.1, Qc = 0.1 I, P0 = diag(.1,.1,.1,.1,.5,.5).

        ``noise="gaussian"``: v ~ N(0, 0.014 I).
        ``noise="mixture"``: v ~ 0.01 N(0, R1) + 0.99 N(0, R2). R2 is printed
        non-symmetric ([[0.01, 0.005], [0.001, 0.01]]); we symmetrise it to
        off-diagonal 0.003 (the mean of the two printed entries).
        """
        if noise == "gaussian":
            return cls()
        if noise == "mixture":
            R1 = np.array([[0.6, 0.25], [0.25, 0.7]])
            R2_printed = np.array([[0.01, 0.005], [0.001, 0.01]])
            R2 = 0.5 * (R2_printed + R2_printed.T)
            return cls(measurement_noise=GaussianMixtureNoise([0.01, 0.99], [R1, R2]))
        raise ValueError("noise must be 'gaussian' or 'mixture'")
