"""Dual extended Kalman filter (DEKF) of Wan & Nelson (2001), batched over Monte Carlo runs.

Two EKFs run side by side (Wan & Nelson, "Dual extended Kalman filter methods", in
Haykin (ed.), *Kalman Filtering and Neural Networks*, ch. 5; the baseline of Hou & Yin 2008):

**Parameter time update** (random walk): θ⁻_k = θ̂_{k-1}, P^θ⁻_k = P^θ_{k-1} + Q^θ_k, with
annealed parameter noise Q^θ_k = max(q_0 λ^k, q_min) (ReBEL's dual-estimation demos anneal
by λ = 0.995 down to a floor).

**State EKF** with θ = θ⁻_k: x⁻ = f(x̂_{k-1}, k, θ⁻), P⁻ = F P Fᵀ + Q, K = P⁻Hᵀ S⁻¹,
S = H P⁻ Hᵀ + R, ν = z_k − h(x⁻), x̂ = x⁻ + K ν, P = (I − K H) P⁻ (Joseph form).

**Recurrent derivative** D = ∂x̂/∂θ (Wan & Nelson's "recurrent" form, with the ∂K/∂θ term
neglected, as they allow):

    D⁻_k = F_k D_{k-1} + ∂f/∂θ,       D_k = (I − K_k H_k) D⁻_k,       D_0 = 0.

**Parameter EKF**: its "measurement" is z_k = h(x⁻_k(θ)) + e with C = ∂h(x⁻(θ))/∂θ = H D⁻_k
and e the state filter's innovation (covariance S, the prediction-error form):
K^θ = P^θ⁻ Cᵀ (C P^θ⁻ Cᵀ + S)⁻¹, θ̂_k = θ⁻ + K^θ ν, P^θ_k = (I − K^θ C) P^θ⁻.

Parameters
----------
model : ParameterizedModel
    A :class:`~pfrepro.models.parameterized.ParameterizedModel`.
theta0, P_theta0 : float
    Initial parameter estimate and its variance.
q0, anneal, q_min : float
    Parameter noise Q^θ_k = max(q0 · anneal^k, q_min).
clip_to_bounds : bool
    Keep θ̂ inside the model's prior range (default False, the plain DEKF).
on_divergence : {"warn", "drop", "raise"}
    "warn" (default): a run whose estimates become non-finite is NaN from that step on,
    its step in ``diagnostics["diverged_at"]``, one ``FilterDivergenceWarning`` with the count; "drop": the
    same, silent; "raise": ``FilterDivergenceError`` (as the EKF, UKF and IMM filters).
"""
from __future__ import annotations

import warnings

import numpy as np

from ..flow import solve_per_run
from ..models.parameterized import as_theta
from ..validation import as_covariance, as_finite_float, check_quantile_levels
from .base import DIVERGENCE_POLICIES, FilterDivergenceError, FilterDivergenceWarning, FilterResult, gaussian_loglik
from .parameter_learning import ParameterLearningFilter

__all__ = ["DualExtendedKalmanFilter"]


def _jacobians(model, x, k, theta):
    """f, ∂f/∂x, ∂f/∂θ (one variational integration for continuous-time models)."""
    if hasattr(model, "f_and_jacobians"):
        return model.f_and_jacobians(x, k, theta)
    return model.f(x, k, theta), model.jacobian_f(x, k, theta), model.jacobian_f_theta(x, k, theta)


class DualExtendedKalmanFilter(ParameterLearningFilter):
    """Wan & Nelson's dual EKF (module docstring)."""

    name = "DEKF"
    parameter_needs = ("f", "h", "jacobian_f", "jacobian_f_theta", "jacobian_h")
    scalar_theta = False

    def __init__(self, model, theta0, P_theta0, q0: float = 0.0, anneal: float = 1.0, q_min: float = 0.0,
                 clip_to_bounds: bool = False, on_divergence: str = "warn", m0=None, P0=None):
        super().__init__(model, m0, P0)
        self.theta0 = as_theta(theta0, model.dim_theta, "theta0").reshape(model.dim_theta)
        self.P_theta0 = as_covariance(P_theta0, "P_theta0", model.dim_theta, allow_singular=True)
        q0 = as_finite_float(q0, "q0", nonnegative=True)
        q_min = as_finite_float(q_min, "q_min", nonnegative=True)
        anneal = as_finite_float(anneal, "anneal")
        if not 0 < anneal <= 1:
            raise ValueError(f"anneal must lie in (0, 1], got {anneal!r}")
        if on_divergence not in DIVERGENCE_POLICIES:
            raise ValueError(f"on_divergence must be one of {DIVERGENCE_POLICIES}, got {on_divergence!r}")
        self.on_divergence = on_divergence
        self.q0, self.anneal, self.q_min = q0, anneal, q_min
        self.clip_to_bounds = bool(clip_to_bounds)

    def q_theta(self, k: int) -> float:
        """Annealed parameter noise variance at step k."""
        return max(self.q0 * self.anneal**k, self.q_min)

    def filter(self, y, rng=None) -> FilterResult:
        y = self._prepare(y, rng)
        mdl = self.model
        runs, T, m = y.shape
        n, p = mdl.dim_x, mdl.dim_theta
        I_n = np.eye(n)
        x = np.broadcast_to(self.m0, (runs, n)).copy()
        P = np.broadcast_to(self.P0, (runs, n, n)).copy()
        th = np.broadcast_to(self.theta0, (runs, p)).copy()
        Pt = np.broadcast_to(self.P_theta0, (runs, p, p)).copy()
        D = np.zeros((runs, n, p))
        xs, Ps = np.empty((runs, T, n)), np.empty((runs, T, n, n))
        ths, Pts = np.empty((runs, T, p)), np.empty((runs, T, p, p))
        Ds, Ks = np.empty((runs, T, n, p)), np.empty((runs, T, n, m))
        loglik = np.empty((runs, T))
        lo, hi = mdl.bounds
        with np.errstate(all="ignore"):
            for k in range(1, T + 1):
                z = y[:, k - 1]
                # parameter time update (random walk, annealed noise)
                Pt_m = Pt + self.q_theta(k) * np.eye(p)
                # state EKF with θ⁻ = θ̂_{k-1}
                xm, F, Fth = _jacobians(mdl, x, k, th)
                Pm = F @ P @ np.swapaxes(F, -1, -2) + mdl.Q
                Dm = F @ D + Fth                                   # recurrent derivative, time update
                H = mdl.jacobian_h(xm)
                S = H @ Pm @ np.swapaxes(H, -1, -2) + mdl.R
                S = 0.5 * (S + np.swapaxes(S, -1, -2))
                K = np.swapaxes(solve_per_run(S, H @ Pm), -1, -2)  # P⁻Hᵀ S⁻¹ (P⁻, S symmetric)
                nu = mdl.residual_y(z, mdl.h(xm))
                x = xm + (K @ nu[..., None])[..., 0]
                IKH = I_n - K @ H
                P = IKH @ Pm @ np.swapaxes(IKH, -1, -2) + K @ mdl.R @ np.swapaxes(K, -1, -2)
                D = IKH @ Dm                                        # recurrent derivative, update
                # parameter EKF: measurement z = h(x⁻(θ)) + e, C = H D⁻, e ~ (0, S)
                C = H @ Dm
                St = C @ Pt_m @ np.swapaxes(C, -1, -2) + S
                Kt = np.swapaxes(solve_per_run(St, C @ Pt_m), -1, -2)
                th = th + (Kt @ nu[..., None])[..., 0]
                Pt = (np.eye(p) - Kt @ C) @ Pt_m
                Pt = 0.5 * (Pt + np.swapaxes(Pt, -1, -2))
                if self.clip_to_bounds:
                    th = np.clip(th, lo, hi)
                xs[:, k - 1], Ps[:, k - 1], ths[:, k - 1], Pts[:, k - 1] = x, P, th, Pt
                Ds[:, k - 1], Ks[:, k - 1] = D, K
                loglik[:, k - 1] = gaussian_loglik(nu, S)
        # divergence (as the EKF: non-finite estimates), judged run by run; a diverged run is
        # NaN from its first non-finite step on (no huge finite numbers before the NaN are
        # passed on as estimates: the step where x or theta first leaves the finite range)
        finite = np.isfinite(xs).all(axis=-1) & np.isfinite(ths).all(axis=-1)       # (runs, T)
        bad = ~finite.all(axis=1)
        diverged_at = np.where(bad, np.argmin(finite, axis=1) + 1, 0)
        if bad.any():
            msg = (f"DEKF: {int(bad.sum())} of {runs} runs diverged (non-finite estimates, first at step "
                   f"{int(diverged_at[bad].min())}) in runs {np.flatnonzero(bad)[:10].tolist()}")
            if self.on_divergence == "raise":
                raise FilterDivergenceError(msg)
            for r in np.flatnonzero(bad):
                sl = slice(diverged_at[r] - 1, None)
                for arr in (xs, Ps, ths, Pts, Ds, Ks, loglik):
                    arr[r, sl] = np.nan
            if self.on_divergence == "warn":
                warnings.warn(FilterDivergenceWarning(
                    msg + "; their estimates are NaN from diagnostics['diverged_at'] on "
                    "(on_divergence='drop' silences this, 'raise' makes it an error)"), stacklevel=2)
        return FilterResult(xs, Ps, diagnostics={
            "theta": ths[..., 0] if p == 1 else ths, "theta_var": Pts[..., 0, 0] if p == 1 else Pts,
            "dx_dtheta": Ds, "gain": Ks, "log_likelihood": loglik, "diverged": bad,
            "diverged_at": diverged_at,
            "n_diverged": int(bad.sum()),
        })

    def theta_quantiles(self, result: FilterResult, q):
        """Gaussian quantiles θ̂ + z_q √P^θ of the parameter EKF: shape (len(q), runs, T)."""
        from scipy.stats import norm

        th, v = result.diagnostics["theta"], result.diagnostics["theta_var"]
        return np.stack([th + norm.ppf(qq) * np.sqrt(np.maximum(v, 0.0)) for qq in check_quantile_levels(q, "q")])
