"""Unscented Kalman filter (Julier & Uhlmann 2004; Wan & van der Merwe 2000), batched over runs."""
from __future__ import annotations

import numpy as np

from ..flow import solve_per_run
from .base import GaussianFilter
from .kalman import symmetrize
from .sigma_points import ScaledSigmaPoints, unscented_transform

__all__ = ["UnscentedKalmanFilter"]


class UnscentedKalmanFilter(GaussianFilter):
    """Unscented Kalman filter with additive noise and scaled sigma points (Julier & Uhlmann 2004).

    Predict: sigma points of N(x, P) through f, their mean and covariance plus Q.
    Update: sigma points through h give y_hat, Pyy (+ R) and Pxy;
    K = Pxy Pyy^{-1}, x = x- + K (y - y_hat), P = P- - K Pyy K^T. The scaled unscented
    transform (:class:`ScaledSigmaPoints`) is the one inside the GPFF, Zhang et al. 2016,
    eqs 47-50 (with the standard weight of eq 47, see that chapter's errata), and the
    UKF is a comparison filter of their sec 5 and of Li et al. 2012's chapter.

    ``redraw=True`` (default) draws fresh sigma points from N(x-, P-) for the
    update, the textbook additive-noise UKF, so Q enters Pxy and Pyy; this is
    also what filterpy's ``UnscentedKalmanFilter`` does (its ``predict`` ends by
    redrawing ``sigmas_f`` from N(x-, P-); checked against filterpy 2.0.0).
    ``redraw=False`` reuses the propagated points f(X_{k-1}) for the update.

    Parameters
    ----------
    model : StateSpaceModel
        A model with additive process and measurement noise.
    alpha, beta, kappa : float
        Scaled-UT parameters (default 1, 2, 0).
    redraw : bool
        See above.
    m0, P0 : array_like, optional
        Override the model's initial distribution N(m0, P0).
    on_divergence : {"warn", "drop", "raise"}
        A run whose estimates become non-finite: NaN from that step on and flagged, one
        warning (default), silent, or an error (see :class:`~pfrepro.filters.GaussianFilter`).

    Model methods
    -------------
    ``f``, ``h``, ``residual_y``, ``Q``, ``R``, ``m0``, ``P0`` (no Jacobians); additive
    measurement noise (y = h(x) + v). Another model raises
    :class:`~pfrepro.models.ModelContractError`.

    Notes
    -----
    ``Q`` may be singular or zero; sigma points use a robust square root of P
    (:func:`~pfrepro.filters.sigma_points.safe_cholesky`). ``filter(y)``: ``y`` is
    ``(runs, T, dim_y)``, or ``(T,)`` for one scalar run, or ``(T, dim_y)`` for one run
    when ``dim_y > 1``; returns ``x``, ``P`` and the log-likelihood diagnostics of
    :class:`~pfrepro.filters.GaussianFilter`.
    """

    name = "UKF"
    model_requirements = ("f", "additive_measurement")

    def __init__(self, model, alpha=1.0, beta=2.0, kappa=0.0, redraw=True, m0=None, P0=None,
                 on_divergence: str = "warn"):
        super().__init__(model, m0, P0, on_divergence)
        self.points = ScaledSigmaPoints(model.dim_x, alpha, beta, kappa)
        self.redraw = bool(redraw)
        self._sigmas_f = None

    def predict(self, x, P, k):
        # a P without a square root (a diverged run) gives NaN points in its own run only
        sig = self.points.sigma_points(x, P, on_error="nan")
        sf = self.model.f(sig, k)
        self._sigmas_f = sf
        x, P, _ = unscented_transform(sf, self.points.Wm, self.points.Wc, self.model.Q)
        return x, symmetrize(P)

    def update(self, x, P, y):
        sig = self.points.sigma_points(x, P, on_error="nan") if self.redraw else self._sigmas_f
        sh = self.model.h(sig)
        y_hat, Pyy, dy = unscented_transform(sh, self.points.Wm, self.points.Wc, self.model.R,
                                             residual=self.model.residual_y)
        dx = sig - x[..., None, :]
        Pxy = np.einsum("i,...ij,...ik->...jk", self.points.Wc, dx, dy)
        K = np.swapaxes(solve_per_run(Pyy, np.swapaxes(Pxy, -1, -2)), -1, -2)
        innov = self.model.residual_y(y, y_hat)
        self._last_innovation = (innov, Pyy)
        x = x + np.einsum("...ij,...j->...i", K, innov)
        P = P - K @ Pyy @ np.swapaxes(K, -1, -2)
        return x, symmetrize(P)
