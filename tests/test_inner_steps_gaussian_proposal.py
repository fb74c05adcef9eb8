"""Inner steps of the EKF- and UKF-proposal particle filters (filters/gaussian_proposal.py),
pinned by hand-computed cases (issue 35).

The older tests of these filters (test_modern_filters) use a linear-Gaussian model: there the
linearised proposal is exact, the unscented one equals it, and the sigma-point weight of the
centre point multiplies a zero deviation (h(mu) = y_hat for a linear h), so a wrong beta or a
wrong centre weight passes. Here the measurement is BILINEAR, h(a, b) = a b, so the UT's
y_hat = mu_a mu_b + Q_ab differs from h(mu) and every sigma-point weight counts. One step per
test, against numbers computed by hand (written out below) with stubs whose transition,
measurement and random draws the test controls:

* the proposal's mean and covariance per particle: linearised (Doucet et al. 2000) and
  unscented (van der Merwe et al. 2000) with the default (1, 2, 0) and non-default UT
  parameters;
* log N(x; m, L L^T) with a shared and with a per-particle factor, and the incremental weight
  p(y | x) N(x; mu, Q) / N(x; m, Sigma);
* the filter's draw x = m + L z and its step-1 weights, estimate, ESS and evidence;
* the weights carried into step 2 (resampled, not resampled, the ESS threshold's boundary);
* the constructor's checks and the collapse report.

Each test was checked once against the wrong formula named in its docstring (the formula
applied by hand to src/, the test seen to fail, the change reverted).
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import stats
from scipy.special import logsumexp

from pfrepro.filters import GaussianProposalParticleFilter
from pfrepro.filters.gaussian_proposal import _log_normal
from pfrepro.filters.particle import WeightCollapseWarning

LOG2PI = np.log(2 * np.pi)


# ------------------------------------------------------------------------------ stubs
class Bilinear:
    """x = (a, b); f(x, k) = (a + k, b / 2); y = h(x) + v with h(x) = a b and v ~ N(0, R = 2);
    Q = [[4, 2], [2, 2]] with Cholesky factor L_Q = [[2, 0], [1, 1]] (columns (2, 1), (0, 1)).

    The filter's initial distribution is N(0, I), so the prior draw IS the scripted normals."""

    dim_x = 2
    dim_y = 1
    Q = np.array([[4.0, 2.0], [2.0, 2.0]])
    R = np.array([[2.0]])
    m0 = np.zeros(2)
    P0 = np.eye(2)

    def __init__(self, dead_runs=(), dead_from=1):
        self.dead_runs = list(dead_runs)     # runs whose likelihood is 0 for every particle ...
        self.dead_from = dead_from           # ... from the step whose measurement is >= this

    def f(self, x, k):
        return np.stack([x[..., 0] + k, 0.5 * x[..., 1]], axis=-1)

    def h(self, x):
        return (x[..., 0] * x[..., 1])[..., None]

    def jacobian_h(self, x):
        return np.stack([x[..., 1], x[..., 0]], axis=-1)[..., None, :]      # (..., 1, 2)

    def residual_y(self, a, b):
        return a - b

    def log_likelihood(self, y, x):
        r = y[:, None, 0] - x[..., 0] * x[..., 1]
        ll = -0.25 * r ** 2 - 0.5 * np.log(2 * np.pi * 2.0)
        dead = [r for r in self.dead_runs if y[r, 0] >= self.dead_from]
        ll[dead] = -np.inf
        return ll


class ScriptedGenerator(np.random.Generator):
    """A Generator whose ``standard_normal`` returns the scripted arrays in order (checking the
    requested shape) and whose ``random`` returns ``u`` everywhere (systematic resampling with
    U = u)."""

    def __init__(self, normals, u=0.5):
        super().__init__(np.random.PCG64(0))
        self.normals = [np.asarray(a, float) for a in normals]
        self.u = u

    def standard_normal(self, size=None, dtype=np.float64, out=None):
        a = self.normals.pop(0)
        assert a.shape == tuple(size), (a.shape, size)
        return a.copy()

    def random(self, size=None, dtype=np.float64, out=None):
        return np.full(size, self.u)


def logN(x, m, C):
    return stats.multivariate_normal(np.asarray(m, float), np.asarray(C, float)).logpdf(x)


# ------------------------------------------------------------------------------ the hand case
# Two runs, two particles. Transition means mu (the same in both runs):
#   particle 0: mu = (1, 2),    H = (b, a) = (2, 1),      h(mu) = 2
#   particle 1: mu = (2, -1/2), H = (-1/2, 2),            h(mu) = -1
# measurements: run 0 y = 5, run 1 y = -1.
MU = np.array([[1.0, 2.0], [2.0, -0.5]])
MU2 = np.stack([MU, MU])                                  # (runs, N, n)
Y = np.array([[5.0], [-1.0]])
Q = Bilinear.Q

# Linearised (EKF) update:
#  p0: Q H^T = (4*2 + 2*1, 2*2 + 2*1) = (10, 6); S = 2*10 + 6 + R = 28; K = (5/14, 3/14)
#      run 0: r = 3 -> m = (1 + 15/14, 2 + 9/14) = (29/14, 37/14); run 1: r = -3 -> (-1/14, 19/14)
#      Sigma = Q - (10, 6)(10, 6)^T / 28 = [[3/7, -1/7], [-1/7, 5/7]]
#  p1: Q H^T = (-2 + 4, -1 + 4) = (2, 3); S = -1 + 6 + 2 = 7; K = (2/7, 3/7)
#      run 0: r = 6 -> m = (2 + 12/7, -1/2 + 18/7) = (26/7, 29/14); run 1: r = 0 -> m = mu
#      Sigma = Q - (2, 3)(2, 3)^T / 7 = [[24/7, 8/7], [8/7, 5/7]]
EKF_MEAN = np.array([[[29 / 14, 37 / 14], [26 / 7, 29 / 14]],
                     [[-1 / 14, 19 / 14], [2.0, -0.5]]])
EKF_COV = np.array([[[3 / 7, -1 / 7], [-1 / 7, 5 / 7]], [[24 / 7, 8 / 7], [8 / 7, 5 / 7]]])
# their Cholesky factors, by hand
EKF_CHOL = np.array([[[np.sqrt(3 / 7), 0.0], [-1 / np.sqrt(21), np.sqrt(2 / 3)]],
                     [[np.sqrt(24 / 7), 0.0], [4 / np.sqrt(42), np.sqrt(1 / 3)]]])

# Unscented, defaults alpha = 1, beta = 2, kappa = 0: lambda = 0, sigma points mu +- sqrt(2) c_j,
# W_m = (0, 1/4, 1/4, 1/4, 1/4), W_c = (0 + 1 - 1 + 2, 1/4, ...) = (2, 1/4, ...).
#  p0: h at mu +- sqrt2 (2, 1): 6 +- 5 sqrt2; at mu +- sqrt2 (0, 1): 2 +- sqrt2; centre 2
#      y_hat = 16/4 = 4 (= mu_a mu_b + Q_ab; the linearised 2 is off by Q_ab)
#      S = 2 * (2 - 4)^2 + (2 * 54 + 2 * 6) / 4 + 2 = 8 + 30 + 2 = 40   (the centre counts 8)
#      Pxy = (20 c_1 + 4 c_2) / 4 = (10, 6); K = (1/4, 3/20)
#      run 0: r = 1 -> m = (5/4, 43/20); run 1: r = -5 -> (-1/4, 5/4)
#      Sigma = Q - (10, 6)(10, 6)^T / 40 = [[3/2, 1/2], [1/2, 11/10]]
#  p1: h at mu +- sqrt2 (2, 1): 3 +- sqrt2; at mu +- sqrt2 (0, 1): -1 +- 2 sqrt2; centre -1
#      y_hat = 4/4 = 1; S = 2 * 4 + (2 * 6 + 2 * 12) / 4 + 2 = 19; Pxy = (4 c_1 + 8 c_2) / 4 = (2, 3)
#      run 0: r = 4 -> m = (2 + 8/19, -1/2 + 12/19) = (46/19, 5/38); run 1: r = -2 -> (34/19, -31/38)
#      Sigma = Q - (2, 3)(2, 3)^T / 19 = [[72/19, 32/19], [32/19, 29/19]]
UKF_MEAN = np.array([[[5 / 4, 43 / 20], [46 / 19, 5 / 38]],
                     [[-1 / 4, 5 / 4], [34 / 19, -31 / 38]]])
UKF_COV = np.array([[[3 / 2, 1 / 2], [1 / 2, 11 / 10]], [[72 / 19, 32 / 19], [32 / 19, 29 / 19]]])

# Unscented, alpha = 2, beta = 4, kappa = -1: lambda = 4 (2 - 1) - 2 = 2, n + lambda = 4,
# sigma points mu +- 2 c_j, W_m = (1/2, 1/8, ...), W_c = (1/2 + 1 - 4 + 4, 1/8, ...) = (3/2, 1/8, ...).
#  p0: points (5, 4), (1, 4), (-3, 0), (1, 0) -> h = 20, 4, 0, 0; centre 2
#      y_hat = 1 + 24/8 = 4; S = 3/2 * 4 + (16^2 + 0 + 4^2 + 4^2) / 8 + 2 = 6 + 36 + 2 = 44
#      Pxy = ((4, 2) 16 + (0, 2) 0 + (-4, -2)(-4) + (0, -2)(-4)) / 8 = (10, 6); K = (5/22, 3/22)
#      run 0: m = (27/22, 47/22); run 1: r = -5 -> (-3/22, 29/22)
#      Sigma = Q - (10, 6)(10, 6)^T / 44 = [[19/11, 7/11], [7/11, 13/11]]
#  p1: points (6, 3/2), (2, 3/2), (-2, -5/2), (2, -5/2) -> h = 9, 3, 5, -5; centre -1
#      y_hat = -1/2 + 12/8 = 1; S = 6 + (64 + 4 + 16 + 36) / 8 + 2 = 23
#      Pxy = ((4, 2) 8 + (0, 2) 2 + (-4, -2) 4 + (0, -2)(-6)) / 8 = (2, 3)
#      run 0: r = 4 -> m = (54/23, 1/46); run 1: r = -2 -> (42/23, -35/46)
#      Sigma = Q - (2, 3)(2, 3)^T / 23 = [[88/23, 40/23], [40/23, 37/23]]
UT2 = dict(alpha=2.0, beta=4.0, kappa=-1.0)
UKF2_MEAN = np.array([[[27 / 22, 47 / 22], [54 / 23, 1 / 46]],
                      [[-3 / 22, 29 / 22], [42 / 23, -35 / 46]]])
UKF2_COV = np.array([[[19 / 11, 7 / 11], [7 / 11, 13 / 11]], [[88 / 23, 40 / 23], [40 / 23, 37 / 23]]])


def _check_update(f, mean_expected, cov_expected):
    mean, L = f.local_update(MU2, Y)
    assert mean.shape == (2, 2, 2) and L.shape == (2, 2, 2, 2)
    np.testing.assert_allclose(mean, mean_expected, rtol=1e-12, atol=1e-14)
    # the factor is lower-triangular, positive on its diagonal, and L L^T = Sigma (both runs)
    assert np.all(np.triu(L, 1) == 0) and np.all(np.diagonal(L, axis1=-2, axis2=-1) > 0)
    np.testing.assert_allclose(L @ np.swapaxes(L, -1, -2), np.stack([cov_expected] * 2), rtol=1e-12, atol=1e-14)
    # one run of N = 3 particles (p0, p1, p0 again; N != n): the same numbers per particle
    m3, L3 = f.local_update(MU[[0, 1, 0]][None], Y[:1])
    np.testing.assert_allclose(m3[0], mean_expected[0, [0, 1, 0]], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(L3[0], L[0, [0, 1, 0]], rtol=1e-12, atol=1e-14)
    return mean, L


def test_linearized_proposal_mean_and_covariance_by_hand():
    """The EKF update at mu with H = dh/dx(mu), on a bilinear h. Checked against the wrong
    formula once: S = H Q H^T without + R (then K = (10/26, 6/26), m = (28/13, 35/13) for p0)."""
    _, L = _check_update(GaussianProposalParticleFilter(Bilinear(), 2), EKF_MEAN, EKF_COV)
    np.testing.assert_allclose(L, np.stack([EKF_CHOL] * 2), rtol=1e-12, atol=1e-14)


def test_unscented_proposal_default_parameters_by_hand():
    """UT with alpha = 1, beta = 2, kappa = 0: y_hat = 4 (not h(mu) = 2) and the centre point's
    covariance weight W_c0 = 2 contributes 8 to S = 40. Checked against the wrong formula once:
    W_c0 = W_m0 (= 0, beta ignored: S = 32, K = (5/16, 3/16))."""
    _check_update(GaussianProposalParticleFilter(Bilinear(), 2, proposal="unscented"), UKF_MEAN, UKF_COV)


def test_unscented_proposal_other_parameters_by_hand():
    """alpha = 2, beta = 4, kappa = -1: lambda = 2, W_m0 = 1/2, W_c0 = 3/2, spread sqrt(n + lambda) = 2.
    Checked against the wrong formula once: lambda = alpha^2 (n - kappa) - n (= 10)."""
    _check_update(GaussianProposalParticleFilter(Bilinear(), 2, proposal="unscented", **UT2),
                  UKF2_MEAN, UKF2_COV)


def test_unscented_weights_stored_by_the_constructor():
    """(lambda, W_m, W_c) for n = 2. Checked against the wrong formula once: W_c0 = lambda/(n + lambda)
    + 1 + alpha^2 + beta."""
    lam, wm, wc = GaussianProposalParticleFilter(Bilinear(), 2, proposal="unscented")._ut
    assert lam == 0.0
    np.testing.assert_array_equal(wm, [0.0, 0.25, 0.25, 0.25, 0.25])
    np.testing.assert_array_equal(wc, [2.0, 0.25, 0.25, 0.25, 0.25])
    lam, wm, wc = GaussianProposalParticleFilter(Bilinear(), 2, proposal="unscented", **UT2)._ut
    assert lam == 2.0
    np.testing.assert_array_equal(wm, [0.5, 0.125, 0.125, 0.125, 0.125])
    np.testing.assert_array_equal(wc, [1.5, 0.125, 0.125, 0.125, 0.125])


# ------------------------------------------------------------------------------ densities
def test_log_normal_with_shared_and_per_particle_factors_by_hand():
    """log N(x; m, L L^T) = -|L^{-1}(x - m)|^2 / 2 - sum log L_ii - (n/2) log 2 pi.
    L_Q = [[2, 0], [1, 1]], x - m = (1, 1): z = (1/2, 1/2), |z|^2 = 1/2, log det L = log 2.
    L = diag(1, 3), x - m = (3, 3): z = (3, 1), |z|^2 = 10, log det L = log 3.
    Checked against the wrong formula once: logdet = 2 sum log L_ii (the covariance's)."""
    LQ = np.array([[2.0, 0.0], [1.0, 1.0]])
    x = np.array([[[1.0, 3.0], [3.0, 4.0]]])                   # (runs=1, N=2, 2)
    m = np.array([[[0.0, 2.0], [0.0, 1.0]]])
    shared = _log_normal(x, m, LQ)
    # particle 1 under L_Q: d = (3, 3), z = (3/2, 3/2), |z|^2 = 9/2
    np.testing.assert_allclose(shared, [[-0.25 - np.log(2) - LOG2PI, -2.25 - np.log(2) - LOG2PI]], rtol=1e-14)
    per = _log_normal(x, m, np.array([[LQ, np.diag([1.0, 3.0])]]))
    np.testing.assert_allclose(per, [[-0.25 - np.log(2) - LOG2PI, -5.0 - np.log(3) - LOG2PI]], rtol=1e-14)
    # against scipy (the covariance L L^T)
    np.testing.assert_allclose(per[0, 1], logN(x[0, 1], m[0, 1], np.diag([1.0, 9.0])), rtol=1e-14)
    # a (N, n, n) stack of factors for (N, n) points (no runs axis)
    three = _log_normal(x[0], m[0], np.array([LQ, np.diag([1.0, 3.0])]))
    np.testing.assert_allclose(three, per[0], rtol=1e-14)
    # three points (N = 3 != n), shared factor: n is read from the last axis
    np.testing.assert_allclose(_log_normal(x[:, [0, 1, 0]], m[:, [0, 1, 0]], LQ), shared[:, [0, 1, 0]], rtol=1e-14)


def test_log_weight_increment_by_hand():
    """log p(y | x) + log N(x; mu, Q) - log N(x; m, Sigma) at x = m (linearised, run 0, p0):
    h(m) = 29 * 37 / 196 = 1073/196, r = 5 - 1073/196 = -93/196, log p = -r^2/4 - log(2 sqrt(pi));
    d = m - mu = (15/14, 9/14), d^T Q^{-1} d = 58.5/196 (Q^{-1} = [[1/2, -1/2], [-1/2, 1]]),
    log N(x; mu, Q) = -58.5/392 - log 2 - log 2 pi; log N(m; m, Sigma) = -log 2 pi - log det(Sigma)/2
    with det Sigma = 2/7. Checked against the wrong formula once: + log N(x; m, Sigma)."""
    f = GaussianProposalParticleFilter(Bilinear(), 2)
    mean, L = f.local_update(MU2, Y)
    inc = f.log_weight_increment(mean, MU2, mean, L, Y)
    by_hand = (-(93 / 196) ** 2 / 4 - 0.5 * np.log(4 * np.pi)
               - 58.5 / 392 - np.log(2) - LOG2PI
               + LOG2PI + 0.5 * np.log(2 / 7))
    assert inc[0, 0] == pytest.approx(by_hand, rel=1e-12)
    # every particle against scipy with the hand means and covariances
    for r in range(2):
        for i in range(2):
            x = EKF_MEAN[r, i]
            ref = (stats.norm(x[0] * x[1], np.sqrt(2)).logpdf(Y[r, 0]) + logN(x, MU[i], Q)
                   - logN(x, EKF_MEAN[r, i], EKF_COV[i]))
            assert inc[r, i] == pytest.approx(ref, rel=1e-12)


# ------------------------------------------------------------------------------ the filter
# prior draws = the starting particles (m0 = 0, P0 = I): (0, 4) -> f(., 1) = (1, 2); (1, -1) -> (2, -1/2)
Z0 = np.array([[[0.0, 4.0], [1.0, -1.0]]] * 2)
Z1 = np.array([[[0.0, 0.0], [1.0, -1.0]],          # run 0: p0 at its proposal mean, p1 at m + L (1, -1)
               [[-1.0, 2.0], [0.0, 0.0]]])         # run 1


def _step1_by_hand(mean, chol, cov):
    """x = m + L z, and the weights p(y|x) N(x; mu, Q) / N(x; m, Sigma) from scipy densities."""
    x = mean + np.einsum("pij,rpj->rpi", chol, Z1)
    lw = np.array([[stats.norm(x[r, i, 0] * x[r, i, 1], np.sqrt(2)).logpdf(Y[r, 0])
                    + logN(x[r, i], MU[i], Q) - logN(x[r, i], mean[r, i], cov[i])
                    for i in range(2)] for r in range(2)])
    return x, lw


@pytest.mark.parametrize("proposal, kw, mean, cov", [
    ("linearized", {}, EKF_MEAN, EKF_COV),
    ("unscented", UT2, UKF2_MEAN, UKF2_COV),
])
def test_filter_step_one_draw_weights_estimate_and_evidence(proposal, kw, mean, cov):
    """One step, scripted normals: the draw is x = m + L z with the hand (m, L); the weights
    p(y|x) N(x; mu, Q) / N(x; m, Sigma) (prior weights 1/N), the weighted estimate, ESS = 1/sum w^2,
    log evidence = log mean_i of the increments. Checked against the wrong formula once:
    log q = -|z|^2/2 - log det L (without - (n/2) log 2 pi: every increment moves by log 2 pi)."""
    chol = np.linalg.cholesky(cov)
    x1, lw = _step1_by_hand(mean, chol, cov)
    # the hand draw for run 0, p1 (linearised): m + L (1, -1)
    if proposal == "linearized":
        np.testing.assert_allclose(x1[0, 1], [26 / 7 + np.sqrt(24 / 7), 29 / 14 + 4 / np.sqrt(42) - np.sqrt(1 / 3)])
        np.testing.assert_allclose(x1[0, 0], [29 / 14, 37 / 14])
    f = GaussianProposalParticleFilter(Bilinear(), 2, proposal=proposal, **kw)
    res = f.filter(Y[:, None, :], ScriptedGenerator([Z0, Z1]))
    w = np.exp(lw - logsumexp(lw, axis=1, keepdims=True))
    np.testing.assert_allclose(res.x[:, 0], np.einsum("rp,rpi->ri", w, x1), rtol=1e-12)
    np.testing.assert_allclose(res.diagnostics["log_evidence"], logsumexp(lw, axis=1) - np.log(2), rtol=1e-12)
    np.testing.assert_allclose(res.diagnostics["ess"][:, 0], 1 / np.sum(w ** 2, axis=1), rtol=1e-12)
    np.testing.assert_array_equal(res.diagnostics["resampled"], [[True], [True]])
    assert res.diagnostics["n_collapsed"] == 0 and not res.diagnostics["collapsed"].any()
    assert res.P is None and res.x.shape == (2, 1, 2)


def _reference_filter(y, normals, u, threshold, N=2):
    """The EKF-proposal PF written out particle by particle (textbook formulas, np.linalg.inv,
    scipy densities, systematic resampling with U = u, counts N C_i - U rounded up)."""
    model = Bilinear()
    runs, T, _ = y.shape
    x = normals[0].copy()
    logw = np.full((runs, N), -np.log(N))
    xs, ev, res, ess = np.zeros((runs, T, 2)), np.zeros(runs), np.zeros((runs, T), bool), np.zeros((runs, T))
    for k in range(1, T + 1):
        for r in range(runs):
            lw = np.zeros(N)
            for i in range(N):
                mu = model.f(x[r, i], k)
                H = np.array([[mu[1], mu[0]]])
                S = H @ Q @ H.T + model.R
                K = Q @ H.T @ np.linalg.inv(S)
                m = mu + K @ (y[r, k - 1] - mu[0] * mu[1])
                C = Q - K @ S @ K.T
                x[r, i] = m + np.linalg.cholesky(C) @ normals[k][r, i]
                lw[i] = (stats.norm(x[r, i, 0] * x[r, i, 1], np.sqrt(2)).logpdf(y[r, k - 1, 0])
                         + logN(x[r, i], mu, Q) - logN(x[r, i], m, C))
            a = logw[r] + lw
            ev[r] += logsumexp(a)
            w = np.exp(a - logsumexp(a))
            xs[r, k - 1] = w @ x[r]
            logw[r] = np.log(w)
            ess[r, k - 1] = 1 / np.sum(w ** 2)
            if threshold is None or ess[r, k - 1] < threshold * N:
                res[r, k - 1] = True
                below = np.ceil(N * np.cumsum(w) - u).astype(int)
                below[-1] = N
                counts = np.diff(np.r_[0, below])
                x[r] = np.repeat(x[r], counts, axis=0)
                logw[r] = -np.log(N)
    return xs, ev, res, ess


Y2 = np.array([[[5.0], [3.0]], [[-1.0], [2.0]]])                          # (runs, T = 2, 1)
Z2 = np.array([[[0.5, 0.0], [-1.0, 0.5]], [[0.0, 1.0], [1.0, 1.0]]])


@pytest.mark.parametrize("threshold, resampled", [
    (None, [[True, True], [True, True]]),       # every run every step (the whole generator)
    (0.0, [[False, False], [False, False]]),    # never: w_1 carried into step 2 as log w_1
    (0.7, [[True, False], [False, True]]),      # run 0 at step 1 only, run 1 at step 2 only
])
def test_filter_two_steps_carries_resampled_and_kept_weights(threshold, resampled):
    """Two steps: a run that resamples enters step 2 with its particles repeated by the
    systematic counts and weights 1/N; a run that does not carries its particles and log w_1, so
    step 2's increment is log sum_i w_1^i p(y|x) N(x; mu, Q) / q. Against the per-particle
    reference above. Checked against the wrong formula once: logw = -log N after every step
    (the kept run's step-2 evidence and estimate move)."""
    f = GaussianProposalParticleFilter(Bilinear(), 2, ess_threshold=threshold)
    # step-1 ESS: run 0 1.00002 < 0.7 * 2, run 1 1.574 >= 1.4; at step 2 (threshold 0.7) run 0
    # (resampled) 1.99999 >= 1.4, run 1 (kept) 1.092 < 1.4
    res = f.filter(Y2, ScriptedGenerator([Z0, Z1, Z2], u=0.3))
    xs, ev, rs, ess = _reference_filter(Y2, [Z0, Z1, Z2], 0.3, threshold)
    np.testing.assert_array_equal(res.diagnostics["resampled"], resampled)
    np.testing.assert_array_equal(rs, resampled)
    np.testing.assert_allclose(res.x, xs, rtol=1e-11)
    np.testing.assert_allclose(res.diagnostics["log_evidence"], ev, rtol=1e-11)
    np.testing.assert_allclose(res.diagnostics["ess"], ess, rtol=1e-9)
    assert res.diagnostics["resampled"].dtype == bool and res.diagnostics["collapsed"].dtype == bool


def test_ess_threshold_boundary_does_not_resample():
    """Two identical particles: equal weights, ESS = N exactly; threshold 1 resamples only when
    ESS < N, so nothing resamples (the particles and 1/N weights are unchanged either way, only
    the flag shows it). Checked against the wrong formula once: ESS <= threshold N."""
    z0 = np.array([[[0.0, 4.0], [0.0, 4.0]]])
    z1 = np.array([[[0.3, -0.2], [0.3, -0.2]]])
    res = GaussianProposalParticleFilter(Bilinear(), 2, ess_threshold=1.0).filter(
        Y[:1, None, :], ScriptedGenerator([z0, z1]))
    assert res.diagnostics["ess"][0, 0] == 2.0
    assert not res.diagnostics["resampled"].any()
    res = GaussianProposalParticleFilter(Bilinear(), 2, ess_threshold=1.0).filter(
        Y[:1, None, :], ScriptedGenerator([Z0[:1], Z1[:1]]))
    assert res.diagnostics["resampled"].all()         # unequal weights: ESS < N


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_collapse_is_reported_under_the_filters_name_and_floating_point_errors_are_contained():
    """Run 1's likelihood is 0 for every particle: its step is a collapse (log evidence -inf,
    one warning naming the filter); run 0 has a particle whose weight underflows to 0 (log 0
    for its carried weight). Both under np.errstate(all="raise"): the filter's own errstate must
    contain the divide/underflow. Checked against the wrong formula once: errstate(divide=None)."""
    z0 = np.array([[[0.0, 4.0], [30.0, 30.0]], [[0.0, 4.0], [1.0, -1.0]]])
    z1 = np.zeros((2, 2, 2))
    for proposal, name in [("linearized", "EKF-proposal PF"), ("unscented", "UT-proposal PF")]:
        f = GaussianProposalParticleFilter(Bilinear(dead_runs=[1]), 2, proposal=proposal, ess_threshold=0.0)
        with np.errstate(all="raise"), pytest.warns(WeightCollapseWarning,
                                                    match=rf"^{name}: weight collapse in 2 of 4 run-steps"):
            res = f.filter(np.array([[[5.0], [5.0]], [[5.0], [5.0]]]), ScriptedGenerator([z0, z1, z1]))
        np.testing.assert_array_equal(res.diagnostics["collapsed"], [[False, False], [True, True]])
        assert res.diagnostics["n_collapsed"] == 2
        assert res.diagnostics["log_evidence"][1] == -np.inf and np.isfinite(res.diagnostics["log_evidence"][0])
        assert res.diagnostics["ess"][0, 0] == pytest.approx(1.0)
        assert res.diagnostics["collapsed"].dtype == bool
    # run 1 collapses at step 2 only (y_2 = 6 >= dead_from): the flag sits at step 2
    f = GaussianProposalParticleFilter(Bilinear(dead_runs=[1], dead_from=6.0), 2)
    with pytest.warns(WeightCollapseWarning, match=r"^EKF-proposal PF: weight collapse in 1 of 4 run-steps"):
        res = f.filter(np.array([[[5.0], [5.0]], [[5.0], [6.0]]]), ScriptedGenerator([z0, z1, z1]))
    np.testing.assert_array_equal(res.diagnostics["collapsed"], [[False, False], [False, True]])


def test_a_far_particle_gets_weight_zero_without_floating_point_errors():
    """UKF proposal, particle 1 starts at (1e100, 1e100): its likelihood's square overflows to
    p = 0 (a legitimate -inf log-weight), so the estimate is particle 0's draw, the UKF mean
    (5/4, 43/20) by hand (z = 0), and the evidence is its increment times 1/2; all under
    np.errstate(all="raise"). Checked against the wrong formula once: errstate(over=None)."""
    z0 = np.array([[[0.0, 4.0], [1e100, 1e100]]])
    z1 = np.zeros((1, 2, 2))
    f = GaussianProposalParticleFilter(Bilinear(), 2, proposal="unscented", ess_threshold=0.0)
    with np.errstate(all="raise"):
        res = f.filter(np.array([[[5.0]]]), ScriptedGenerator([z0, z1]))
    np.testing.assert_allclose(res.x[0, 0], [5 / 4, 43 / 20], rtol=1e-14)
    x = np.array([5 / 4, 43 / 20])
    inc = (stats.norm(x[0] * x[1], np.sqrt(2)).logpdf(5.0) + logN(x, MU[0], Q)
           - logN(x, UKF_MEAN[0, 0], UKF_COV[0]))
    np.testing.assert_allclose(res.diagnostics["log_evidence"], [inc - np.log(2)], rtol=1e-12)
    assert res.diagnostics["ess"][0, 0] == 1.0


# ------------------------------------------------------------------------------ constructor
def test_constructor_settings_names_and_requirements():
    """Checked against the wrong formula once: the UKF proposal requiring jacobian_h."""
    ekf = GaussianProposalParticleFilter(Bilinear(), 7)
    ukf = GaussianProposalParticleFilter(Bilinear(), 3, proposal="unscented", resampling="residual",
                                         ess_threshold=0.25)
    assert (ekf.name, ukf.name) == ("EKF-proposal PF", "UT-proposal PF")
    assert ekf.model_requirements == ("f", "h", "additive_measurement", "transition_density", "jacobian_h")
    assert ukf.model_requirements == ("f", "h", "additive_measurement", "transition_density")
    assert (ekf.proposal, ekf.n_particles, ekf.resampling, ekf.ess_threshold) == ("linearized", 7, "systematic", None)
    assert (ukf.proposal, ukf.n_particles, ukf.resampling, ukf.ess_threshold) == ("unscented", 3, "residual", 0.25)
    assert repr(ekf) == "GaussianProposalParticleFilter(N=7, proposal='linearized', resampling='systematic')"
    assert repr(ukf) == "GaussianProposalParticleFilter(N=3, proposal='unscented', resampling='residual')"
    np.testing.assert_array_equal(ekf._LQ, [[2.0, 0.0], [1.0, 1.0]])
    np.testing.assert_array_equal(ekf._R, [[2.0]])
    # integer Q and R given as lists are stored as float arrays
    ints = Bilinear()
    ints.Q, ints.R = [[4, 2], [2, 2]], [[2]]
    f = GaussianProposalParticleFilter(ints, 2)
    assert f._Q.dtype == float and f._R.dtype == float


def test_initial_distribution_override_is_used():
    """m0 = (1, 1), P0 = 4 I: the prior draw is m0 + 2 z, so z = (Z0 - m0) / 2 gives the hand case's
    particles and the same step-1 results; the filter keeps the overrides. Checked against the
    wrong formula once: super().__init__(model, m0, None) (the model's P0 = I: particles at
    m0 + z)."""
    m0, P0 = np.array([1.0, 1.0]), 4.0 * np.eye(2)
    f = GaussianProposalParticleFilter(Bilinear(), 2, m0=m0, P0=P0)
    np.testing.assert_array_equal(f.m0, m0)
    np.testing.assert_array_equal(f.P0, P0)
    res = f.filter(Y[:, None, :], ScriptedGenerator([(Z0 - m0) / 2, Z1]))
    ref = GaussianProposalParticleFilter(Bilinear(), 2).filter(Y[:, None, :], ScriptedGenerator([Z0, Z1]))
    np.testing.assert_allclose(res.x, ref.x, rtol=1e-14)
    np.testing.assert_allclose(res.diagnostics["log_evidence"], ref.diagnostics["log_evidence"], rtol=1e-14)


def test_constructor_refuses_bad_settings_with_exact_messages():
    """n + lambda = alpha^2 (n + kappa) must be > 0: kappa = -2 gives exactly 0 and is refused,
    kappa = -1.5 gives 1/2 and is accepted. Checked against the wrong formula once:
    n + lam < 0 (the boundary accepted)."""
    with pytest.raises(ValueError, match=r"^proposal must be one of \('linearized', 'unscented'\), got 'ekf'$"):
        GaussianProposalParticleFilter(Bilinear(), 5, proposal="ekf")
    with pytest.raises(ValueError, match=r"^unscented parameters give n \+ lambda = 0\.0 <= 0$"):
        GaussianProposalParticleFilter(Bilinear(), 5, proposal="unscented", kappa=-2.0)
    lam = GaussianProposalParticleFilter(Bilinear(), 5, proposal="unscented", kappa=-1.5)._ut[0]
    assert lam == -1.5
    with pytest.raises(ValueError, match=r"^n_particles must be >= 1, got 0$"):
        GaussianProposalParticleFilter(Bilinear(), 0)
    with pytest.raises(ValueError, match=r"^ess_threshold must lie in \[0, 1\], got 1.5$"):
        GaussianProposalParticleFilter(Bilinear(), 5, ess_threshold=1.5)
    with pytest.raises(ValueError, match="resampling scheme"):
        GaussianProposalParticleFilter(Bilinear(), 5, resampling="best")
    with pytest.raises(TypeError, match="rng"):
        GaussianProposalParticleFilter(Bilinear(), 5).filter(Y[:, None, :], None)
