"""Bearings-only tracking with two sensors (Zhang et al. 2016, sec 5.3, eqs 59-60).

State (x, y, vx, vy), discrete Wiener velocity model; each sensor at (s_x, s_y)
measures the bearing theta = atan2(y - s_y, x - s_x). The paper prints
arctan((y - s_y)/(x - s_x)); with the paper's geometry the two agree up to a
constant pi for the sensor whose x-offset is negative, which an additive noise
model does not see. Residuals are wrapped to (-pi, pi].
"""
from __future__ import annotations

import numpy as np

from ..validation import as_finite_float, as_matrix
from .base import StateSpaceModel, batch_matmul

__all__ = ["BearingsOnly", "wrap_angle"]


def wrap_angle(a, out=None):
    """Wrap angles to (-pi, pi]: ``pi - mod(pi - a, 2 pi)``.

    For arrays, ``mod`` (the costly part) is skipped when every ``t = pi - a`` already lies in
    [0, 2 pi), where ``mod(t, 2 pi) = t`` exactly: the result is bit-identical to the formula
    (residuals of a tracking filter almost never need the wrap). ``out`` (arrays only): write
    the result there (it may be ``a`` itself).
    """
    if np.ndim(a) == 0 and out is None:
        return np.pi - np.mod(np.pi - a, 2.0 * np.pi)
    t = np.subtract(np.pi, a, out=out)
    if t.size and not (t.min() >= 0.0 and t.max() < 2.0 * np.pi):   # NaN fails the test too
        np.mod(t, 2.0 * np.pi, out=t)
    return np.subtract(np.pi, t, out=t)


class BearingsOnly(StateSpaceModel):
    """Two-sensor (or more) bearings-only tracking; see module docstring."""

    name = "BOT"

    def __init__(self, dt=0.1, q=0.1, sensors=((-10.0, -10.0), (10.0, -10.0)), sigma_theta=0.05,
                 measurement_noise=None, x0=(0.0, 36.0, 0.2, -1.0), m0=(-6.0, 17.0, 0.0, 0.0),
                 P0=(25.0, 25.0, 1.0, 1.0), truth_init="fixed"):
        self.dt = dt = as_finite_float(dt, "dt", positive=True)
        q = as_finite_float(q, "q", nonnegative=True)
        self.sensors = as_matrix(sensors, "sensors", (None, 2))  # one (s_x, s_y) row per sensor
        ns = self.sensors.shape[0]
        I2 = np.eye(2)
        self.F = np.block([[I2, dt * I2], [np.zeros((2, 2)), I2]])
        Q = q**2 * np.block([[dt**3 / 3 * I2, dt**2 / 2 * I2], [dt**2 / 2 * I2, dt * I2]])
        P0 = np.asarray(P0, float)
        if P0.ndim == 1:  # the paper prints P0 as a vector: read it as a diagonal
            P0 = np.diag(P0)
        if measurement_noise is None:
            sigma_theta = as_finite_float(sigma_theta, "sigma_theta", positive=True)
        noise = measurement_noise if measurement_noise is not None else sigma_theta**2 * np.eye(ns)
        super().__init__(4, ns, Q, noise, x0, m0, P0, truth_init=truth_init)

    @classmethod
    def zhang2016(cls) -> "BearingsOnly":
        """Sec 5.3 settings: dt = 0.1, q = 0.1, R = 0.05^2 I, sensors (-10,-10), (10,-10)."""
        return cls()

    def f(self, x, k):
        # batch_matmul, not x @ F.T: a 2-D (runs, 4) product rounds a lone run differently
        return batch_matmul(x, self.F)

    def jacobian_f(self, x, k):
        return np.broadcast_to(self.F, x.shape[:-1] + self.F.shape)

    def h(self, x):
        dx = x[..., None, 0] - self.sensors[:, 0]
        dy = x[..., None, 1] - self.sensors[:, 1]
        return np.arctan2(dy, dx)

    def jacobian_h(self, x):
        dx = x[..., None, 0] - self.sensors[:, 0]
        dy = x[..., None, 1] - self.sensors[:, 1]
        r2 = dx * dx + dy * dy
        J = np.zeros(x.shape[:-1] + (self.sensors.shape[0], 4))
        J[..., 0] = -dy / r2
        J[..., 1] = dx / r2
        return J

    def residual_y(self, y, y_pred):
        return wrap_angle(y - y_pred)
