"""Dual particle filter (DPF) of Hou & Yin (2008), sec 4.2, batched over Monte Carlo runs.

Two filters alternate at every step k:

**State filter** (step 2): a bootstrap particle filter with ``n_x`` particles that treats
the current parameter estimate θ̂_{k-1} as known: x_k^i ~ p(x_k | x_{k-1}^i, θ̂_{k-1}),
w^i ∝ p(z_k | x_k^i), x̂_k = Σ w^i x_k^i, then resampling at every step (step 2e).

**Parameter filter** (step 3), Storvik's sufficient-statistics idea with a Beta law on
[r_l, r_u]: draw φ^i ~ Beta(α_{k-1}, β_{k-1}), θ^i = r_l + φ^i (r_u − r_l), i = 1..n_θ
(the Beta itself is the proposal, so the weight is the likelihood alone), weight each θ^i
by an approximation of p(z_k | θ^i, z_1:k-1) (eq 11), take the weighted mean and variance
(step 3d), and refit α_k, β_k by the method of moments (eq 7, :func:`beta_moment_fit`),
starting from α_0 = β_0 = 1 (uniform). The parameter particles are redrawn from the
refitted Beta at every step, so they never degenerate onto a few values.

**The parameter weight** (``weight=``) — eq (11) writes it as p(z_k | θ, x̂_k):

``"predictive"`` (default, our working reading)
    eq (11)'s E[x_k | θ, z_1:k-1], approximated by predicting from the previous state
    estimate under each θ: m^i = f(x̂_{k-1}, k, θ^i), scored with the *predictive*
    variance, p(z_k | θ^i) ≈ N(z_k; h(m^i), H_i P⁻ H_iᵀ + R), with
    P⁻ = F P_{k-1} Fᵀ + Q, F = ∂f/∂x at (x̂_{k-1}, θ̂_{k-1}), H_i = ∂h/∂x at m^i and
    P_{k-1} the state particles' weighted covariance. This is the linearised form of the
    integral in eq (11)'s second line; on a linear-Gaussian model with the exact
    conditional moments it *is* the exact p(z_k | θ, z_1:k-1).
``"plugin"``
    eq (11)'s third line as printed: the same m^i, variance R only (state uncertainty
    ignored: overconfident when H P⁻ Hᵀ is not small against R).
``"literal"``
    p(z_k | θ^i, x̂_k) with x̂_k the state filter's estimate: it does not depend on θ^i,
    so every weight is equal and the Beta only drifts by Monte Carlo noise.

**Failure guards of the refit** (all counted in ``diagnostics``): a weighted variance at or
above μ(1 − μ) makes α, β ≤ 0 (eq 7) and a vanishing one makes them infinite; the concentration
ν = α + β is then set to ``nu_min`` (the uniform prior's 2), or to the cap. **Cap**
(``cap``, the paper's unstated upper limit on α and β): max(α, β) ≤ cap, applied by
shrinking ν with the mean μ kept (capping α and β separately would move μ).

Parameters
----------
model : ParameterizedModel
    A :class:`~pfrepro.models.parameterized.ParameterizedModel` with scalar θ.
n_x, n_theta : int
    Particle numbers of the state and parameter filters (≥ 1).
weight : {"predictive", "plugin", "literal"}
    The parameter weight (above).
cap : float or None
    Upper limit on α and β (None means no cap, only the zero-variance guard).
theta0 : float, optional
    θ̂_0, the estimate the state filter uses at k = 1 (default the prior mean).
roughening : float or None
    None or Gordon et al.'s (1993) roughening constant K. After resampling, the
    state particles get N(0, (K E_j n_x^{-1/d})²) jitter per component j (E_j = range of
    the particles) — needed when the model has no process noise.
resampling : str
    Resampling scheme of the state filter (every step, as in step 2e).
theta_law : {"beta", "gaussian"}
    "beta" (the paper, default) or "gaussian", the comparison of sec 3.2 / Fig. 2.
    With "gaussian", step 3(a) draws θ^i ~ N(μ_θ, σ_θ²) with the mean and variance of the
    same fitted Beta(α_{k-1}, β_{k-1}) (same sufficient statistics, same guards and cap; at
    k = 1 the uniform prior's moments), and a draw outside [r_l, r_u] gets weight zero
    (the prior has no mass there): only the sampling law differs. The share of draws
    outside the range per step is ``diagnostics["outside"]``.
"""
from __future__ import annotations

import numpy as np
from scipy import special

from ..models.parameterized import as_theta
from ..validation import as_finite_float, check_positive_int, check_quantile_levels
from .base import FilterDivergenceError, FilterResult
# the family's shared set-up; check_parameterized and init_parameterized_filter stay importable from here
from .parameter_learning import ParameterLearningFilter, check_parameterized, init_parameterized_filter
from .particle import normalize_log_weights
from .resampling import check_scheme, resample_counts

__all__ = ["DualParticleFilter", "beta_moment_fit", "beta_moments", "weighted_mean_var", "roughen",
           "PARAMETER_WEIGHTS", "THETA_LAWS", "check_parameterized", "init_parameterized_filter"]

PARAMETER_WEIGHTS = ("predictive", "plugin", "literal")
#: sampling laws of the parameter draws (step 3a) — the paper's Beta, or a Gaussian with its moments
THETA_LAWS = ("beta", "gaussian")
#: status codes of :func:`beta_moment_fit`
FIT_OK, FIT_TOO_WIDE, FIT_ZERO_VAR, FIT_CAPPED = 0, 1, 2, 3
#: concentration used when the variance vanishes and no cap is set
NU_HARD_MAX = 1e12
_MU_EPS = 1e-12


def beta_moments(alpha, beta):
    """Mean and variance of Beta(α, β) (eq 6): μ = α/(α+β), σ² = αβ / ((α+β)²(α+β+1))."""
    alpha, beta = np.asarray(alpha, float), np.asarray(beta, float)
    s = alpha + beta
    return alpha / s, alpha * beta / (s * s * (s + 1.0))


def beta_moment_fit(mu, var, cap=None, nu_min: float = 2.0):
    """Method-of-moments Beta fit, eq (7), with the failure guards and the cap.

    α = μ²(1 − μ)/σ² − μ,   β = (μ(1 − μ)/σ² − 1)(1 − μ),

    i.e. α = μν, β = (1 − μ)ν with ν = α + β = μ(1 − μ)/σ² − 1.

    Parameters
    ----------
    mu, var : ndarray
        Means in (0, 1) and variances ≥ 0 (on the unit interval).
    cap : float or None
        None or the upper limit on max(α, β); ν is reduced with μ kept.
    nu_min : float
        Concentration used when σ² ≥ μ(1 − μ) (eq 7 gives α, β ≤ 0) or ν < nu_min.

    Returns
    -------
    alpha, beta : ndarray
        The Beta parameters.
    status : ndarray
        0 = eq (7) as is, 1 = too wide (ν floored at ``nu_min``), 2 = zero variance
        (ν set to the cap, or ``NU_HARD_MAX``), 3 = capped.
    """
    mu = np.clip(np.asarray(mu, dtype=float), _MU_EPS, 1.0 - _MU_EPS)
    var = np.asarray(var, dtype=float)
    if np.any(np.isnan(var)) or np.any(np.isnan(mu)):
        raise ValueError("beta_moment_fit: NaN mean or variance")
    if cap is not None and not cap > 0:
        raise ValueError(f"cap must be > 0 or None, got {cap}")
    status = np.zeros(np.broadcast_shapes(mu.shape, var.shape), dtype=np.int8)
    zero = var <= 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        nu = np.where(zero, np.inf, mu * (1.0 - mu) / np.where(zero, 1.0, var) - 1.0)
    wide = ~zero & (nu < nu_min)
    nu = np.where(wide, nu_min, nu)
    status[wide] = FIT_TOO_WIDE
    big = np.isinf(nu) | (nu > NU_HARD_MAX)
    nu = np.where(big, NU_HARD_MAX, nu)
    status[big] = FIT_ZERO_VAR
    if cap is not None:
        nu_cap = cap / np.maximum(mu, 1.0 - mu)   # max(α, β) = ν max(μ, 1 − μ) ≤ cap
        over = nu > nu_cap
        nu = np.where(over, nu_cap, nu)
        status[over & (status == FIT_OK)] = FIT_CAPPED
    return mu * nu, (1.0 - mu) * nu, status


def weighted_mean_var(w, theta):
    """Weighted mean and variance (step 3d, corrected): θ̂ = Σ wᵢθᵢ, σ² = Σ wᵢ(θᵢ − θ̂)².

    ``w`` (runs, N) normalised, ``theta`` (runs, N). (The paper prints Σ wᵢ θᵢ (θ̂ − θᵢ)², an
    extra factor θᵢ; see the chapter's errata.)
    """
    m = np.einsum("rn,rn->r", w, theta)
    d = theta - m[:, None]
    return m, np.einsum("rn,rn->r", w, d * d)


def roughen(x, K: float, rng):
    """Gordon, Salmond & Smith's (1993) roughening: x + N(0, diag(σ_j²)), σ_j = K E_j N^{-1/d}.

    ``x`` (runs, N, d); E_j is the range (max − min) of component j in each run.
    """
    runs, N, d = x.shape
    sd = K * (x.max(axis=1) - x.min(axis=1)) * N ** (-1.0 / d)      # (runs, d)
    return x + rng.standard_normal((runs, N, d)) * sd[:, None, :]


def _gauss_logpdf(nu, S):
    """log N(nu; 0, S) for nu (..., m), S (..., m, m) (tiny m)."""
    m = nu.shape[-1]
    if m == 1:
        s = S[..., 0, 0]
        return -0.5 * (nu[..., 0] ** 2 / s + np.log(2.0 * np.pi * s))
    L = np.linalg.cholesky(S)
    z = np.linalg.solve(L, nu[..., None])[..., 0]
    return -0.5 * np.sum(z * z, -1) - np.log(np.diagonal(L, axis1=-2, axis2=-1)).sum(-1) - 0.5 * m * np.log(2 * np.pi)


class DualParticleFilter(ParameterLearningFilter):
    """Hou & Yin's dual particle filter (module docstring)."""

    name = "DPF"
    needs_rng = True

    def __init__(self, model, n_x: int, n_theta: int, weight: str = "predictive", cap=None,
                 theta0=None, roughening=None, resampling: str = "systematic", nu_min: float = 2.0,
                 theta_law: str = "beta"):
        super().__init__(model, needs=("f", "h") if weight == "plugin" or weight == "literal"
                         else ("f", "h", "jacobian_f", "jacobian_h"))
        self.n_x = check_positive_int(n_x, "n_x")
        self.n_theta = check_positive_int(n_theta, "n_theta")
        if weight not in PARAMETER_WEIGHTS:
            raise ValueError(f"weight must be one of {PARAMETER_WEIGHTS}, got {weight!r}")
        self.weight = weight
        self.cap = None if cap is None else as_finite_float(cap, "cap", positive=True)
        lo, hi = model.bounds
        if theta0 is None:
            theta0 = 0.5 * (lo + hi)
        theta0 = float(as_theta(theta0, 1, "theta0")[0])
        if not lo <= theta0 <= hi:
            raise ValueError(f"theta0 = {theta0} lies outside the prior range {model.bounds}")
        self.theta0 = theta0
        self.roughening = None if roughening is None else as_finite_float(roughening, "roughening", positive=True)
        self.resampling = check_scheme(resampling)
        self.nu_min = as_finite_float(nu_min, "nu_min", positive=True)
        if theta_law not in THETA_LAWS:
            raise ValueError(f"theta_law must be one of {THETA_LAWS}, got {theta_law!r}")
        self.theta_law = theta_law

    # -- the parameter step -------------------------------------------------------------
    def parameter_loglik(self, z, theta, x_prev, P_prev, x_now, theta_prev, k):
        """log-weights of the parameter draws ``theta`` (runs, N_θ) at step k (module docstring)."""
        mdl = self.model
        runs = theta.shape[0]
        if self.weight == "literal":
            pred = np.broadcast_to(x_now[:, None, :], (runs, theta.shape[1], mdl.dim_x))
            return mdl.log_likelihood(z, pred)
        m = mdl.f(x_prev[:, None, :], k, theta[..., None])            # (runs, Nθ, dx)
        if self.weight == "plugin":
            return mdl.log_likelihood(z, m)
        F = mdl.jacobian_f(x_prev, k, theta_prev[:, None])            # (runs, dx, dx)
        Pm = F @ P_prev @ np.swapaxes(F, -1, -2) + mdl.Q
        H = mdl.jacobian_h(m)                                          # (runs, Nθ, dy, dx)
        S = H @ Pm[:, None] @ np.swapaxes(H, -1, -2) + mdl.R
        zz = np.asarray(z, float)[:, None, :]
        return _gauss_logpdf(mdl.residual_y(zz, mdl.h(m)), S)

    def filter(self, y, rng=None) -> FilterResult:
        y = self._prepare(y, rng)
        mdl = self.model
        runs, T, _ = y.shape
        Nx, Nt, n = self.n_x, self.n_theta, mdl.dim_x
        lo, hi = mdl.bounds
        width = hi - lo
        x = self.sample_prior(rng, (runs, Nx))
        x_hat = np.broadcast_to(self.m0, (runs, n)).copy()
        P_hat = np.broadcast_to(self.P0, (runs, n, n)).copy()
        alpha = np.ones(runs)
        beta = np.ones(runs)
        theta_hat = np.full(runs, self.theta0)
        xs = np.empty((runs, T, n))
        Ps = np.empty((runs, T, n, n))
        th = np.empty((runs, T))
        th_var = np.empty((runs, T))
        alphas = np.empty((runs, T))
        betas = np.empty((runs, T))
        status = np.empty((runs, T), dtype=np.int8)
        ess_x = np.empty((runs, T))
        ess_t = np.empty((runs, T))
        coll_x = np.zeros((runs, T), bool)
        coll_t = np.zeros((runs, T), bool)
        outside = np.zeros((runs, T))
        for k in range(1, T + 1):
            z = y[:, k - 1]
            # (2) state filter, conditioned on θ̂_{k-1}
            x = mdl.sample_transition(x, k, theta_hat[:, None, None], rng)
            if not np.all(np.isfinite(x)):
                raise FilterDivergenceError(f"DPF state particles became non-finite at step {k}")
            w, _, cx = normalize_log_weights(mdl.log_likelihood(z, x))
            coll_x[:, k - 1] = cx
            ess_x[:, k - 1] = 1.0 / np.sum(w * w, axis=1)
            x_new = np.einsum("rn,rni->ri", w, x)
            d = x - x_new[:, None, :]
            P_new = np.einsum("rn,rni,rnj->rij", w, d, d)
            counts = resample_counts(w, rng, self.resampling)
            x = np.repeat(x.reshape(runs * Nx, n), counts.ravel(), axis=0).reshape(runs, Nx, n)
            if self.roughening is not None:
                x = roughen(x, self.roughening, rng)
            # (3) parameter filter: draw from Beta(α_{k-1}, β_{k-1}), weight, refit (eq 7)
            if self.theta_law == "beta":
                phi = rng.beta(alpha[:, None], beta[:, None], size=(runs, Nt))
            else:  # a Gaussian with the fitted Beta's moments (sec 3.2's comparison)
                mu_b, var_b = beta_moments(alpha, beta)
                phi = mu_b[:, None] + np.sqrt(var_b)[:, None] * rng.standard_normal((runs, Nt))
            out = (phi < 0.0) | (phi > 1.0)
            outside[:, k - 1] = out.mean(axis=1)
            theta = lo + width * phi
            logw = self.parameter_loglik(z, theta, x_hat, P_hat, x_new, theta_hat, k)
            if self.theta_law == "gaussian":
                logw = np.where(out, -np.inf, logw)   # no prior mass outside [r_l, r_u]
            wt, _, ct = normalize_log_weights(logw)
            coll_t[:, k - 1] = ct
            ess_t[:, k - 1] = 1.0 / np.sum(wt * wt, axis=1)
            mu_t, var_t = weighted_mean_var(wt, theta)
            alpha, beta, st = beta_moment_fit((mu_t - lo) / width, var_t / width**2, self.cap, self.nu_min)
            status[:, k - 1] = st
            mu_fit, var_fit = beta_moments(alpha, beta)
            theta_hat = lo + width * mu_fit
            xs[:, k - 1], Ps[:, k - 1] = x_new, P_new
            th[:, k - 1], th_var[:, k - 1] = theta_hat, var_fit * width**2
            alphas[:, k - 1], betas[:, k - 1] = alpha, beta
            x_hat, P_hat = x_new, P_new
        return FilterResult(xs, Ps, diagnostics={
            "theta": th, "theta_var": th_var, "alpha": alphas, "beta": betas, "fit_status": status,
            # per-run counts (runs axis first, so chunked Monte Carlo results concatenate)
            "n_too_wide": (status == FIT_TOO_WIDE).sum(axis=1), "n_zero_var": (status == FIT_ZERO_VAR).sum(axis=1),
            "n_capped": (status == FIT_CAPPED).sum(axis=1), "ess_x": ess_x, "ess_theta": ess_t,
            "collapsed_x": coll_x, "collapsed_theta": coll_t,
            "likelihood_evaluations_per_step": Nx + Nt, "outside": outside,
        })

    def theta_quantiles(self, result: FilterResult, q):
        """Quantiles ``q`` of the fitted Beta laws, on [r_l, r_u]: shape (len(q), runs, T)."""
        lo, hi = self.model.bounds
        a, b = result.diagnostics["alpha"], result.diagnostics["beta"]
        return np.stack([lo + (hi - lo) * special.betaincinv(a, b, qq) for qq in check_quantile_levels(q, "q")])

    def __repr__(self) -> str:
        return (f"DualParticleFilter(n_x={self.n_x}, n_theta={self.n_theta}, weight={self.weight!r}, "
                f"cap={self.cap}, roughening={self.roughening}, theta_law={self.theta_law!r})")
