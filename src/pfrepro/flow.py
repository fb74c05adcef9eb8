"""Particle-flow mathematics of the Gaussian particle flow filter (Zhang, Zhou & Feng 2016).

Notation (the paper's, with the prior of step k written m, P):

* homotopy q(x, lambda) ∝ g(x) h(x)^lambda, lambda in [0, 1]            (eq 4)
* flow dx/dlambda = f(x, lambda)                                         (eq 5)
* linear-Gaussian case, g = N(m, P), h(x) = N(y; H x, R): q(., lambda) is the
  Kalman posterior with measurement covariance R / lambda, with mean x_lambda and
  covariance P_lambda (eqs 12, 25, 26), and the flow is affine,
  f = A(lambda) x + b(lambda) (eqs 13, 22, 24, 27) with, written with the prior
  covariance only (the reading under which eqs 24-27 hold; see the chapter),

      A(lambda) = -1/2 P H^T (lambda H P H^T + R)^{-1} H                      (24)
      b(lambda) = (I + 2 lambda A) [(I + lambda A) P H^T R^{-1} y + A m]      (27)

* nonlinear case (sec 4): P H^T -> Pxy, H P H^T -> Pyy, H m -> y_hat, H x -> h(x),
  which gives (our corrected eq 46, with C = (lambda Pyy + R)^{-1})

      f(x, lambda) = 1/2 Pxy C [ (y - h(x)) + R C (y - y_hat) ].

Every function is batched over leading axes: means ``(..., d)``, covariances
``(..., d, d)``, particle clouds ``(runs, N, d)`` with per-run matrices ``(runs, ...)``.
"""
from __future__ import annotations

import numpy as np

__all__ = ["lambda_schedule", "homotopy_moments", "affine_flow_coefficients", "affine_flow_field",
           "flow_moment_rhs", "kalman_bucy_rhs", "exact_affine_map", "gaussian_flow_field",
           "flow_field_coefficients", "field_from_coefficients",
           "nonlinear_coefficients", "integrate_flow", "stage_lambdas", "affine_flow_map", "AffineField", "solve_per_run",
           "INTEGRATORS", "SCHEDULES"]

#: integrators of the flow ODE in lambda and their orders
INTEGRATORS = {"euler": 1, "midpoint": 2, "rk4": 4}
#: lambda schedules
SCHEDULES = ("uniform", "exponential")


# ----------------------------------------------------------------------------- checks
def _finite(a, name):
    a = np.asarray(a, dtype=float)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or infinite entries")
    return a


def _check_cov(P, name):
    P = _finite(P, name)
    if P.ndim < 2 or P.shape[-1] != P.shape[-2]:
        raise ValueError(f"{name} must be (..., n, n), got shape {P.shape}")
    scale = np.maximum(np.max(np.abs(P), axis=(-2, -1)), np.finfo(float).tiny)
    if np.any(np.max(np.abs(P - np.swapaxes(P, -1, -2)), axis=(-2, -1)) > 1e-9 * scale):
        raise ValueError(f"{name} is not symmetric")
    try:
        np.linalg.cholesky(0.5 * (P + np.swapaxes(P, -1, -2)))
    except np.linalg.LinAlgError:
        raise ValueError(f"{name} is not positive definite") from None
    return 0.5 * (P + np.swapaxes(P, -1, -2))


def _check_linear(m, P, H, R, y):
    m = _finite(m, "m")
    P = _check_cov(P, "P")
    R = _check_cov(R, "R")
    H = _finite(H, "H")
    y = _finite(y, "y")
    d, mdim = P.shape[-1], R.shape[-1]
    if m.shape[-1] != d:
        raise ValueError(f"m has length {m.shape[-1]} but P is {d}x{d}")
    if H.shape[-2:] != (mdim, d):
        raise ValueError(f"H must be ({mdim}, {d}), got {H.shape[-2:]}")
    if y.shape[-1] != mdim:
        raise ValueError(f"y has length {y.shape[-1]} but R is {mdim}x{mdim}")
    return m, P, H, R, y


def _check_lam(lam):
    lam = float(lam)
    if not (0.0 <= lam <= 1.0) or not np.isfinite(lam):
        raise ValueError(f"lambda must lie in [0, 1], got {lam}")
    return lam


def _T(a):
    return np.swapaxes(a, -1, -2)


def _mv(A, v):
    return np.einsum("...ij,...j->...i", A, v)


# ----------------------------------------------------------------------------- schedules
def lambda_schedule(n_steps: int = 20, kind: str = "uniform", ratio: float = 1.2) -> np.ndarray:
    """Pseudo-time grid 0 = lambda_0 < lambda_1 < ... < lambda_n = 1 for the flow.

    ``kind="uniform"``: Delta lambda = 1/n (the paper, sec 5: Delta lambda = 0.05, n = 20).
    ``kind="exponential"``: Delta lambda_j = Delta lambda_1 ratio^(j-1) with
    Delta lambda_1 = (ratio - 1)/(ratio^n - 1) (small steps first, where the field changes
    fastest; the EDH literature, e.g. Li & Coates 2017, uses ratio 1.2).
    The returned grid starts at exactly 0 and ends at exactly 1, so the steps
    ``np.diff(grid)`` sum to 1 (up to the rounding of the differences).
    """
    if isinstance(n_steps, bool) or int(n_steps) != n_steps or n_steps < 1:
        raise ValueError(f"n_steps must be an integer >= 1, got {n_steps!r}")
    n = int(n_steps)
    if kind == "uniform":
        grid = np.arange(n + 1) / n
    elif kind == "exponential":
        ratio = float(ratio)
        if not np.isfinite(ratio) or ratio <= 0:
            raise ValueError(f"ratio must be positive, got {ratio}")
        if ratio == 1.0:
            grid = np.arange(n + 1) / n
        else:
            steps = ratio ** np.arange(n)
            grid = np.concatenate([[0.0], np.cumsum(steps)]) / steps.sum()
    else:
        raise ValueError(f"unknown schedule {kind!r}; choose from {SCHEDULES}")
    grid[0], grid[-1] = 0.0, 1.0
    return grid


# ----------------------------------------------------------------------------- linear case
def homotopy_moments(m, P, H, R, y, lam):
    """Mean and covariance of q(x, lambda) for the linear-Gaussian homotopy (eqs 12, 25, 26).

    q(., lambda) is the Kalman posterior of the prior N(m, P) given y with
    measurement covariance R / lambda:
    P_lambda = P - lambda P H^T (lambda H P H^T + R)^{-1} H P   (= P + 2 lambda A P, eq 26),
    x_lambda = m + lambda P H^T (lambda H P H^T + R)^{-1} (y - H m)   (eq 25, corrected).
    """
    m, P, H, R, y = _check_linear(m, P, H, R, y)
    lam = _check_lam(lam)
    PHt = P @ _T(H)
    S = lam * H @ PHt + R
    G = _T(np.linalg.solve(S, _T(PHt)))  # P H^T (lam M + R)^{-1}
    x_lam = m + lam * _mv(G, y - _mv(H, m))
    P_lam = P - lam * G @ _T(PHt)
    return x_lam, 0.5 * (P_lam + _T(P_lam))


def affine_flow_coefficients(m, P, H, R, y, lam):
    """A(lambda), b(lambda) of the linear-Gaussian flow f = A x + b (eqs 24, 27), prior-only form.

    ``m``, ``P`` are the *prior* mean and covariance (x_{k|k-1}, P_{k|k-1}); see the
    chapter's errata for the printed P^lambda_{k|k} in eqs (23)-(25), (27).
    """
    m, P, H, R, y = _check_linear(m, P, H, R, y)
    lam = _check_lam(lam)
    PHt = P @ _T(H)
    S = lam * H @ PHt + R
    A = -0.5 * _T(np.linalg.solve(S, _T(PHt))) @ H
    I = np.eye(P.shape[-1])
    g = _mv(PHt, np.linalg.solve(R, y[..., None])[..., 0])  # P H^T R^{-1} y
    b = _mv(I + 2 * lam * A, _mv(I + lam * A, g) + _mv(A, m))
    return A, b


def affine_flow_field(x, lam, m, P, H, R, y):
    """f(x, lambda) = A(lambda) x + b(lambda) for states/particles ``x`` (..., N, d) or (..., d).

    Matrices carry the leading (runs) axes of ``x`` minus its particle axis.
    """
    A, b = affine_flow_coefficients(m, P, H, R, y, lam)
    x = np.asarray(x, float)
    if x.ndim == A.ndim:  # (..., N, d) with A (..., d, d)
        return x @ _T(A) + b[..., None, :]
    return _mv(A, x) + b


def flow_moment_rhs(mean, cov, lam, m, P, H, R, y):
    """d/dlambda of the mean and covariance of a cloud moved by the affine flow.

    For f = A x + b: d mean/dlambda = A mean + b, d cov/dlambda = A cov + cov A^T.
    Integrated from (m, P) at lambda = 0, these land on the Kalman posterior at lambda = 1.
    """
    A, b = affine_flow_coefficients(m, P, H, R, y, lam)
    return _mv(A, mean) + b, A @ cov + cov @ _T(A)


def kalman_bucy_rhs(mean, cov, H, R, y):
    """Kalman-Bucy filter in pseudo-time lambda with zero drift and zero process noise (eqs 39, 40).

    K = cov H^T R^{-1}; d mean/dlambda = K (y - H mean); d cov/dlambda = -K R K^T.
    """
    K = _T(np.linalg.solve(R, H @ cov))  # cov H^T R^{-1} (cov, R symmetric)
    return _mv(K, y - _mv(H, mean)), -K @ R @ _T(K)


def exact_affine_map(m, P, H, R, y, lam=1.0):
    """Exact solution of the affine flow from 0 to ``lam``: x(lam) = x_lam + Phi (x(0) - m).

    The A(lambda) of eq (24) commute for all lambda, so Phi = expm(int_0^lam A); in
    whitened coordinates (L_P, L_R Cholesky factors of P, R; Ht = L_R^{-1} H L_P)
    it is the symmetric square root Phi = L_P (I + lam Ht^T Ht)^{-1/2} L_P^{-1},
    hence Phi P Phi^T = P_lam. Returns ``(x_lam, Phi)``.
    """
    m, P, H, R, y = _check_linear(m, P, H, R, y)
    lam = _check_lam(lam)
    Lp = np.linalg.cholesky(P)
    Lr = np.linalg.cholesky(R)
    Ht = np.linalg.solve(Lr, H @ Lp)
    s, V = np.linalg.eigh(_T(Ht) @ Ht)
    D = (1.0 + lam * np.clip(s, 0.0, None)) ** -0.5
    core = (V * D[..., None, :]) @ _T(V)
    Phi = Lp @ core @ np.linalg.inv(Lp)
    x_lam, _ = homotopy_moments(m, P, H, R, y, lam)
    return x_lam, Phi


# ----------------------------------------------------------------------------- per-run linear algebra
def solve_per_run(A, B):
    """``np.linalg.solve(A, B)`` over a batch of matrices, one run unable to spoil another.

    numpy's batched solve factorises each matrix on its own (run i's result does not depend
    on the other matrices), but raises ``LinAlgError`` for the *whole* batch when one matrix
    is singular. Here the batch is tried first (the common case, bit-identical); on failure
    each matrix is solved alone and a singular one gives NaN in its own run only, which the
    caller's divergence check then marks.
    """
    try:
        return np.linalg.solve(A, B)
    except np.linalg.LinAlgError:
        pass
    lead = np.broadcast_shapes(A.shape[:-2], B.shape[:-2])
    A = np.broadcast_to(A, lead + A.shape[-2:])
    B = np.broadcast_to(B, lead + B.shape[-2:])
    out = np.empty(lead + B.shape[-2:])
    for idx in np.ndindex(*lead):
        try:
            out[idx] = np.linalg.solve(A[idx], B[idx])
        except np.linalg.LinAlgError:
            out[idx] = np.nan
    return out


# ----------------------------------------------------------------------------- nonlinear case
def _solve_sym(S, B):
    """``S^{-1} B`` for a batch of small matrices ``S`` (..., n, n), ``B`` (..., n, k), each run
    on its own (a singular ``S`` gives non-finite numbers in its own run only)."""
    if S.shape[-1] == 1:
        # scalar measurement: LAPACK's 1 x 1 solve is this division (bit-identical),
        # without np.linalg's per-call overhead (the flow calls it 2 x 20-80 times a step)
        return B / S
    if S.shape[-1] == 2:
        # 2 x 2 (e.g. two bearings): Cramer's rule, elementwise over the batch, instead of one
        # LAPACK factorisation per matrix (the GPFF solves 2 x L x runs of them a time step);
        # for the symmetric positive definite lambda Pyy + R its error is of the order of
        # cond(S) times the rounding unit, as LU's
        a, b, c, d = S[..., 0:1, 0:1], S[..., 0:1, 1:2], S[..., 1:2, 0:1], S[..., 1:2, 1:2]
        det = a * d - b * c
        B0, B1 = B[..., 0:1, :], B[..., 1:2, :]
        return np.concatenate([(d * B0 - b * B1) / det, (a * B1 - c * B0) / det], axis=-2)
    return solve_per_run(S, B)


def flow_field_coefficients(lam, y, y_hat, Pxy, Pyy, R, residual=None):
    """The particle-independent parts of :func:`gaussian_flow_field` at pseudo-time ``lam``.

    Returns ``(G, c)``: ``G = Pxy C`` (runs, d, m) and ``c = R C r(y, y_hat)`` (runs, m),
    ``C = (lam Pyy + R)^{-1}``, so that f = 1/2 [r(y, h(x)) + c] G^T. They depend on
    ``lam`` but not on the particles: an integrator that evaluates the field several
    times at one ``lam`` (RK4's two midpoint stages; a step's end is the next step's
    start) can compute them once.
    """
    r = (lambda a, b: a - b) if residual is None else residual
    S = lam * Pyy + R
    PT, rr = _T(np.asarray(Pxy, float)), r(y, y_hat)[..., None]
    if S.shape[-1] <= 2 and PT.shape[:-2] == rr.shape[:-2]:
        # one elementwise solve for both right-hand sides (a division or Cramer's rule: every
        # entry is the same formula on the same numbers as with two solves)
        X = _solve_sym(S, np.concatenate([PT, rr], axis=-1))
        G, z = _T(X[..., :-1]), X[..., -1]              # Pxy C (runs, d, m); C r(y, y_hat)
    else:
        G = _T(_solve_sym(S, PT))                       # Pxy C        (runs, d, m)
        z = _solve_sym(S, rr)[..., 0]
    # R z; a scalar measurement: one product (the same number as the 1 x 1 einsum)
    c = R[..., 0, :] * z if R.shape[-1] == 1 else _mv(R, z)  # R C r(y, y_hat) (runs, m)
    return G, c


def field_from_coefficients(h_x, y, G, c, residual=None):
    """f = 1/2 [r(y, h(x)) + c] G^T from :func:`flow_field_coefficients` (see
    :func:`gaussian_flow_field`); ``h_x`` (runs, N, m) -> (runs, N, d)."""
    r = (lambda a, b: a - b) if residual is None else residual
    inner = r(y[..., None, :], h_x) + c[..., None, :]   # (runs, N, m)
    return 0.5 * inner @ _T(G)


def gaussian_flow_field(x, lam, h_x, y, y_hat, Pxy, Pyy, R, residual=None):
    """The GPFF field for nonlinear h (sec 4, eqs 41-46, corrected), at particles ``x``.

    f(x, lambda) = B(lambda) h(x) + u(lambda)
                 = 1/2 Pxy C [ r(y, h(x)) + R C r(y, y_hat) ],   C = (lambda Pyy + R)^{-1},

    where r(a, b) = a - b (or ``residual(a, b)`` for wrapped measurements such as
    angles). Shapes: ``h_x`` (runs, N, m) = h at the particles; ``y``, ``y_hat`` (runs, m);
    ``Pxy`` (runs, d, m); ``Pyy`` (runs, m, m); ``R`` (m, m). Returns (runs, N, d).
    With linear h (Pxy = P H^T, Pyy = H P H^T, y_hat = H m) this is eq (27)'s
    A x + b exactly. ``x`` is unused (the field depends on x only through h(x)).
    """
    G, c = flow_field_coefficients(lam, y, y_hat, Pxy, Pyy, R, residual)
    return field_from_coefficients(h_x, y, G, c, residual)


def nonlinear_coefficients(lam, y, y_hat, Pxy, Pyy, R, form="corrected"):
    """B(lambda) and u(lambda) of eq (46), as printed or corrected (for the chapter's checks).

    ::

        Printed (sec 4):  B = -1/2 Pyy C,  u = U/2 y + V/2 y_hat,
            U = lam^2 S Pyy + 2 Pxy + 6 lam B Pyy,  V = 2 B + lam S,
            S = Pxy C Pyy C,  C = (lam Pyy + R)^{-1}.
        Corrected:        B = -1/2 Pxy C,  u = U/2 R^{-1} y + V/2 y_hat (same U, V, S, C).

    The printed B is m x m where a d x m matrix is needed, so with d != m the
    printed products fail (numpy raises ``ValueError``); with d == m they run but
    give the wrong field. Returns ``(B, u)``; f(x) = B h(x) + u.
    """
    if form not in ("printed", "corrected"):
        raise ValueError("form must be 'printed' or 'corrected'")
    C = np.linalg.inv(lam * Pyy + R)
    S = Pxy @ C @ Pyy @ C
    B = -0.5 * (Pyy if form == "printed" else Pxy) @ C
    U = lam**2 * S @ Pyy + 2 * Pxy + 6 * lam * B @ Pyy
    V = 2 * B + lam * S
    yy = y if form == "printed" else _mv(np.linalg.inv(R), y)
    u = 0.5 * _mv(U, yy) + 0.5 * _mv(V, y_hat)
    return B, u


# ----------------------------------------------------------------------------- integration
def integrate_flow(x, field, grid, method: str = "euler"):
    """Move particles ``x`` (..., d) along dx/dlambda = field(x, lambda) over ``grid``.

    ``grid`` is a lambda grid from :func:`lambda_schedule` (0 ... 1); ``method`` is
    "euler" (the paper), "midpoint" (RK2) or "rk4". Vectorised over every leading axis.
    An :class:`AffineField` is integrated in closed form (:func:`affine_flow_map`, the same
    map up to rounding); any other callable, a wrapper around an :class:`AffineField`
    included, is stepped.
    """
    if isinstance(field, AffineField):      # its own grid and integrator, checked there
        return field.integrate(x, grid, method)
    if method not in INTEGRATORS:
        raise ValueError(f"unknown integrator {method!r}; choose from {sorted(INTEGRATORS)}")
    grid = np.asarray(grid, float)
    if grid.ndim != 1 or grid.size < 2 or np.any(np.diff(grid) <= 0):
        raise ValueError("grid must be an increasing 1-D array of at least two lambdas")
    x = np.array(x, dtype=float)
    for l0, l1 in zip(grid[:-1], grid[1:]):
        h = l1 - l0
        if method == "euler":
            x += h * field(x, l0)
        elif method == "midpoint":
            k1 = field(x, l0)
            x += h * field(x + 0.5 * h * k1, l0 + 0.5 * h)
        else:
            k1 = field(x, l0)
            k2 = field(x + 0.5 * h * k1, l0 + 0.5 * h)
            k3 = field(x + 0.5 * h * k2, l0 + 0.5 * h)
            k4 = field(x + h * k3, l1)
            x += (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


# ----------------------------------------------------------------------------- affine fields in closed form
def stage_lambdas(grid, method: str = "euler"):
    """The pseudo-times at which :func:`integrate_flow` evaluates the field on ``grid``.

    Returns ``(lams, index)``: ``lams`` the distinct lambdas in the order of first use (the
    grid points and, for "midpoint"/"rk4", the midpoints ``l0 + 0.5 * h`` with the
    integrator's own arithmetic), and ``index`` (n_steps, stages) the position in ``lams`` of
    each step's stage lambdas: (l0,) for "euler", (l0, l0 + h/2) for "midpoint",
    (l0, l0 + h/2, l1) for "rk4" (RK4's two midpoint stages share one lambda). Both arrays
    are read-only (computed once per grid and integrator).
    """
    plan = _plan(grid, method)
    return plan[0], plan[1]


_PLANS: dict = {}


def _plan(grid, method):
    """``(lams, index, h, cols, at)`` of :func:`stage_lambdas` with the steps ``h`` (n_steps,),
    each stage column of ``index`` as a slice where it is a progression (a view, not a copy)
    and ``at`` = {lambda: position in lams}, cached by grid and integrator."""
    if method not in INTEGRATORS:
        raise ValueError(f"unknown integrator {method!r}; choose from {sorted(INTEGRATORS)}")
    grid = np.asarray(grid, float)
    key = (method, grid.tobytes())
    plan = _PLANS.get(key)
    if plan is not None:
        return plan
    if grid.ndim != 1 or grid.size < 2 or np.any(np.diff(grid) <= 0):
        raise ValueError("grid must be an increasing 1-D array of at least two lambdas")
    at, rows = {}, []
    for l0, l1 in zip(grid[:-1], grid[1:]):
        stages = [l0]
        if method in ("midpoint", "rk4"):
            stages.append(l0 + 0.5 * (l1 - l0))
        if method == "rk4":
            stages.append(l1)
        rows.append([at.setdefault(float(lam), len(at)) for lam in stages])
    lams, index = np.asarray(list(at), float), np.asarray(rows, dtype=np.intp)
    cols = []
    for col in index.T:
        step = col[1] - col[0] if col.size > 1 else 1
        prog = step > 0 and np.array_equal(col, col[0] + step * np.arange(col.size))
        cols.append(slice(int(col[0]), int(col[-1]) + 1, int(step)) if prog else col)
    for a in (lams, index):
        a.setflags(write=False)
    plan = (lams, index, np.diff(grid), tuple(cols), {lam: i for i, lam in enumerate(lams.tolist())})
    if len(_PLANS) < 64:
        _PLANS[key] = plan
    return plan


def affine_flow_map(A, b, grid, method: str = "euler", stages=None):
    """The map of :func:`integrate_flow` over ``grid`` for an affine field, in closed form.

    For a field affine in the state, f(u, lambda) = u A(lambda) + b(lambda) (row vectors u, b
    of length d; the eq-43 field of the GPFF with a plain residual, and the linear-Gaussian
    flow of eqs 24, 27, are of this form), every stage of an Euler, midpoint or RK4 step is
    affine in the step's start u, k_i = u K_i + kappa_i, with (h the step, l0, lm = l0 + h/2,
    l1 its stage lambdas)

    * K1 = A(l0), kappa1 = b(l0);
    * K2 = (I + h/2 K1) A(lm), kappa2 = h/2 kappa1 A(lm) + b(lm); K3 likewise from K2;
    * K4 = (I + h K3) A(l1), kappa4 = h kappa3 A(l1) + b(l1);

    so a step is u -> u M_j + v_j with M_j = I + h K1, v_j = h kappa1 (Euler),
    M_j = I + h K2, v_j = h kappa2 (midpoint, from l0 and lm), or
    M_j = I + h/6 (K1 + 2 K2 + 2 K3 + K4), v_j likewise (RK4), and the whole integration is
    u(1) = u(0) M + v with M = M_1 M_2 ... M_n. Every step's map is built at once over all
    steps (batched over the lambda axis), and the maps are composed by a pairwise tree of
    stacked products of the augmented matrices [[M_j, 0], [v_j, 1]] (about log2(n) batched
    calls; for d = 1 by a cumulative product), instead of n sequential steps of d + 1 probe
    points. The result equals integrating with :func:`integrate_flow` up to rounding.

    Parameters
    ----------
    A : ndarray
        (L, ..., d, d): A(lambda) at the distinct stage lambdas ``lams`` of
        :func:`stage_lambdas` ``(grid, method)``, leading axis in that order.
    b : ndarray
        (L, ..., d): b(lambda) at the same lambdas.
    grid : array_like
        The lambda grid (:func:`lambda_schedule`).
    method : str
        "euler", "midpoint" or "rk4".
    stages : tuple, optional
        ``stage_lambdas(grid, method)`` if the caller has it already (not recomputed).

    Returns
    -------
    M : ndarray
        (..., d, d), the linear part (acting on row vectors: u M).
    v : ndarray
        (..., d), the offset.

    Notes
    -----
    Every product is a stacked matrix product over the batch axes, one small matrix at a
    time, so a run's map does not depend on the other runs of the batch.
    """
    lams, index, hs, cols, _ = _plan(grid, method)
    if stages is not None and stages[1] is not index and (
            len(stages[0]) != len(lams) or not np.array_equal(stages[1], index)):
        raise ValueError("stages are not stage_lambdas(grid, method)")
    A = np.asarray(A, float)
    b = np.asarray(b, float)
    if A.ndim < 3 or A.shape[-1] != A.shape[-2] or A.shape[0] != lams.size:
        raise ValueError(f"A must be (L, ..., d, d) with L = {lams.size} stage lambdas, got shape {A.shape}")
    if b.shape != A.shape[:-1]:
        raise ValueError(f"b must be {A.shape[:-1]} (A's shape without the last axis), got {b.shape}")
    d = A.shape[-1]
    if d == 1:
        # scalars: the same formulas on (L, batch) arrays, products of scalars
        lead = A.shape[1:-2]
        M, v = _step_maps(A.reshape(lams.size, -1), b.reshape(lams.size, -1), hs[:, None], cols, method,
                          np.multiply, 1.0)
        # M = prod_j M_j, v = sum_j v_j prod_{k > j} M_k (suffix products by a cumulative product)
        S = np.cumprod(M[::-1], axis=0)[::-1]
        # the sum over steps along a contiguous axis (numpy's pairwise sum) whatever the batch:
        # a sum over axis 0 of (n, batch) would be pairwise for one run and sequential for
        # several, and a run's numbers would depend on its batch
        vt = np.ascontiguousarray((v[:-1] * S[1:]).T).sum(axis=-1) + v[-1]
        return S[0].reshape(lead + (1, 1)), vt.reshape(lead + (1,))
    h = hs.reshape((-1,) + (1,) * (A.ndim - 1))                       # (n, 1, ..., 1, 1)
    M, v = _step_maps(A, b[..., None, :], h, cols, method, np.matmul, np.eye(d))
    # compose u -> u M_1 + v_1 -> ... -> u M_1 ... M_n + v: augmented matrices
    # E = [[M, 0], [v, 1]] acting on [u, 1], multiplied in order by pairs
    E = np.zeros(M.shape[:-2] + (d + 1, d + 1))
    E[..., :d, :d] = M
    E[..., d:, :d] = v
    E[..., d, d] = 1.0
    while E.shape[0] > 1:
        k = E.shape[0] // 2
        P = E[0:2 * k:2] @ E[1:2 * k:2]
        E = P if E.shape[0] == 2 * k else np.concatenate([P, E[-1:]])
    return E[0, ..., :d, :d], E[0, ..., d, :d]


def _step_maps(A, b, h, cols, method, mm, I):
    """Each step's map u -> u M_j + v_j of :func:`affine_flow_map` (see there), for all steps at
    once: ``A`` (L, ..., d, d) / ``b`` (L, ..., 1, d) at the stage lambdas, ``cols`` the
    stage columns, ``mm`` the product (matmul, or multiply for scalars), ``I`` the identity."""
    K1, k1 = A[cols[0]], b[cols[0]]
    if method == "euler":
        return I + h * K1, h * k1
    hh = 0.5 * h
    Am, bm = A[cols[1]], b[cols[1]]
    K2, k2 = mm(I + hh * K1, Am), mm(hh * k1, Am) + bm
    if method == "midpoint":
        return I + h * K2, h * k2
    A1, b1 = A[cols[2]], b[cols[2]]
    K3, k3 = mm(I + hh * K2, Am), mm(hh * k2, Am) + bm
    K4, k4 = mm(I + h * K3, A1), mm(h * k3, A1) + b1
    h6 = h / 6.0
    return I + h6 * (K1 + 2.0 * (K2 + K3) + K4), h6 * (k1 + 2.0 * (k2 + k3) + k4)


class AffineField:
    """A flow field affine in the state, f(z, lambda) = (z - origin) A(lambda) + b(lambda),
    tabulated at the stage lambdas of one grid and integrator (row vectors).

    Called as ``field(z, lam)`` it is an ordinary field (``z`` (..., K, d) -> (..., K, d)) at
    any of those lambdas; :func:`integrate_flow` recognises it and, instead of stepping,
    applies the integrator's whole map over the grid in closed form (:func:`affine_flow_map`):
    z(1) = origin + (z(0) - origin) M + v.

    Parameters
    ----------
    A : ndarray
        (L, ..., d, d), A(lambda) at ``stage_lambdas(grid, method)[0]``.
    b : ndarray
        (L, ..., d), b(lambda) at the same lambdas.
    origin : ndarray
        (..., d), the point about which the field is written (the GPFF: the prior mean).
    grid : array_like
        The lambda grid the field is tabulated for.
    method : str
        The integrator ("euler", "midpoint", "rk4").
    stages : tuple, optional
        ``stage_lambdas(grid, method)`` if the caller has it already (not recomputed).
    """

    def __init__(self, A, b, origin, grid, method="euler", stages=None):
        self.grid = np.asarray(grid, float)
        self.method = method
        plan = _plan(self.grid, method)
        self.stages = plan[:2] if stages is None else stages
        self.A, self.b, self.origin = A, b, origin
        self._at = plan[4]

    def __call__(self, z, lam):
        i = self._at[float(lam)]
        return (z - self.origin[..., None, :]) @ self.A[i] + self.b[i][..., None, :]

    def map(self):
        """``(M, v)`` of :func:`affine_flow_map` over the field's grid and integrator."""
        return affine_flow_map(self.A, self.b, self.grid, self.method, stages=self.stages)

    def integrate(self, z, grid, method):
        """``z`` (..., K, d) moved over ``grid`` with ``method`` in closed form (the tabulated grid
        and integrator only: another raises ``ValueError``)."""
        grid = np.asarray(grid, float)
        if method != self.method or (grid is not self.grid and not (
                grid.shape == self.grid.shape and np.array_equal(grid, self.grid))):
            raise ValueError(f"this AffineField is tabulated for the {self.method!r} integrator on its own grid; "
                             f"got {method!r} on another grid")
        M, v = self.map()
        o = self.origin[..., None, :]
        u = np.asarray(z, float) - o
        # d = 1: u M is a product of scalars (numpy's multiply, the same number as the 1 x 1 matmul)
        return o + (u * M if M.shape[-1] == 1 else u @ M) + v[..., None, :]
