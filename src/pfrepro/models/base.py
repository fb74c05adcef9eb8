"""State-space model interface shared by every model and filter.

A model describes

    x_k = f(x_{k-1}, k) + w_{k-1},    w ~ process_noise   (covariance Q)
    y_k = h(x_k) + v_k,               v ~ measurement_noise (covariance R)

for k = 1..T, with the truth starting at ``x0`` and the filters starting from
``N(m0, P0)``. Everything is vectorised over arbitrary leading axes: a state
array has shape ``(..., dim_x)``, so the same ``f`` serves a single state, a
batch of runs ``(runs, dim_x)`` or a particle cloud ``(runs, N, dim_x)``.

This follows the separation used by N. Chopin's ``particles`` package: the
model knows how to simulate and evaluate densities; filters know nothing about
a particular model beyond this interface.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..noise import GaussianNoise
from ..rng import check_rng
from ..validation import as_covariance, as_vector, check_positive_int

__all__ = ["StateSpaceModel", "Simulation"]


@dataclass(frozen=True)
class Simulation:
    """Simulated truth and measurements for ``runs`` independent runs.

    Attributes
    ----------
    x : ndarray
        True states, shape (runs, T + 1, dim_x); ``x[:, 0]`` is the initial state x_0,
        ``x[:, k]`` is x_k.
    y : ndarray
        Measurements, shape (runs, T, dim_y); ``y[:, k - 1]`` is y_k.
    """

    x: np.ndarray
    y: np.ndarray

    @property
    def runs(self) -> int:
        """Number of runs."""
        return self.x.shape[0]

    @property
    def T(self) -> int:
        """Number of time steps (measurements per run)."""
        return self.y.shape[1]

    def run(self, i: int) -> "Simulation":
        """The i-th run as a one-run simulation (keeps the leading axis)."""
        return Simulation(self.x[i : i + 1], self.y[i : i + 1])


class StateSpaceModel:
    """Additive-Gaussian-process-noise state-space model (see module docstring).

    Subclasses implement :meth:`f`, :meth:`h` and their Jacobians
    :meth:`jacobian_f`, :meth:`jacobian_h`. Angles and other wrapped
    measurements override :meth:`residual_y`.

    Parameters
    ----------
    Q : (dim_x, dim_x) process-noise covariance.
    measurement_noise : a ``GaussianNoise``/``GaussianMixtureNoise`` or a
        covariance matrix (read as zero-mean Gaussian).
    x0 : true initial state.
    m0, P0 : the filters' initial distribution N(m0, P0).
    truth_init : ``"fixed"`` (every run starts at ``x0``) or ``"prior"``
        (each run draws x_0 ~ N(m0, P0)).
    """

    name = "state-space model"

    def __init__(self, dim_x, dim_y, Q, measurement_noise, x0, m0, P0, truth_init="fixed"):
        self.dim_x = check_positive_int(dim_x, "dim_x")
        self.dim_y = check_positive_int(dim_y, "dim_y")
        # Q may be singular (Q = G Qc G^T of lower rank) or zero (deterministic dynamics)
        self.process_noise = GaussianNoise(as_covariance(Q, "Q", self.dim_x, allow_singular=True),
                                           allow_singular=True)
        if not hasattr(measurement_noise, "logpdf"):
            measurement_noise = GaussianNoise(as_covariance(measurement_noise, "R", self.dim_y))
        if measurement_noise.dim != self.dim_y:
            raise ValueError(f"measurement noise has dimension {measurement_noise.dim}, model has dim_y = {self.dim_y}")
        self.measurement_noise = measurement_noise
        self.x0 = as_vector(x0, "x0", self.dim_x)
        self.m0 = as_vector(m0, "m0", self.dim_x)
        self.P0 = as_covariance(P0, "P0", self.dim_x)
        if truth_init not in ("fixed", "prior"):
            raise ValueError("truth_init must be 'fixed' or 'prior'")
        self.truth_init = truth_init

    # -- covariances a Gaussian filter is given ------------------------------------
    @property
    def Q(self) -> np.ndarray:
        """Process-noise covariance (dim_x, dim_x)."""
        return self.process_noise.cov

    @property
    def R(self) -> np.ndarray:
        """Measurement-noise covariance (the mixture's own covariance for a mixture)."""
        return self.measurement_noise.cov

    # -- to be implemented by subclasses ------------------------------------------
    def f(self, x: np.ndarray, k: int) -> np.ndarray:
        """Noise-free transition: mean of x_k given x_{k-1} = x."""
        raise NotImplementedError

    def jacobian_f(self, x: np.ndarray, k: int) -> np.ndarray:
        """d f / d x at ``x``, shape ``(..., dim_x, dim_x)``."""
        raise NotImplementedError

    def h(self, x: np.ndarray) -> np.ndarray:
        """Noise-free measurement function."""
        raise NotImplementedError

    def jacobian_h(self, x: np.ndarray) -> np.ndarray:
        """d h / d x at ``x``, shape ``(..., dim_y, dim_x)``."""
        raise NotImplementedError

    def residual_y(self, y: np.ndarray, y_pred: np.ndarray) -> np.ndarray:
        """Innovation y - y_pred (overridden for wrapped quantities such as angles)."""
        return y - y_pred

    # -- derived ---------------------------------------------------------------------
    def sample_transition(self, x: np.ndarray, k: int, rng: np.random.Generator) -> np.ndarray:
        """Draw x_k ~ p(x_k | x_{k-1} = x) for every state in the batch ``x``."""
        out = self.process_noise.sample(rng, x.shape[:-1])
        out += self.f(x, k)
        return out

    def log_likelihood(self, y: np.ndarray, x: np.ndarray) -> np.ndarray:
        """log p(y | x) for a batch: ``y`` (runs, dim_y), ``x`` (runs, ..., dim_x).

        ``y`` is broadcast over the particle axes of ``x``; returns ``x.shape[:-1]``.
        """
        y = np.asarray(y, dtype=float)
        y = y.reshape(y.shape[:1] + (1,) * (x.ndim - 2) + y.shape[1:])
        return self.measurement_noise.logpdf(self.residual_y(y, self.h(x)))

    def sample_initial(self, rng: np.random.Generator, shape) -> np.ndarray:
        """Draw from the filters' prior N(m0, P0); returns ``(*shape, dim_x)``."""
        shape = tuple(np.atleast_1d(shape))
        z = rng.standard_normal(shape + (self.dim_x,))
        return self.m0 + z @ np.linalg.cholesky(self.P0).T

    def simulate(self, T: int, runs: int = 1, rng: np.random.Generator | None = None) -> Simulation:
        """Simulate ``runs`` independent trajectories of length ``T``.

        All runs advance together (one vectorised draw per time step), so the
        cost is T numpy calls regardless of ``runs``.
        """
        T = check_positive_int(T, "T")
        runs = check_positive_int(runs, "runs")
        check_rng(rng)
        x = np.empty((runs, T + 1, self.dim_x))
        y = np.empty((runs, T, self.dim_y))
        x[:, 0] = self.x0 if self.truth_init == "fixed" else self.sample_initial(rng, runs)
        for k in range(1, T + 1):
            x[:, k] = self.sample_transition(x[:, k - 1], k, rng)
            y[:, k - 1] = self.h(x[:, k]) + self.measurement_noise.sample(rng, runs)
        return Simulation(x=x, y=y)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(dim_x={self.dim_x}, dim_y={self.dim_y})"
