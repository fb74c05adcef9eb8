"""Particle flow particle filter (Li & Coates 2017), EDH and LEDH, batched over runs and particles.

GPFF (Zhang 2016) moves particles along the exact Daum–Huang (EDH) flow and then treats
the moved cloud as the posterior; for a nonlinear measurement the flow is only
approximately right and nothing corrects it. Li & Coates (2017) make the flow a
*proposal*: because the EDH map of one step is affine given the past (and the LEDH map of
particle i is affine given its own past), its Jacobian determinant is known, and the
moved particle eta_1 can be weighted exactly (their eq. 20, Algorithms 1–2):

    eta_0^i ~ p(x_k | x_{k-1}^i)                       (a transition draw)
    eta_1^i = T_i(eta_0^i)                             (the flow, pseudo-time 0 -> 1)
    w_k^i  ∝ w_{k-1}^i p(y_k | eta_1^i) p(eta_1^i | x_{k-1}^i) abs(det dT_i/deta_0) / p(eta_0^i | x_{k-1}^i)

The flow at pseudo-time lambda, linearised at eta_bar (EDH: one point, the flowed
prediction; LEDH: per particle, its own flowed prediction eta_bar^i), with
H = dh/dx(eta_bar), e = h(eta_bar) - H eta_bar and the predictive covariance P
(Daum & Huang 2010; Li & Coates 2017, eqs. 10–11; GPFF's eqs. 24 and 27):

    A(lambda) = -1/2 P H^T (lambda H P H^T + R)^{-1} H
    b(lambda) = (I + 2 lambda A) [(I + lambda A) P H^T R^{-1} (y - e) + A eta_bar_0]

integrated with Euler steps on an exponentially spaced pseudo-time grid (29 steps,
ratio 1.2, as in Li & Coates 2017, sec. VI). The Jacobian of one Euler step is
I + eps_j A(lambda_j), so abs(det dT/deta_0) = prod_j abs(det(I + eps_j A_j)) (their eq. 22).
P comes from an EKF run alongside (prediction with the Jacobian of f at the previous
estimate; update with the Jacobian of h at the prediction), as in their Algorithm 1.

Because the weights are proper importance weights, the evidence estimate
prod_k sum_i w_{k-1}^i w_k^i(unnormalised) is unbiased (tested against the Kalman evidence).

A nearly deterministic transition defeats the proposal. The flow moves every particle of a
run by one map built from the predictive covariance P, not from the transition's Q; where Q
is nearly singular, eta_1 lands many of Q's standard deviations away from its own
transition mean, and p(eta_1 | x_{k-1}) is astronomically small for every particle. The
weights stay proper (the evidence estimate is still unbiased in expectation) but collapse:
on the CWPA tracking model (Q's smallest eigenvalue 1.4e-9), with N = 1000 over 20 runs of
30 steps, the mean effective sample size was 1.01, the log-evidence about -5e7 against the
Kalman filter's +18 to +40, and the position-velocity-acceleration MSE 0.134 against the
Kalman filter's 0.046 and a bootstrap PF(1000)'s 0.070 (a test keeps the collapse visible).
Use it where Q is well conditioned.
"""
from __future__ import annotations

import numpy as np

from ..flow import lambda_schedule
from ..validation import check_positive_int, check_probability
from .resampling import check_scheme
from .small_linalg import det_small, inv_components, inv_small, mm_components
from .smc_steps import ParticleLoop, particle_result

__all__ = ["ParticleFlowParticleFilter", "edh_coefficients", "FLOWS"]

#: the two flows of Li & Coates (2017) — one linearisation for all particles, or one per particle
FLOWS = ("edh", "ledh")


def _T(a):
    return np.swapaxes(a, -1, -2)


def edh_coefficients(P, H, R, innov, eta_bar0, lam, R_inv=None):
    """A(lambda), b(lambda) of the (L)EDH flow (Li & Coates 2017, eqs. 10–11), batched.

    ``P`` (..., n, n) predictive covariance; ``H`` (..., m, n) Jacobian of h at the
    linearisation point; ``R`` (m, m); ``innov`` (..., m) = y - e = r(y, h(eta_bar)) + H eta_bar;
    ``eta_bar0`` (..., n) the linearisation point's start. Leading axes broadcast (EDH:
    ``(runs,)``; LEDH: ``(runs, N)`` with ``P`` given as ``(runs, 1, n, n)``). The same
    coefficients as :func:`pfrepro.flow.affine_flow_coefficients` (GPFF's eqs. 24, 27)
    without its input checks (this runs 29 times a step). ``R_inv``: R^{-1}, if precomputed.
    """
    PHt = P @ _T(H)                                           # (..., n, m)
    S = lam * (H @ PHt) + R
    G = PHt @ inv_small(S)                                         # P H^T S^{-1}
    A = -0.5 * G @ H
    n = A.shape[-1]
    I = np.eye(n)
    R_inv = np.linalg.inv(R) if R_inv is None else R_inv
    g = np.einsum("...im,...m->...i", PHt, np.einsum("ml,...l->...m", R_inv, innov))
    inner = np.einsum("...ij,...j->...i", I + lam * A, g) + np.einsum("...ij,...j->...i", A, eta_bar0)
    b = np.einsum("...ij,...j->...i", I + 2.0 * lam * A, inner)
    return A, b


class ParticleFlowParticleFilter(ParticleLoop):
    """Invertible particle flow particle filter, PFPF(EDH) or PFPF(LEDH) (Li & Coates 2017).

    Parameters
    ----------
    model : StateSpaceModel
        Additive Gaussian noise on both equations, with ``f``, ``jacobian_f``, ``h``,
        ``jacobian_h`` and a non-singular ``Q`` (the weights evaluate the transition density).
    n_particles : int
        N >= 1.
    flow : {"edh", "ledh"}
        One linearisation for the whole cloud (EDH, Algorithm 1) or one per particle
        (LEDH, Algorithm 2; N Jacobians and N small solves per pseudo-time step).
    n_steps : int
        Pseudo-time steps (default 29).
    ratio : float
        Ratio of consecutive pseudo-time steps (default 1.2; 1 is uniform).
    resampling : str
        ``"systematic"`` (default), ``"stratified"``, ``"multinomial"`` or ``"residual"``.
    ess_threshold : float or None
        None (resample every step) or a fraction in [0, 1].
    m0, P0 : array_like, optional
        Override the model's initial distribution N(m0, P0).

    Notes
    -----
    Diagnostics: ``ess`` (runs, T), ``resampled`` (runs, T), ``log_evidence`` (runs,),
    ``log_det`` (runs, T) the EDH map's log abs(det) (LEDH: its weighted mean over particles),
    ``collapsed`` and ``n_collapsed``.
    """

    name = "PFPF"
    model_requirements = ("f", "jacobian_f", "h", "jacobian_h", "additive_measurement", "transition_density")

    def __init__(self, model, n_particles: int, flow: str = "edh", n_steps: int = 29, ratio: float = 1.2,
                 resampling: str = "systematic", ess_threshold: float | None = None, m0=None, P0=None):
        super().__init__(model, m0, P0)
        self.n_particles = check_positive_int(n_particles, "n_particles")
        if flow not in FLOWS:
            raise ValueError(f"flow must be one of {FLOWS}, got {flow!r}")
        self.flow = flow
        self.grid = lambda_schedule(check_positive_int(n_steps, "n_steps"), "exponential", ratio)
        self.resampling = check_scheme(resampling)
        self.ess_threshold = None if ess_threshold is None else check_probability(ess_threshold, "ess_threshold")
        self.name = f"PFPF({flow.upper()})"
        Q = np.asarray(model.Q, float)
        self._Q = Q
        self._Qinv_chol = np.linalg.inv(np.linalg.cholesky(Q))   # whitening of the transition noise
        self._R_inv = np.linalg.inv(np.asarray(model.R, float))

    def _log_transition(self, x, mu):
        """log N(x; mu, Q) up to its constant (it cancels in the ratio p(eta_1 | .) / p(eta_0 | .))."""
        z = np.einsum("ij,...j->...i", self._Qinv_chol, x - mu)
        return -0.5 * np.einsum("...i,...i->...", z, z)

    def _flow(self, eta, eta_bar, P, y):
        """Move ``eta`` (runs, N, n) from pseudo-time 0 to 1; returns (eta_1, log abs(det) per particle).

        EDH: A(lambda) and b(lambda) are the same for every particle of a run, so the Euler steps
        compose to one affine map eta_1 = M eta_0 + c per run (:meth:`edh_map`, on n x n matrices),
        applied once; LEDH: each particle has its own A and b, moved step by step
        (``_flow_steps``)."""
        if self.flow == "ledh":
            return self._ledh_flow(eta, eta_bar, P, y)
        runs, N, n = eta.shape
        M, c, log_det = self.edh_map(eta_bar, P, y)
        # one (N, n) @ (n, n) product per run (same shapes in any batch: batch-independent bits)
        eta = eta @ _T(M)
        eta += c[:, None, :]
        return eta, np.broadcast_to(log_det[:, None], (runs, N))

    def edh_map(self, eta_bar, P, y):
        """The EDH flow of one time step as one affine map per run: ``(M, c, log_det)``.

        The Euler step j moves a particle by eta -> J_j eta + eps_j b_j with J_j = I + eps_j A_j
        (Li & Coates 2017, eq. 22: A_j, b_j at lambda_j, linearised at the flowed prediction
        eta_bar, which moves with the same steps). Composed over the pseudo-time grid:
        M = J_last ... J_1 (runs, n, n) and c (runs, n) the image of 0, so eta_1 = M eta_0 + c
        for every particle; log_det = log abs(det M) = sum_j log abs(det J_j) (runs,).
        ``eta_bar`` (runs, n) the linearisation point at pseudo-time 0, ``P`` (runs, n, n),
        ``y`` (runs, m). The model's h and Jacobian see ``eta_bar`` as (runs, 1, n), one row
        per run, so a run's arithmetic does not depend on the number of runs.
        """
        model, R = self.model, np.asarray(self.model.R, float)
        runs, n = eta_bar.shape
        eb = eta_bar[:, None, :]                                # (runs, 1, n)
        eb0 = eb.copy()
        Pb, yb = P[:, None], y[:, None]
        I = np.eye(n)
        M = np.broadcast_to(I, (runs, 1, n, n)).copy()
        c = np.zeros((runs, 1, n))
        log_det = np.zeros((runs, 1))
        for lam0, lam1 in zip(self.grid[:-1], self.grid[1:]):
            eps, lam = lam1 - lam0, lam1                        # Li & Coates evaluate at lambda_j
            H = model.jacobian_h(eb)
            innov = model.residual_y(yb, model.h(eb)) + np.einsum("...mn,...n->...m", H, eb)
            A, b = edh_coefficients(Pb, H, R, innov, eb0, lam, self._R_inv)
            J = I + eps * A
            log_det += np.log(np.abs(det_small(J)))
            eb = eb + eps * (np.einsum("...ij,...j->...i", A, eb) + b)
            M = J @ M
            c = np.einsum("...ij,...j->...i", J, c) + eps * b
        return M[:, 0], c[:, 0], log_det[:, 0]

    def _ledh_flow(self, eta, eta_bar, P, y):
        """LEDH: every particle through every Euler step with its own A and b (Li & Coates 2017,
        Algorithm 2), written out over the small state and measurement axes (particles' arrays
        stored small axes first, one vector operation per term over all particles: the
        (runs, N) stacks of tiny matrices cost far more as matrix products). The per-particle
        step determinant det(I + eps A), with A = -1/2 P H^T S^{-1} H of rank m, is the m x m
        det(I_m - eps/2 H P H^T S^{-1}) (the matrix determinant lemma). Returns what
        ``_flow_steps`` does (the same flow, the same numbers up to rounding)."""
        model = self.model
        runs, N, n = eta.shape
        m = model.dim_y
        Rc = np.asarray(model.R, float)[:, :, None, None]
        Rinv = self._R_inv[:, :, None, None]
        Pc = np.ascontiguousarray(np.moveaxis(P, (-2, -1), (0, 1)))[:, :, :, None]   # (n, n, runs, 1)
        ec = np.ascontiguousarray(np.moveaxis(eta, -1, 0))              # (n, runs, N)
        bc = np.ascontiguousarray(np.moveaxis(eta_bar, -1, 0))
        b0 = bc.copy()
        Im = np.eye(m)[:, :, None, None]
        log_det = np.zeros((runs, N))
        yb = y[:, None]
        for lam0, lam1 in zip(self.grid[:-1], self.grid[1:]):
            eps, lam = lam1 - lam0, lam1                        # Li & Coates evaluate at lambda_j
            eb = np.moveaxis(bc, 0, -1)
            # small axes first and contiguous: a moved-axis view would hand its strides on to every
            # result computed from it
            Hc = np.ascontiguousarray(np.moveaxis(model.jacobian_h(eb), (-2, -1), (0, 1)))   # (m, n, runs, N)
            innov = np.moveaxis(model.residual_y(yb, model.h(eb)), -1, 0) + mm_components(Hc, bc[:, None])[:, 0]
            PHt = mm_components(Pc, np.swapaxes(Hc, 0, 1))              # (n, m, runs, N)
            HPHt = mm_components(Hc, PHt)                               # (m, m, runs, N)
            Sinv = inv_components(lam * HPHt + Rc)
            G = mm_components(PHt, Sinv)                                # P H^T S^-1
            A = -0.5 * mm_components(G, Hc)                             # (n, n, runs, N)
            g = mm_components(PHt, mm_components(Rinv, innov[:, None]))[:, 0]
            Ag = mm_components(A, g[:, None])[:, 0]
            inner = g + lam * Ag + mm_components(A, b0[:, None])[:, 0]
            b = inner + 2.0 * lam * mm_components(A, inner[:, None])[:, 0]
            small = Im - (0.5 * eps) * mm_components(HPHt, Sinv)       # det(I + eps A), m x m
            log_det += np.log(np.abs(small[0, 0] if m == 1 else det_small(np.moveaxis(small, (0, 1), (-2, -1)))))
            bc = bc + eps * (mm_components(A, bc[:, None])[:, 0] + b)
            ec = ec + eps * (mm_components(A, ec[:, None])[:, 0] + b)
        return np.moveaxis(ec, 0, -1), log_det

    def _flow_steps(self, eta, eta_bar, P, y):
        """The flow step by step with the stacked matrices of :func:`edh_coefficients`: the
        reference :meth:`edh_map` (EDH) and ``_ledh_flow`` (LEDH) are tested against."""
        model, R = self.model, np.asarray(self.model.R, float)
        runs, N, n = eta.shape
        ledh = self.flow == "ledh"
        Pb = P[:, None] if ledh else P                          # LEDH: one P per run, H per particle
        eta_bar0 = eta_bar.copy()
        log_det = np.zeros((runs, N) if ledh else (runs,))
        for lam0, lam1 in zip(self.grid[:-1], self.grid[1:]):
            eps, lam = lam1 - lam0, lam1                        # Li & Coates evaluate at lambda_j
            H = model.jacobian_h(eta_bar)
            innov = model.residual_y(y[:, None] if ledh else y, model.h(eta_bar)) \
                + np.einsum("...mn,...n->...m", H, eta_bar)
            A, b = edh_coefficients(Pb, H, R, innov, eta_bar0, lam, self._R_inv)
            log_det += np.log(np.abs(det_small(np.eye(n) + eps * A)))
            eta_bar = eta_bar + eps * (np.einsum("...ij,...j->...i", A, eta_bar) + b)
            if ledh:
                eta = eta + eps * (np.einsum("rnij,rnj->rni", A, eta) + b)
            else:
                eta = eta + eps * (eta @ _T(A) + b[:, None, :])
        return eta, (log_det if ledh else np.broadcast_to(log_det[:, None], (runs, N)))

    def _start(self, y, rng, runs, N):
        x, state = super()._start(y, rng, runs, N)
        n, T = self.model.dim_x, y.shape[1]
        state["x_hat"] = np.broadcast_to(self.m0, (runs, n)).copy()      # the EKF run alongside (for P)
        state["P"] = np.broadcast_to(self.P0, (runs, n, n)).copy()
        state["diag"] = {"log_det": np.empty((runs, T))}
        return x, state

    def _move(self, k, x, logw, yk, rng, state):
        model = self.model
        x_hat, P = state["x_hat"], state["P"]
        # EKF prediction at the previous estimate (Li & Coates, Alg. 1 lines 5-6)
        # the model sees the estimate as (runs, 1, n): one row per run, whatever the number of runs
        # (a (runs, n) matrix product rounds differently with one row than with several)
        xh = x_hat[:, None, :]
        F = model.jacobian_f(xh, k)[:, 0]
        P_pred = F @ P @ _T(F) + self._Q
        P_pred = 0.5 * (P_pred + _T(P_pred))
        m_pred = model.f(xh, k)[:, 0]
        mu = model.f(x, k)                               # transition means of the particles
        eta0 = model.sample_transition(x, k, rng)
        # linearisation points: EDH one per run (f of the estimate), LEDH one per particle
        eta_bar = mu.copy() if self.flow == "ledh" else m_pred
        eta1, log_det = self._flow(eta0, eta_bar, P_pred, yk)
        lw = (model.log_likelihood(yk, eta1) + self._log_transition(eta1, mu)
              - self._log_transition(eta0, mu) + log_det)
        state["P_pred"], state["m_pred"], state["log_det"] = P_pred, m_pred, log_det
        return eta1, lw

    def _after_weight(self, k, w, x, x_hat, state):
        model, n = self.model, self.model.dim_x
        R = np.asarray(model.R, float)
        P_pred, m_pred = state["P_pred"], state["m_pred"]
        state["x_hat"] = x_hat
        state["diag"]["log_det"][:, k - 1] = np.einsum("rn,rn->r", w, state["log_det"])
        # EKF update of P at the prediction (Alg. 1 line 17)
        Hm = model.jacobian_h(m_pred[:, None, :])[:, 0]
        S = Hm @ P_pred @ _T(Hm) + R
        K = _T(np.linalg.solve(S, Hm @ P_pred))
        IKH = np.eye(n) - K @ Hm
        P = IKH @ P_pred @ _T(IKH) + K @ R @ _T(K)
        state["P"] = 0.5 * (P + _T(P))

    def _result(self, xs, log_inc, collapsed, diag, state):
        return particle_result(self.name, xs, log_inc, collapsed, **diag,
                               diverged=~np.isfinite(xs).all(axis=(1, 2)))

    def __repr__(self) -> str:
        return (f"ParticleFlowParticleFilter(N={self.n_particles}, flow={self.flow!r}, "
                f"n_steps={len(self.grid) - 1}, resampling={self.resampling!r})")
