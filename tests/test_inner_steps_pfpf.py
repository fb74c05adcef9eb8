"""Inner steps of the particle flow particle filter (Li & Coates 2017), pinned by hand (issue 35).

Each test checks ONE step of :mod:`pfrepro.filters.pfpf` against numbers computed by hand
(exact fractions, written out below) on a NONLINEAR measurement function (h(x) = x^2 or
h(x) = x1 x2), with model stubs whose dynamics and likelihood the test controls:

* the flow coefficients A(lambda), b(lambda) (eqs. 10-11), scalar and 2-D (a non-symmetric A);
* one Euler step of the EDH flow on a 2-D state (particles and log abs det(I + eps A));
* two Euler steps on an exponential grid: lambda taken at the step's right end, the
  linearisation point moved along the flow, H re-evaluated there, eta_bar_0 kept fixed;
* LEDH: each particle linearised at its own point, its own log-determinant;
* the whitened transition log-density with a correlated Q;
* the weights of the invertible flow (eq. 20): likelihood x transition ratio x abs(det),
  the estimate, the evidence, the ESS and the log_det diagnostic (EDH and LEDH);
* the EKF run alongside: step 2's P_pred and linearisation point come from step 1's
  Joseph-form update and the particle estimate;
* the weights carried after resampling (every step, never, one run of two).

Each test was checked once against the wrong formula named in its docstring (the wrong
formula applied by hand to src/, the test seen to fail, the change reverted).
"""
from __future__ import annotations

from fractions import Fraction as Fr
from math import log, pi

import numpy as np
import pytest

from pfrepro.filters.pfpf import ParticleFlowParticleFilter, edh_coefficients


# ------------------------------------------------------------------------------ stubs
class FlowStub:
    """Additive-Gaussian model stub: ``f``, its Jacobian, ``h``, its Jacobian given as callables;
    the transition draw at step k is f(x) + ``noise[k - 1]`` (scripted, (N, n) or (runs, N, n));
    the likelihood is log N(y; h(x), R) with its constant."""

    additive_measurement_noise = True

    def __init__(self, f, jf, h, jh, Q, R, noise=None, m0=None, P0=None):
        self._f, self._jf, self._h, self._jh = f, jf, h, jh
        self.Q, self.R = np.atleast_2d(np.asarray(Q, float)), np.atleast_2d(np.asarray(R, float))
        self.dim_x, self.dim_y = self.Q.shape[0], self.R.shape[0]
        self.noise = None if noise is None else [np.asarray(e, float) for e in noise]
        self.m0 = np.zeros(self.dim_x) if m0 is None else np.asarray(m0, float)
        self.P0 = np.eye(self.dim_x) if P0 is None else np.atleast_2d(np.asarray(P0, float))
        self.steps = []                                   # the k of every f / jacobian_f / transition call

    def f(self, x, k):
        self.steps.append(k)
        return self._f(x)

    def jacobian_f(self, x, k):
        self.steps.append(k)
        return self._jf(x)

    def h(self, x):
        return self._h(x)

    def jacobian_h(self, x):
        return self._jh(x)

    def residual_y(self, y, hx):
        return y - hx

    def sample_transition(self, x, k, rng):
        return self._f(x) + self.noise[k - 1]

    def log_likelihood(self, y, x):
        d = y[:, None, :] - self.h(x)
        Ri = np.linalg.inv(self.R)
        return (-0.5 * np.einsum("...i,ij,...j->...", d, Ri, d)
                - 0.5 * np.log(np.linalg.det(2 * np.pi * self.R)))


def square(x):                      # h(x) = x^2 (scalar), dh/dx = 2x
    return x ** 2


def d_square(x):
    return (2.0 * x)[..., None]


def half_square(x):                 # f(x) = x^2 / 2 (scalar), df/dx = x
    return 0.5 * x ** 2


def d_half_square(x):
    return x[..., None]


def product(x):                     # h(x) = x1 x2, dh/dx = [x2, x1]
    return (x[..., 0] * x[..., 1])[..., None]


def d_product(x):
    return np.stack([x[..., 1], x[..., 0]], axis=-1)[..., None, :]


def scalar_stub(**kw):
    return FlowStub(half_square, d_half_square, square, d_square, **kw)


def fl(v):
    return np.array(v, dtype=float)


def with_prior(pf, x0):
    """The filter's initial particles set to ``x0`` (runs, N, n) instead of prior draws."""
    pf.sample_prior = lambda rng, shape: np.broadcast_to(fl(x0), tuple(shape) + (pf.model.dim_x,)).copy()
    return pf


# ------------------------------------------------------------------------------ 1. A(lambda), b(lambda)
def test_edh_coefficients_scalar_by_hand():
    """P = 2, H = 3, lambda = 1/2, y - e = 2, eta_bar_0 = 1.
    R = 1: S = lam H P H + R = 10, A = -1/2 P H S^-1 H = -0.9, P H R^-1 (y - e) = 12,
           b = (1 + 2 lam A) [(1 + lam A) 12 + A eta_bar_0] = 0.1 (0.55 * 12 - 0.9) = 0.57.
    R = 2: S = 11, A = -9/11, P H R^-1 (y - e) = 6, b = (2/11) (13/22 * 6 - 9/11) = 60/121
           (with R^-1 computed inside and passed in).
    Checked against b = (I + lam A) [...] (the outer factor without its 2)."""
    A, b = edh_coefficients(fl([[2.0]]), fl([[3.0]]), fl([[1.0]]), fl([2.0]), fl([1.0]), 0.5)
    assert A[0, 0] == pytest.approx(-0.9, rel=1e-14) and b[0] == pytest.approx(0.57, rel=1e-14)
    for R_inv in (None, fl([[0.5]])):
        A, b = edh_coefficients(fl([[2.0]]), fl([[3.0]]), fl([[2.0]]), fl([2.0]), fl([1.0]), 0.5, R_inv)
        assert A[0, 0] == pytest.approx(-9 / 11, rel=1e-14) and b[0] == pytest.approx(60 / 121, rel=1e-14)


def test_edh_coefficients_2d_non_symmetric_by_hand():
    """P = diag(2, 1), H = [1 1], R = 1, lambda = 1/2, y - e = 1, eta_bar_0 = (1, 2):
    P H^T = (2, 1), S = 1/2 * 3 + 1 = 5/2, A = -1/2 (2, 1)^T (2/5) [1 1] = [[-.4 -.4] [-.2 -.2]]
    (not symmetric); g = P H^T R^-1 (y - e) = (2, 1); (I + A/2) g = (1.4, 0.7); A eta_bar_0 =
    (-1.2, -0.6); inner = (0.2, 0.1); b = (I + A) inner = (0.08, 0.04).
    Batched: leading axes (runs, N) with P as (runs, 1, n, n) give the same per element.
    Checked against A = -1/2 H^T S^-1 H P (the factors in the wrong order: A^T here)."""
    P, H, R = np.diag([2.0, 1.0]), fl([[1.0, 1.0]]), fl([[1.0]])
    A, b = edh_coefficients(P, H, R, fl([1.0]), fl([1.0, 2.0]), 0.5)
    np.testing.assert_allclose(A, [[-0.4, -0.4], [-0.2, -0.2]], rtol=1e-14)
    np.testing.assert_allclose(b, [0.08, 0.04], rtol=1e-13)
    # LEDH shapes: (runs=2, N=3); particle (1, 2) gets the hand case, the others other innovations
    innov = np.zeros((2, 3, 1))
    innov[1, 2] = 1.0
    Hs = np.broadcast_to(H, (2, 3, 1, 2))
    eb0 = np.broadcast_to(fl([1.0, 2.0]), (2, 3, 2))
    A2, b2 = edh_coefficients(np.broadcast_to(P, (2, 1, 2, 2)), Hs, R, innov, eb0, 0.5)
    assert A2.shape == (2, 3, 2, 2) and b2.shape == (2, 3, 2)
    np.testing.assert_allclose(A2[1, 2], A, rtol=1e-14)
    np.testing.assert_allclose(b2[1, 2], [0.08, 0.04], rtol=1e-13)
    # innov = 0: b = (I + A)(A eta_bar_0) = (I + A)(-1.2, -0.6) = (-0.48, -0.24)
    np.testing.assert_allclose(b2[0, 0], [-0.48, -0.24], rtol=1e-13)


# ------------------------------------------------------------------------------ 2. the flow
def _flow_filter(model, flow, n_steps, ratio):
    return ParticleFlowParticleFilter(model, 2, flow=flow, n_steps=n_steps, ratio=ratio)


def test_one_euler_step_of_the_edh_flow_2d_product_measurement():
    """h(x) = x1 x2, one Euler step (eps = lambda = 1), linearised at eta_bar = (1, 1):
    H = [1 1], e = h - H eta_bar = -1, y = 1 -> y - e = 2; P = diag(2, 1), R = 1:
    S = 4, A = [[-1/4 -1/4] [-1/8 -1/8]], g = (4, 2), (I + A) g = (5/2, 5/4),
    A eta_bar_0 = (-1/2, -1/4), b = (I + 2A)(2, 1) = (1/2, 1/4).
    eta_1 = eta_0 + A eta_0 + b: (2, 2) -> (3/2, 7/4); (1, -1) -> (3/2, -3/4);
    log abs det(I + A) = log(3/4 * 7/8 - 1/32) = log(5/8) for every particle.
    Checked against eta @ A for eta @ A^T (gives (5/4, 3/2) for the first particle)."""
    model = FlowStub(None, None, product, d_product, Q=np.eye(2), R=[[1.0]])
    f = _flow_filter(model, "edh", 1, 1.2)
    eta, log_det = f._flow(fl([[[2.0, 2.0], [1.0, -1.0]]]), fl([[1.0, 1.0]]), np.diag([2.0, 1.0])[None], fl([[1.0]]))
    np.testing.assert_allclose(eta[0], [[1.5, 1.75], [1.5, -0.75]], rtol=1e-14)
    np.testing.assert_allclose(log_det, np.full((1, 2), log(5 / 8)), rtol=1e-14)


def test_two_euler_steps_move_the_linearisation_point_and_evaluate_at_lambda_j():
    """h(x) = x^2, P = R = 1, y = 2, EDH from eta_bar = 1; n_steps = 2, ratio 2: grid (0, 1/3, 1).
    Step 1 (eps = 1/3, lambda = 1/3): H = 2, y - e = 2 - 1 + 2 = 3, A = -6/7, b = 72/49;
      eta_bar -> 1 + (1/3)(-6/7 + 72/49) = 59/49; particles 1/2 -> 83/98, 2 -> 94/49.
    Step 2 (eps = 2/3, lambda = 1): H = 118/49, y - e = 8283/2401, A = -6962/16325,
      b = 8332267684/13058775625 (b keeps eta_bar_0 = 1, the START point);
      particles -> 26940766487/26117551250, 23484015806/13058775625.
    log abs det = log(1 - 2/7) + log(1 - (2/3)(6962/16325)) = log(5/7) + log(35051/48975).
    Checked against A, b at lambda_{j-1} (the step's left end), against eta_bar_0 moved with
    eta_bar, and against H kept at the start point (each moves the particles)."""
    model = FlowStub(None, None, square, d_square, Q=[[1.0]], R=[[1.0]])
    f = _flow_filter(model, "edh", 2, 2.0)
    np.testing.assert_allclose(f.grid, [0.0, 1 / 3, 1.0], rtol=1e-15)
    eta, log_det = f._flow(fl([[[0.5], [2.0]]]), fl([[1.0]]), fl([[[1.0]]]), fl([[2.0]]))
    want = [float(Fr(26940766487, 26117551250)), float(Fr(23484015806, 13058775625))]
    np.testing.assert_allclose(eta[0, :, 0], want, rtol=1e-13)
    np.testing.assert_allclose(log_det[0], log(5 / 7) + log(35051 / 48975), rtol=1e-13)


def test_ledh_linearises_each_particle_at_its_own_point():
    """h(x) = x^2, P = R = 1, y = 2, one Euler step; particle i at eta_0 with eta_bar^i:
    i = 0: eta_bar = 1, H = 2, y - e = 3, S = 5, A = -2/5, b = (1/5)(3/5 * 6 - 2/5) = 16/25;
           eta_0 = 1/2 -> 1/2 - 1/5 + 16/25 = 47/50, log det = log(3/5);
    i = 1: eta_bar = 2, H = 4, y - e = 6, S = 17, A = -8/17, b = (1/17)(9/17 * 24 - 16/17) = 200/289;
           eta_0 = 3 -> 3 - 24/17 + 200/289 = 659/289, log det = log(9/17).
    Checked against the LEDH branch moving particles with particle 0's A, b (EDH's update)."""
    model = FlowStub(None, None, square, d_square, Q=[[1.0]], R=[[1.0]])
    f = _flow_filter(model, "ledh", 1, 1.2)
    eta, log_det = f._flow(fl([[[0.5], [3.0]]]), fl([[[1.0], [2.0]]]), fl([[[1.0]]]), fl([[2.0]]))
    np.testing.assert_allclose(eta[0, :, 0], [47 / 50, 659 / 289], rtol=1e-14)
    np.testing.assert_allclose(log_det[0], [log(3 / 5), log(9 / 17)], rtol=1e-14)


def test_log_transition_whitens_with_a_correlated_q():
    """Q = [[2 1] [1 1]], Q^-1 = [[1 -1] [-1 2]]: -1/2 d^T Q^-1 d for d = (1, 1), (1, 0), (0, 1),
    (2, -1) = -1/2, -1/2, -1, -5 (up to the constant, which cancels in the weight).
    Checked against the whitening applied transposed, L^-T d (gives -1 for d = (1, 1))."""
    model = FlowStub(None, None, product, d_product, Q=[[2.0, 1.0], [1.0, 1.0]], R=[[1.0]])
    f = ParticleFlowParticleFilter(model, 4)
    mu = fl([[[1.0, -1.0]] * 4])
    d = fl([[[1.0, 1.0], [1.0, 0.0], [0.0, 1.0], [2.0, -1.0]]])
    np.testing.assert_allclose(f._log_transition(mu + d, mu), [[-0.5, -0.5, -1.0, -5.0]], rtol=1e-14)


# ------------------------------------------------------------------------------ 3. the weights (eq. 20)
# Scalar stub, one step: f(x) = x^2/2, h(x) = x^2, Q = R = 1, EKF start m0 = P0 = 1; two
# particles x_0 = (1, 2), transition noise (1/2, -1/2): mu = f(x_0) = (1/2, 2), eta_0 = (1, 3/2);
# y_1 = 1. EKF: F = f'(m0) = 1, P_pred = 1 + 1 = 2, m_pred = f(1) = 1/2.
STEP1 = dict(x0=[[[1.0], [2.0]]], noise=[[[0.5], [-0.5]]], y=1.0)


def _log_w(eta1, eta0, mu, log_det, y=1.0):
    """log p(y | eta_1) + log p(eta_1 | x) - log p(eta_0 | x) + log abs det, by hand (R = Q = 1)."""
    return (-0.5 * (y - eta1 ** 2) ** 2 - 0.5 * log(2 * pi)
            - 0.5 * (eta1 - mu) ** 2 + 0.5 * (eta0 - mu) ** 2 + log_det)


def _run_step1(flow, T=1, ys=(1.0,), noise=None, ess_threshold=None):
    model = scalar_stub(Q=[[1.0]], R=[[1.0]], noise=STEP1["noise"] if noise is None else noise,
                        m0=[1.0], P0=[[1.0]])
    pf = with_prior(ParticleFlowParticleFilter(model, 2, flow=flow, n_steps=1, ess_threshold=ess_threshold),
                    STEP1["x0"])
    return pf.filter(fl(ys).reshape(1, T, 1), rng=np.random.default_rng(0))


# EDH: eta_bar = m_pred = 1/2, H = 1, y - e = 1 - 1/4 + 1/2 = 5/4, S = 3, A = -1/3,
#      b = (1/3)(2/3 * 2 * 5/4 - 1/6) = 1/2; eta_1 = (2/3) eta_0 + 1/2 = (7/6, 3/2), log det = log(2/3)
EDH1 = dict(eta1=[7 / 6, 3 / 2], log_det=[log(2 / 3), log(2 / 3)])
# LEDH: particle 0 is linearised at mu_0 = 1/2 (the EDH numbers); particle 1 at mu_1 = 2: H = 4,
#      y - e = 1 - 4 + 8 = 5, S = 33, A = -16/33, b = (1/33)(17/33 * 40 - 32/33) = 72/121;
#      eta_1 = 3/2 - 8/11 + 72/121 = 331/242, log det = log(17/33)
LEDH1 = dict(eta1=[7 / 6, 331 / 242], log_det=[log(2 / 3), log(17 / 33)])


def _edh1_weights():
    """The normalised step-1 EDH weights from the hand numbers."""
    w = np.exp([_log_w(EDH1["eta1"][i], [1.0, 1.5][i], [0.5, 2.0][i], log(2 / 3)) for i in range(2)])
    return w / w.sum()


@pytest.mark.parametrize("flow, hand", [("edh", EDH1), ("ledh", LEDH1)])
def test_step_one_weights_estimate_evidence_of_the_invertible_flow(flow, hand):
    """w^i ∝ (1/N) p(y | eta_1^i) p(eta_1^i | x^i) abs(det) / p(eta_0^i | x^i) with the hand eta_1,
    log det above. Estimate sum_i w^i eta_1^i; log evidence log sum_i (1/N) exp(log w^i); ESS
    1/sum w^2; log_det diagnostic sum_i w^i log det^i; the resampled/collapsed flags are booleans.
    Checked against the weight without the transition ratio, against - log det, against the
    ratio inverted (eta_0 over eta_1) and against the flags allocated as float zeros."""
    res = _run_step1(flow)
    eta1, mu, eta0 = np.array(hand["eta1"]), np.array([0.5, 2.0]), np.array([1.0, 1.5])
    lw = np.array([_log_w(eta1[i], eta0[i], mu[i], hand["log_det"][i]) for i in range(2)])
    w = np.exp(lw) / np.exp(lw).sum()
    np.testing.assert_allclose(res.x[0, 0, 0], w @ eta1, rtol=1e-13)
    np.testing.assert_allclose(res.diagnostics["log_evidence"][0], log(np.exp(lw).mean()), rtol=1e-13)
    np.testing.assert_allclose(res.diagnostics["ess"][0, 0], 1 / (w @ w), rtol=1e-13)
    np.testing.assert_allclose(res.diagnostics["log_det"][0, 0], w @ hand["log_det"], rtol=1e-13)
    assert res.diagnostics["resampled"].all() and not res.diagnostics["collapsed"].any()
    assert not res.diagnostics["diverged"].any() and res.diagnostics["n_collapsed"] == 0
    assert res.diagnostics["resampled"].dtype == bool and res.diagnostics["collapsed"].dtype == bool


def test_ekf_alongside_gives_step_two_its_covariance_and_linearisation_point():
    """Step 1's EKF update at m_pred = 1/2 (H = 1, P_pred = 2, R = 1): K = 2/3, Joseph form
    P_1 = (1/3)^2 2 + (2/3)^2 1 = 2/3. Step 2 (EDH, one Euler step) at the particle estimate
    xh = x_hat_1: F = f'(xh) = xh, P_pred = xh^2 (2/3) + 1, eta_bar = m_pred = f(xh) = xh^2/2,
    H = 2 m_pred = xh^2; its log det = log(1 + A) with A = -1/2 P_pred H^2 / (H^2 P_pred + 1).
    Each step's diagnostics go to its own column (step 1's log det is log(2/3), its ESS the hand
    weights'), and the model is called with the step index k (f, jacobian_f: 1, 1, 1, 2, 2, 2).
    Checked against the update without K R K^T (P_1 = 2/9), against P not updated (P_1 = 2)
    and against the diagnostics written to column k - 2."""
    model = scalar_stub(Q=[[1.0]], R=[[1.0]], noise=STEP1["noise"] * 2, m0=[1.0], P0=[[1.0]])
    pf = with_prior(ParticleFlowParticleFilter(model, 2, n_steps=1), STEP1["x0"])
    res = pf.filter(fl([1.0, 0.5]).reshape(1, 2, 1), rng=np.random.default_rng(0))
    assert model.steps == [1, 1, 1, 2, 2, 2]            # jacobian_f(x_hat), f(x_hat), f(x) per step
    w = _edh1_weights()
    np.testing.assert_allclose(res.diagnostics["log_det"][0, 0], log(2 / 3), rtol=1e-13)
    np.testing.assert_allclose(res.diagnostics["ess"][0, 0], 1 / (w @ w), rtol=1e-13)
    xh = res.x[0, 0, 0]
    np.testing.assert_allclose(xh, 1.3, atol=0.2)       # the step-1 estimate (pinned above)
    P_pred = xh ** 2 * 2 / 3 + 1
    H = xh ** 2
    A = -0.5 * P_pred * H ** 2 / (H ** 2 * P_pred + 1)
    np.testing.assert_allclose(res.diagnostics["log_det"][0, 1], log(1 + A), rtol=1e-13)


# ------------------------------------------------------------------------------ 4. after resampling
# Two steps where the transition forgets the past: f(x) = 1 (F = 0), so mu = 1 and eta_0 = 1 + e_k
# for every particle whatever resampling did; h(x) = x^2, Q = R = 1. Only the weights carried
# out of step 1 differ between "resampled" (1/N) and "kept" (the step-1 weights).
def _forgetful(noise):
    return FlowStub(lambda x: np.ones_like(x), lambda x: np.zeros(x.shape + (1,)), square, d_square,
                    Q=[[1.0]], R=[[1.0]], noise=noise, m0=[1.0], P0=[[1.0]])


def _forgetful_lw(e, y):
    """Step weights of particles eta_0 = 1 + e at mu = 1 by hand: P_pred = 0 + Q = 1, eta_bar = 1,
    H = 2, y - e' = y - 1 + 2 = y + 1, S = 5, A = -2/5, b = (1/5)(3/5 * 2 (y + 1) - 2/5);
    eta_1 = eta_0 + A eta_0 + b, log det = log(3/5)."""
    eta0 = 1.0 + np.asarray(e)
    A, b = -0.4, 0.2 * (1.2 * (y + 1) - 0.4)
    eta1 = eta0 + A * eta0 + b
    return np.array([_log_w(a, c, 1.0, log(0.6), y) for a, c in zip(eta1, eta0)]), eta1


E1, E2, YS = [-1.0, 0.0, 1.5], [0.5, -0.5, 2.0], (2.0, 1.0)


@pytest.mark.parametrize("ess_threshold, resampled", [(None, [True, True]), (0.0, [False, False]),
                                                      (0.9, [True, False])])
def test_weights_carried_after_resampling(ess_threshold, resampled):
    """Run 0 sees (E1, E2), run 1 sees E1 with the particles swapped so its weights are flatter
    (the ESS threshold 0.9 N splits them). Step 2's estimate is sum_i c_i l_i eta_1^i / sum_i c_i l_i
    with c = 1/N after resampling and c = the step-1 weights otherwise; the evidence adds
    log sum_i c_i l_i. Checked against logw not reset to -log N after resampling (the old
    weights carried) and against the resampled runs' logw reset for every run."""
    noise1 = np.array([[[-1.0], [0.0], [1.5]], [[0.1], [0.0], [-0.1]]])
    noise2 = np.array([[[0.5], [-0.5], [2.0]], [[0.5], [-0.5], [2.0]]])
    model = _forgetful([noise1, noise2])
    pf = with_prior(ParticleFlowParticleFilter(model, 3, n_steps=1, ess_threshold=ess_threshold),
                    np.ones((2, 3, 1)))
    res = pf.filter(np.broadcast_to(fl(YS)[None, :, None], (2, 2, 1)).copy(), rng=np.random.default_rng(1))
    np.testing.assert_array_equal(res.diagnostics["resampled"][:, 0], resampled)
    for r in range(2):
        lw1, _ = _forgetful_lw(noise1[r, :, 0], YS[0])
        w1 = np.exp(lw1 - lw1.max()) / np.exp(lw1 - lw1.max()).sum()
        lw2, eta2 = _forgetful_lw(noise2[r, :, 0], YS[1])
        c = np.full(3, 1 / 3) if resampled[r] else w1
        v = c * np.exp(lw2)
        np.testing.assert_allclose(res.x[r, 1, 0], v @ eta2 / v.sum(), rtol=1e-12)
        ev = log(np.exp(lw1).mean()) + log(v.sum())
        np.testing.assert_allclose(res.diagnostics["log_evidence"][r], ev, rtol=1e-12)
        np.testing.assert_allclose(res.diagnostics["ess"][r, 0], 1 / (w1 @ w1), rtol=1e-12)


# ------------------------------------------------------------------------------ 5. zero weights, divergence
def test_zero_weights_resample_to_copies_and_survive_floating_point_errors():
    """Three particles x_0 = (1, 2, 2), noise (1/2, 40, 1e200): eta_0 = (1, 42, ~1e200). EDH as in
    the step-1 case (A = -1/3, b = 1/2): eta_1 = (7/6, 57/2, ~6.7e199). Particle 1's log weight is
    about -3e5 (its weight underflows to exactly 0), particle 2's is NaN (h and the transition
    density overflow, inf - inf), so w = (1, 0, 0): x_hat_1 = 7/6 and systematic resampling makes
    three copies of 7/6. Step 2 (zero noise, y = 1/2): every particle starts at
    f(7/6) = 49/72 = eta_bar, P_pred = (49/36)(2/3) + 1 = 103/54, H = 49/36,
    y - e = 1/2 + 2401/5184, A = -247303/634574, b = 8062990978945/28993259626272, so all three
    move to 6701614749697/9664419875424 with equal weights (ESS 3).
    The filter ignores the over/under/divide/invalid floating-point events it causes, also when
    the caller raises on them. Checked against the particles not resampled (ESS < 3, another
    estimate) and against errstate(under=None) (a FloatingPointError)."""
    model = scalar_stub(Q=[[1.0]], R=[[1.0]], noise=[[[0.5], [40.0], [1e200]], np.zeros((3, 1))],
                        m0=[1.0], P0=[[1.0]])
    pf = with_prior(ParticleFlowParticleFilter(model, 3, n_steps=1), [[[1.0], [2.0], [2.0]]])
    with np.errstate(all="raise"):
        res = pf.filter(fl([1.0, 0.5]).reshape(1, 2, 1), rng=np.random.default_rng(2))
    np.testing.assert_allclose(res.x[0, :, 0], [7 / 6, 6701614749697 / 9664419875424], rtol=1e-13)
    np.testing.assert_allclose(res.diagnostics["ess"][0], [1.0, 3.0], rtol=1e-13)
    assert not res.diagnostics["collapsed"].any()


def test_collapse_and_divergence_are_flagged_per_run_and_step():
    """Two runs of the forgetful stub (f = 1): run 1's step-1 draws are all +inf, so every log
    weight is NaN (collapse: uniform weights, ESS = N) and its estimate is inf (diverged); its
    step 2 is normal again (the transition forgets). Run 0 is normal throughout. Expected:
    collapsed = [[F, F], [T, F]], diverged = [F, T], ESS[1, 0] = 3, one WeightCollapseWarning
    naming PFPF(EDH). Checked against collapsed written to column k - 2 and against the
    divergence flag reduced over all runs (axis=None)."""
    noise1 = np.array([[[-1.0], [0.0], [1.5]], [[np.inf], [np.inf], [np.inf]]])
    noise2 = np.array([[[0.5], [-0.5], [2.0]], [[0.5], [-0.5], [2.0]]])
    pf = with_prior(ParticleFlowParticleFilter(_forgetful([noise1, noise2]), 3, n_steps=1, ess_threshold=0.5),
                    np.ones((2, 3, 1)))
    with pytest.warns(RuntimeWarning, match=r"^PFPF\(EDH\): weight collapse in 1 of 4 run-steps"):
        res = pf.filter(np.broadcast_to(fl(YS)[None, :, None], (2, 2, 1)).copy(), rng=np.random.default_rng(1))
    d = res.diagnostics
    np.testing.assert_array_equal(d["collapsed"], [[False, False], [True, False]])
    np.testing.assert_array_equal(d["diverged"], [False, True])
    assert d["n_collapsed"] == 1 and d["ess"][1, 0] == pytest.approx(3.0, rel=1e-14)
    assert np.isfinite(res.x[1, 1]).all() and np.isfinite(res.x[0]).all()


# ------------------------------------------------------------------------------ 6. settings
def test_settings_default_grid_initial_distribution_names_and_messages():
    """Defaults: 29 exponential steps with ratio 1.2, first step (1.2 - 1)/(1.2^29 - 1);
    the m0/P0 overrides start the EKF (model m0 = 0, P0 = 5 overridden by 1, 1 gives the
    step-1 numbers above); names PFPF(EDH)/PFPF(LEDH) and the repr; messages name the argument.
    Checked against ratio 2.2 by default, against m0 (P0) not passed to the base class, and
    against 'XXn_stepsXX' in the message."""
    model = scalar_stub(Q=[[1.0]], R=[[1.0]], noise=STEP1["noise"], m0=[0.0], P0=[[5.0]])
    f = ParticleFlowParticleFilter(model, 2)
    assert len(f.grid) == 30 and f.grid[1] == pytest.approx(0.2 / (1.2 ** 29 - 1), rel=1e-12)
    assert f.name == "PFPF(EDH)" and ParticleFlowParticleFilter(model, 2, flow="ledh").name == "PFPF(LEDH)"
    assert repr(f) == "ParticleFlowParticleFilter(N=2, flow='edh', n_steps=29, resampling='systematic')"
    pf = with_prior(ParticleFlowParticleFilter(model, 2, n_steps=1, m0=[1.0], P0=[[1.0]]), STEP1["x0"])
    res = pf.filter(fl([1.0]).reshape(1, 1, 1), rng=np.random.default_rng(0))
    np.testing.assert_allclose(res.diagnostics["log_det"][0, 0], log(2 / 3), rtol=1e-13)
    np.testing.assert_allclose(res.x[0, 0, 0], _edh1_weights() @ EDH1["eta1"], rtol=1e-13)
    for kw, msg in ((dict(n_particles=0), r"^n_particles must be >= 1"), (dict(n_steps=0), r"^n_steps must be >= 1"),
                    (dict(ess_threshold=1.5), r"^ess_threshold must lie in \[0, 1\]")):
        args = {"n_particles": 2, **kw}
        with pytest.raises(ValueError, match=msg):
            ParticleFlowParticleFilter(model, **args)
