"""EKF variants found in circulating implementations of the UNGM benchmark.

:class:`PreviousEstimateJacobianEKF` is the EKF of the widely copied MATLAB
demonstration of the Gordon-Salmond-Smith benchmark (D. Simon, *Optimal State
Estimation*, Wiley 2006, ch. 15 example code): it linearises the measurement
function at the *previous posterior* estimate x_{k-1|k-1} instead of at the
prediction x_{k|k-1} that Li et al. (2012) prescribe in eq (10). It exists so a
chapter can show how much a published EKF number may depend on that detail; the
textbook EKF is :class:`pfrepro.filters.ExtendedKalmanFilter`.
"""
from __future__ import annotations

import numpy as np

from .kalman import ExtendedKalmanFilter, kalman_update

__all__ = ["PreviousEstimateJacobianEKF"]


class PreviousEstimateJacobianEKF(ExtendedKalmanFilter):
    """EKF with :math:`B_k = dh/dx` at :math:`x_{k-1|k-1}`, not at :math:`x_{k|k-1}` (Li et al. 2012, eq 10).

    Predict exactly as eq (11): x_{k|k-1} = f(x_{k-1|k-1}), P_{k|k-1} = A P A^T + Q
    with A = df/dx at x_{k-1|k-1}. Update with the innovation y_k - h(x_{k|k-1})
    as in eq (11) but with the gain built from B = dh/dx at x_{k-1|k-1}.
    Batched over runs like every Gaussian filter of the package.

    Model methods
    -------------
    As :class:`~pfrepro.filters.ExtendedKalmanFilter`.
    """

    name = "EKF (B at previous estimate)"

    def predict(self, x, P, k):
        self._x_prev = np.array(x, copy=True)
        return super().predict(x, P, k)

    def update(self, x, P, y):
        if getattr(self, "_x_prev", None) is None or self._x_prev.shape != x.shape:
            raise RuntimeError("PreviousEstimateJacobianEKF.update must follow predict (use .filter)")
        H = self.model.jacobian_h(self._x_prev)
        innov = self.model.residual_y(y, self.model.h(x))
        x, P, S = kalman_update(x, P, innov, H, self.model.R)
        self._last_innovation = (innov, S)
        return x, P

    def filter(self, y, rng=None):
        self._x_prev = None
        try:
            return super().filter(y, rng)
        finally:
            self._x_prev = None
