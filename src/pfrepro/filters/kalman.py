"""Kalman filter and extended Kalman filter, batched over Monte Carlo runs.

Notation follows filterpy: state ``x``, covariance ``P``, transition ``F``,
measurement matrix ``H``, noise covariances ``Q`` and ``R``. Arrays carry a
leading runs axis: ``x`` is ``(runs, dim_x)``, ``P`` is ``(runs, dim_x, dim_x)``.
Both use the Joseph-form covariance update, as filterpy does, which keeps P
symmetric positive definite in floating point.
"""
from __future__ import annotations

import numpy as np

from ..flow import solve_per_run
from ..models.base import batch_matmul
from .base import GaussianFilter

__all__ = ["KalmanFilter", "ExtendedKalmanFilter", "kalman_update", "symmetrize"]


def symmetrize(P):
    """(P + Pᵀ) / 2 over the last two axes: removes round-off asymmetry from a covariance."""
    return 0.5 * (P + np.swapaxes(P, -1, -2))


def kalman_update(x, P, innovation, H, R):
    """Batched Kalman measurement update with a given innovation y - h(x).

    ``x`` (runs, n), ``P`` (runs, n, n), ``innovation`` (runs, m), ``H`` (runs, m, n)
    or (m, n), ``R`` (m, m). Joseph form: P+ = (I - K H) P (I - K H)^T + K R K^T.
    """
    Ht = np.swapaxes(H, -1, -2)
    PHt = P @ Ht
    S = symmetrize(H @ PHt + R)
    # K = P H^T S^{-1}  <=>  K^T = S^{-1} H P  (S symmetric); a singular S (a diverged run)
    # gives NaN in its own run instead of a LinAlgError for the whole batch
    K = np.swapaxes(solve_per_run(S, np.swapaxes(PHt, -1, -2)), -1, -2)
    x_new = x + np.einsum("...ij,...j->...i", K, innovation)
    I_KH = np.eye(P.shape[-1]) - K @ H
    P_new = I_KH @ P @ np.swapaxes(I_KH, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
    return x_new, symmetrize(P_new), S


class KalmanFilter(GaussianFilter):
    """Linear Kalman filter (Kalman 1960), batched over runs.

    For a linear-Gaussian model x_k = F x_{k-1} + w_{k-1}, y_k = H x_k + v_k this is the
    exact posterior N(x_{k|k}, P_{k|k}): predict x- = F x, P- = F P F^T + Q; update
    K = P- H^T (H P- H^T + R)^{-1}, x = x- + K (y - H x-), Joseph-form P. It is the
    update that the GPFF's affine flow reproduces at lambda = 1 in the linear-Gaussian
    case (Zhang et al. 2016, eq 12 and eqs 22-27), and the reference of their sec 5.1.
    For mixture measurement noise it uses the mixture's covariance ``model.R`` (then it
    is the best *linear* estimator, no longer the posterior mean). ``Q`` may be singular
    or zero (P stays positive definite because P0 and R are).

    Parameters
    ----------
    model : LinearGaussianModel
        Any model with matrices ``F`` and ``H`` (e.g. :class:`~pfrepro.models.CWPA`).
    m0, P0 : array_like, optional
        Override the model's initial distribution N(m0, P0).
    on_divergence : {"warn", "drop", "raise"}
        A run whose estimates become non-finite: NaN from that step on and flagged, one
        warning (default), silent, or an error (see :class:`~pfrepro.filters.GaussianFilter`).

    Model methods
    -------------
    ``F``, ``H`` (matrices), ``Q``, ``R``, ``residual_y``, ``m0``, ``P0``; additive
    measurement noise (y = H x + v). Another model raises
    :class:`~pfrepro.models.ModelContractError`.

    Notes
    -----
    ``filter(y)``: ``y`` is ``(runs, T, dim_y)``, or ``(T,)`` for one scalar run, or
    ``(T, dim_y)`` for one run when ``dim_y > 1``. Returns ``x`` (runs, T, dim_x),
    ``P`` (runs, T, dim_x, dim_x) and ``diagnostics["log_likelihood"]`` (runs, T),
    ``diagnostics["log_evidence"]`` (runs,).
    """

    name = "KF"
    model_requirements = ("linear", "additive_measurement")

    def predict(self, x, P, k=None):
        F = self.model.F
        # batch_matmul: a run's mean does not depend on how many runs share the call
        return batch_matmul(x, F), symmetrize(F @ P @ F.T + self.model.Q)

    def update(self, x, P, y):
        H = self.model.H
        nu = y - batch_matmul(x, H)
        x, P, S = kalman_update(x, P, nu, H, self.model.R)
        self._last_innovation = (nu, S)
        return x, P


class ExtendedKalmanFilter(GaussianFilter):
    """Extended Kalman filter: linearise f and h at the current estimate (Li et al. 2012, eqs 8-11).

    Predict: x- = f(x, k), P- = A P A^T + Q with A = df/dx at x_{k-1|k-1} (eq 10);
    update: B = dh/dx at x- (eq 10), K = P- B^T (B P- B^T + R)^{-1},
    x = x- + K (y - h(x-)) (eq 11), with the Joseph-form covariance update (equal to
    eq 11's P_{k|k} = P- - K B P- in exact arithmetic, better conditioned in floating
    point). The chapter checks it against eq (11) written out literally. ``Q`` may be
    singular or zero.

    Parameters
    ----------
    model : StateSpaceModel
        A model with additive process and measurement noise.
    m0, P0 : array_like, optional
        Override the model's initial distribution N(m0, P0).
    on_divergence : {"warn", "drop", "raise"}
        As for :class:`KalmanFilter`.

    Model methods
    -------------
    ``f``, ``jacobian_f``, ``h``, ``jacobian_h``, ``residual_y``, ``Q``, ``R``, ``m0``,
    ``P0``; additive measurement noise (y = h(x) + v). Another model raises
    :class:`~pfrepro.models.ModelContractError`.

    Notes
    -----
    ``y`` shapes and diagnostics as for :class:`KalmanFilter`.
    """

    name = "EKF"
    model_requirements = ("additive_measurement", "jacobian_h", "f", "jacobian_f")

    def predict(self, x, P, k):
        F = self.model.jacobian_f(x, k)
        return self.model.f(x, k), symmetrize(F @ P @ np.swapaxes(F, -1, -2) + self.model.Q)

    def update(self, x, P, y):
        H = self.model.jacobian_h(x)
        innov = self.model.residual_y(y, self.model.h(x))
        x, P, S = kalman_update(x, P, innov, H, self.model.R)
        self._last_innovation = (innov, S)
        return x, P
