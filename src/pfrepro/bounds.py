"""Posterior Cramér–Rao bound (PCRB) for filtering, Tichavský, Muravchik & Nehorai (1998).

For a model with *linear* dynamics and additive Gaussian noises,

    x_k = F x_{k-1} + w_{k-1},  w ~ N(0, Q),        y_k = h(x_k) + v_k,  v ~ N(0, R),

the Bayesian information matrix J_k of x_k obeys Tichavský et al.'s recursion
J_k = D22 − D21 (J_{k-1} + D11)⁻¹ D12 with D11 = Fᵀ Q⁻¹ F, D12 = D21ᵀ = −Fᵀ Q⁻¹ and
D22 = Q⁻¹ + E[H_kᵀ R⁻¹ H_k], which the matrix inversion lemma turns into

    J_k = (Q + F J_{k-1}⁻¹ Fᵀ)⁻¹ + E[H_kᵀ R⁻¹ H_k],    H_k = ∂h/∂x at the true x_k,

and every estimator x̂_k(y_{1:k}) has E[(x̂_k − x_k)(x̂_k − x_k)ᵀ] ⪰ J_k⁻¹, the expectation
being over the *true* joint distribution of states and measurements. The prediction part is
exact (linear dynamics); the only expectation, E[H_kᵀ R⁻¹ H_k], is over the distribution of
the true state x_k and is estimated here by Monte Carlo over simulated truth trajectories.
For a linear h the bound is the Kalman filter's posterior covariance.

What the bound refers to depends on the distribution of x_0 (``init``):

* ``"prior"`` — x_0 ~ N(m0, P0), J_0 = P0⁻¹: the Bayesian setting the filters assume.
  It bounds the MSE averaged over truths drawn from that prior, not the MSE on data whose
  truth starts at a fixed ``x0``.
* ``"prior_info"`` — J_0 = P0⁻¹ (the filters' own prior information), the truths simulated
  as the data are (from ``model.x0``, or from the prior when ``model.truth_init == "prior"``):
  the yardstick usual in tracking (Ristic, Arulampalam & Gordon 2004, ch. 4) for filters
  started from N(m0, P0) on data whose truth starts elsewhere. It is a bound for an estimator
  whose knowledge of x_0 is that prior; it is not a strict bound on every estimator's MSE on
  data from a fixed start (an estimator that guessed ``x0`` would beat it early on), and not
  the optimal filter's MSE.
* ``"fixed"`` — x_0 = ``model.x0`` known exactly (J_0⁻¹ = 0), trajectories from ``x0``: the
  true distribution of data simulated with ``truth_init="fixed"``, so a valid lower bound on
  every estimator's MSE on such data, but one that credits the estimator with knowing x_0
  (filters started from a mismatched prior cannot reach it early on).

Caveat for bearings: the information of an angle measurement grows like 1/r² at its sensor,
so E[H_kᵀ R⁻¹ H_k] strictly diverges (logarithmically, in 2-D) for any state density positive
there; the Monte Carlo estimate is then the bound with a small exclusion zone around the
sensor, and is well determined only when the trajectories stay away from the sensors.
"""
from __future__ import annotations

import numpy as np

from .noise import GaussianNoise
from .validation import check_positive_int

__all__ = ["pcrb_linear_dynamics"]


def _sym(A):
    return 0.5 * (A + np.swapaxes(A, -1, -2))


def pcrb_linear_dynamics(model, T: int, runs: int, rng: np.random.Generator, init: str = "prior",
                         return_cov: bool = False) -> np.ndarray:
    """PCRB of x_1..x_T for a model with linear dynamics ``model.F`` (see module docstring).

    Parameters
    ----------
    model : StateSpaceModel
        A :class:`~pfrepro.models.StateSpaceModel` with a matrix attribute ``F``
        (``f(x) = F x``), Gaussian measurement noise, ``jacobian_h`` and ``Q``.
    T : int
        Horizon; the bound is returned for k = 1..T.
    runs : int
        Number of simulated truth trajectories for the Monte Carlo estimate of
        E[H_kᵀ R⁻¹ H_k] (all advanced together; vectorised over runs).
    rng : numpy.random.Generator
        Generator for the truth trajectories (use ``montecarlo.truth_rng``).
    init : {"prior", "prior_info", "fixed"}
        ``"prior"`` (x_0 ~ N(m0, P0), J_0 = P0⁻¹), ``"prior_info"`` (J_0 = P0⁻¹, truths
        from the model's own truth start) or ``"fixed"`` (x_0 = x0 known, J_0⁻¹ = 0).
    return_cov : bool
        Return the full J_k⁻¹ ``(T, dim_x, dim_x)`` instead of its diagonal.

    Returns
    -------
    ndarray
        ``(T, dim_x)``: the diagonal of J_k⁻¹ (the bound on each component's MSE) at
        k = 1..T; or ``(T, dim_x, dim_x)`` with ``return_cov=True``.
    """
    T = check_positive_int(T, "T")
    runs = check_positive_int(runs, "runs")
    if not hasattr(model, "F"):
        raise TypeError("pcrb_linear_dynamics needs a model with linear dynamics (a matrix attribute F)")
    if not isinstance(model.measurement_noise, GaussianNoise):
        raise TypeError("pcrb_linear_dynamics needs Gaussian measurement noise (Fisher information R^-1)")
    if init not in ("prior", "prior_info", "fixed"):
        raise ValueError("init must be 'prior', 'prior_info' or 'fixed'")
    F, Q, d = np.asarray(model.F, float), model.Q, model.dim_x
    W = np.linalg.cholesky(np.linalg.inv(model.R))               # R⁻¹ = W Wᵀ
    if init == "prior" or (init == "prior_info" and getattr(model, "truth_init", "fixed") == "prior"):
        x = model.sample_initial(rng, runs)
        J_inv = model.P0.copy()
    elif init == "prior_info":
        x = np.broadcast_to(model.x0, (runs, d)).copy()
        J_inv = model.P0.copy()
    else:
        x = np.broadcast_to(model.x0, (runs, d)).copy()
        J_inv = np.zeros((d, d))
    out = np.empty((T, d, d))
    for k in range(1, T + 1):
        x = model.sample_transition(x, k, rng)
        G = (np.swapaxes(W, 0, 1) @ model.jacobian_h(x)).reshape(-1, d)  # Wᵀ H_k, stacked over runs
        info_y = G.T @ G / runs                                           # E[H_kᵀ R⁻¹ H_k]
        J = np.linalg.inv(_sym(F @ J_inv @ F.T + Q)) + info_y
        J_inv = _sym(np.linalg.inv(_sym(J)))
        out[k - 1] = J_inv
    return out if return_cov else np.diagonal(out, axis1=1, axis2=2).copy()
