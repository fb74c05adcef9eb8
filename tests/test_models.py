"""Models: Jacobians, discretisation, simulation conventions, likelihoods and noise densities."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad_vec
from scipy.linalg import expm
from scipy.stats import multivariate_normal

from conftest import random_linear_model, random_spd
from pfrepro.models import CWPA, UNGM, BearingsOnly, LinearGaussianModel, Simulation, van_loan_discretize, wrap_angle
from pfrepro.noise import GaussianMixtureNoise, GaussianNoise


def central_diff_jacobian(fun, x, eps=1e-6):
    """d fun / d x by central differences, for one state ``x`` (n,)."""
    cols = []
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = eps
        cols.append((fun(x + e) - fun(x - e)) / (2 * eps))
    return np.stack(cols, axis=-1)


# ------------------------------------------------------------------ Jacobians ---------------------
@pytest.mark.parametrize("model", [UNGM.zhang2016(), UNGM.li2012_model2(), UNGM.ning2011()],
                         ids=["zhang", "li-model2", "ning"])
def test_ungm_jacobians_vs_finite_differences(model):
    for x in np.linspace(-20, 20, 41):
        x = np.array([x])
        for k in (1, 2, 7):
            np.testing.assert_allclose(model.jacobian_f(x, k), central_diff_jacobian(lambda z: model.f(z, k), x),
                                       rtol=1e-7, atol=1e-8)
        np.testing.assert_allclose(model.jacobian_h(x), central_diff_jacobian(model.h, x), rtol=1e-7, atol=1e-8)


def test_bot_jacobians_vs_finite_differences():
    model = BearingsOnly.zhang2016()
    rng = np.random.default_rng(0)
    for x in rng.uniform([-30, -5, -2, -2], [30, 50, 2, 2], size=(30, 4)):
        np.testing.assert_allclose(model.jacobian_f(x, 1), central_diff_jacobian(lambda z: model.f(z, 1), x),
                                   rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(model.jacobian_h(x), central_diff_jacobian(model.h, x), rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("model", [UNGM.zhang2016(), BearingsOnly.zhang2016(), CWPA.zhang2016(),
                                   random_linear_model(3, 3, 2)], ids=["UNGM", "BOT", "CWPA", "linear"])
def test_functions_and_jacobians_batch_over_leading_axes(model):
    rng = np.random.default_rng(1)
    X = rng.normal(size=(3, 5, model.dim_x)) + np.r_[5.0, 20.0, 0, 0, 0, 0][: model.dim_x]
    X_copy = X.copy()
    assert model.f(X, 3).shape == X.shape
    assert model.h(X).shape == (3, 5, model.dim_y)
    assert model.jacobian_f(X, 3).shape == (3, 5, model.dim_x, model.dim_x)
    assert model.jacobian_h(X).shape == (3, 5, model.dim_y, model.dim_x)
    np.testing.assert_array_equal(X, X_copy)  # no in-place modification of the input
    for i, j in [(0, 0), (2, 4)]:
        np.testing.assert_allclose(model.f(X, 3)[i, j], model.f(X[i, j], 3), rtol=1e-15)
        np.testing.assert_allclose(model.jacobian_h(X)[i, j], model.jacobian_h(X[i, j]), rtol=1e-15)


def test_ungm_formula_and_presets():
    x = np.array([[-3.0], [0.5], [2.0]])
    m = UNGM.zhang2016()
    for k in (1, 4):
        expected = 0.5 * x + 25 * x / (1 + x**2) + 8 * np.cos(1.2 * (k - 1))
        np.testing.assert_allclose(m.f(x, k), expected, rtol=1e-14)
    np.testing.assert_allclose(m.h(x), x**2 / 20, rtol=1e-15)
    assert (m.Q[0, 0], m.R[0, 0], m.x0[0], m.m0[0], m.P0[0, 0]) == (1.0, 1.0, 0.1, 0.1, 0.1)
    n = UNGM.ning2011()
    np.testing.assert_allclose(n.f(x, 3), 0.5 * x + 25 * x / (1 + x**2) + 8 * np.cos(1.2 * 3), rtol=1e-14)
    assert n.m0[0] == 0.0 and n.P0[0, 0] == 1.0
    l2 = UNGM.li2012_model2()
    np.testing.assert_allclose(l2.f(x, 2), 0.5 * x + 18 * np.cos(1.2), rtol=1e-14)
    assert l2.Q[0, 0] == 10.0


def test_bot_measurement_geometry():
    m = BearingsOnly.zhang2016()
    np.testing.assert_array_equal(m.sensors, [[-10, -10], [10, -10]])
    np.testing.assert_allclose(m.R, 0.05**2 * np.eye(2))
    # target at (0, 0): bearings from (-10,-10) and (10,-10) are 45 and 135 degrees
    np.testing.assert_allclose(m.h(np.array([0.0, 0.0, 1.0, 1.0])), [np.pi / 4, 3 * np.pi / 4], rtol=1e-15)
    dt, q = 0.1, 0.1
    np.testing.assert_allclose(m.Q[0, 0], q**2 * dt**3 / 3)
    np.testing.assert_allclose(m.Q[0, 2], q**2 * dt**2 / 2)
    np.testing.assert_allclose(m.P0, np.diag([25.0, 25.0, 1.0, 1.0]))


# ------------------------------------------------------------------ discretisation ---------------
@pytest.mark.parametrize("seed, dt", [(0, 0.1), (1, 0.7), (2, 2.0)])
def test_van_loan_vs_quadrature_and_expm(seed, dt):
    rng = np.random.default_rng(seed)
    n = 4
    F_c = rng.normal(size=(n, n)) * 0.8
    L = rng.normal(size=(n, 2))
    Qc = random_spd(rng, 2)
    F, Q = van_loan_discretize(F_c, L, Qc, dt)
    np.testing.assert_allclose(F, expm(F_c * dt), rtol=1e-12, atol=1e-13)
    G = L @ Qc @ L.T
    Q_quad, _ = quad_vec(lambda s: expm(F_c * s) @ G @ expm(F_c * s).T, 0.0, dt, epsabs=0.0, epsrel=1e-11, norm="max")
    np.testing.assert_allclose(Q, Q_quad, rtol=1e-10, atol=0)  # measured <= 7e-14 relative
    np.testing.assert_array_equal(Q, Q.T)


def test_cwpa_matches_closed_form():
    dt, qc = 0.1, 0.1
    m = CWPA(dt=dt, qc=qc)
    # per axis (position, velocity, acceleration); the state is (x, y, vx, vy, ax, ay)
    F1 = np.array([[1, dt, dt**2 / 2], [0, 1, dt], [0, 0, 1]])
    Q1 = qc * np.array([[dt**5 / 20, dt**4 / 8, dt**3 / 6],
                        [dt**4 / 8, dt**3 / 3, dt**2 / 2],
                        [dt**3 / 6, dt**2 / 2, dt]])
    F, Q = np.kron(F1, np.eye(2)), np.kron(Q1, np.eye(2))
    np.testing.assert_allclose(m.F, F, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(m.Q, Q, rtol=1e-9, atol=1e-18)
    np.testing.assert_array_equal(m.H, np.hstack([np.eye(2), np.zeros((2, 4))]))
    np.testing.assert_allclose(m.R, 0.014 * np.eye(2))
    np.testing.assert_allclose(m.P0, np.diag([0.1, 0.1, 0.1, 0.1, 0.5, 0.5]))


def test_cwpa_mixture_noise_covariance():
    m = CWPA.zhang2016("mixture")
    R1 = np.array([[0.6, 0.25], [0.25, 0.7]])
    R2 = np.array([[0.01, 0.003], [0.003, 0.01]])  # printed [[.01, .005], [.001, .01]], symmetrised
    assert isinstance(m.measurement_noise, GaussianMixtureNoise)
    np.testing.assert_allclose(m.R, 0.01 * R1 + 0.99 * R2, rtol=1e-14)
    np.testing.assert_allclose(m.measurement_noise.weights, [0.01, 0.99])
    v = m.measurement_noise.sample(np.random.default_rng(0), 200000)
    np.testing.assert_allclose(np.cov(v.T), m.R, rtol=0.05)
    with pytest.raises(ValueError, match="noise must be"):
        CWPA.zhang2016("laplace")


# ------------------------------------------------------------------ simulation -------------------
@pytest.mark.parametrize("model", [UNGM.zhang2016(), BearingsOnly.zhang2016(), CWPA.zhang2016(),
                                   CWPA.zhang2016("mixture")], ids=["UNGM", "BOT", "CWPA", "CWPA-mix"])
def test_simulate_shapes_and_initial_state(model):
    sim = model.simulate(7, runs=3, rng=np.random.default_rng(0))
    assert isinstance(sim, Simulation)
    assert sim.x.shape == (3, 8, model.dim_x) and sim.y.shape == (3, 7, model.dim_y)
    assert sim.runs == 3 and sim.T == 7
    np.testing.assert_array_equal(sim.x[:, 0], np.broadcast_to(model.x0, (3, model.dim_x)))
    one = sim.run(1)
    assert one.x.shape == (1, 8, model.dim_x)
    np.testing.assert_array_equal(one.y[0], sim.y[1])


def test_simulate_prior_initial_state():
    m = UNGM(truth_init="prior", x0=0.1, m0=3.0, P0=0.25)
    sim = m.simulate(1, runs=20000, rng=np.random.default_rng(1))
    x0 = sim.x[:, 0, 0]
    assert abs(x0.mean() - 3.0) < 5 * 0.5 / np.sqrt(20000)
    assert abs(x0.var() - 0.25) < 0.02


def test_simulated_noise_has_model_covariances():
    """x_k - f(x_{k-1}) ~ N(0, Q) and y_k - h(x_k) ~ N(0, R), with y[:, k-1] belonging to x[:, k]."""
    model = CWPA.zhang2016()
    sim = model.simulate(4, runs=5000, rng=np.random.default_rng(2))
    w = np.concatenate([sim.x[:, k] - model.f(sim.x[:, k - 1], k) for k in range(1, 5)])
    v = (sim.y - model.h(sim.x[:, 1:])).reshape(-1, 2)
    for e, C in [(w, model.Q), (v, model.R)]:
        Li = np.linalg.inv(np.linalg.cholesky(C))
        white = np.cov((e @ Li.T).T)
        np.testing.assert_allclose(white, np.eye(C.shape[0]), atol=0.06)
        assert np.all(np.abs(e.mean(axis=0)) < 5 * np.sqrt(np.diag(C) / len(e)))


# ------------------------------------------------------------------ angles -----------------------
def test_wrap_angle_fixed_points():
    a = np.array([0.0, np.pi, -np.pi, 3 * np.pi, -3 * np.pi, 2 * np.pi, np.pi / 2 + 4 * np.pi, -0.1])
    np.testing.assert_allclose(wrap_angle(a), [0.0, np.pi, np.pi, np.pi, np.pi, 0.0, np.pi / 2, -0.1],
                               atol=1e-12)


@settings(max_examples=300, derandomize=True, database=None, deadline=None)
@given(st.floats(-1e4, 1e4, allow_nan=False))
def test_wrap_angle_range_and_equivalence(a):
    w = wrap_angle(a)
    assert -np.pi < w <= np.pi
    turns = (a - w) / (2 * np.pi)
    assert abs(turns - round(turns)) < 1e-9


def test_wrap_angle_fast_path_is_bit_identical_to_the_formula():
    """The array fast path (no mod when pi - a lies in [0, 2 pi)) gives the formula's bits exactly."""
    rng = np.random.default_rng(7)
    edge = np.array([0.0, -0.0, np.pi, -np.pi, np.nextafter(np.pi, 0), np.nextafter(-np.pi, 0),
                     np.nextafter(-np.pi, -4), 1e-300, -1e-17, 2 * np.pi, 7.0])
    for a in (rng.uniform(-np.pi, np.pi, 1000), rng.normal(0, 1e-3, (4, 3, 50)), rng.uniform(-50, 50, 999),
              edge, np.r_[rng.normal(0, 0.1, 20), np.nan], np.r_[0.1, np.inf], np.zeros(0),
              rng.normal(0, 1e-2, (5, 7, 3))[..., 2]):
        with np.errstate(invalid="ignore"):          # the inf case: NaN, as the formula gives
            ref = np.pi - np.mod(np.pi - a, 2.0 * np.pi)
            got = wrap_angle(a)
        assert got.shape == ref.shape and got.dtype == ref.dtype
        assert np.array_equal(got.view(np.int64), ref.view(np.int64))    # bitwise, NaN and -0.0 included
    assert wrap_angle(0.1) == np.pi - np.mod(np.pi - 0.1, 2.0 * np.pi)
    # in place on a strided view (as the radar residual uses it)
    d = np.random.default_rng(8).uniform(-7, 7, (5, 4, 3))
    ref = np.pi - np.mod(np.pi - d[..., 2], 2.0 * np.pi)
    assert wrap_angle(d[..., 2], out=d[..., 2]) is not None and np.array_equal(d[..., 2], ref)


def test_bot_residual_wraps():
    m = BearingsOnly.zhang2016()
    r = m.residual_y(np.array([np.pi - 0.01, -np.pi + 0.02]), np.array([-np.pi + 0.01, np.pi - 0.03]))
    np.testing.assert_allclose(r, [-0.02, 0.05], atol=1e-12)


# ------------------------------------------------------------------ densities --------------------
@pytest.mark.parametrize("model", [UNGM.zhang2016(), BearingsOnly.zhang2016(), CWPA.zhang2016(),
                                   random_linear_model(5, 3, 3)], ids=["UNGM", "BOT", "CWPA", "linear"])
def test_log_likelihood_vs_scipy(model):
    rng = np.random.default_rng(3)
    runs, N = 3, 6
    X = rng.normal(size=(runs, N, model.dim_x)) + np.r_[1.0, 20.0, 0, 0, 0, 0][: model.dim_x]
    y = model.h(X[:, 0]) + rng.normal(size=(runs, model.dim_y)) * 0.3
    ll = model.log_likelihood(y, X)
    assert ll.shape == (runs, N)
    for r in range(runs):
        for i in range(N):
            innov = model.residual_y(y[r], model.h(X[r, i]))
            ref = multivariate_normal(np.zeros(model.dim_y), model.R).logpdf(innov)
            np.testing.assert_allclose(ll[r, i], ref, rtol=1e-12)


def test_bot_log_likelihood_uses_wrapped_residual():
    m = BearingsOnly.zhang2016()
    x = np.array([[[0.0, 30.0, 0.0, 0.0]]])
    y = m.h(x[:, 0])
    np.testing.assert_allclose(m.log_likelihood(y + 2 * np.pi, x), m.log_likelihood(y, x), rtol=1e-12)


def test_gaussian_noise_logpdf_sample_and_mean():
    C = np.array([[2.0, 0.3], [0.3, 0.5]])
    g = GaussianNoise(C, mean=[1.0, -2.0])
    v = np.array([[0.0, 0.0], [1.0, -2.0], [3.0, 1.0]])
    np.testing.assert_allclose(g.logpdf(v), multivariate_normal([1.0, -2.0], C).logpdf(v), rtol=1e-12)
    s = g.sample(np.random.default_rng(0), (400, 50))
    assert s.shape == (400, 50, 2)
    s = s.reshape(-1, 2)
    np.testing.assert_allclose(s.mean(axis=0), [1.0, -2.0], atol=0.03)
    np.testing.assert_allclose(np.cov(s.T), C, atol=0.04)
    g1 = GaussianNoise(4.0)  # scalar fast path
    np.testing.assert_allclose(g1.logpdf(np.array([[1.0], [-3.0]])),
                               multivariate_normal(0.0, 4.0).logpdf([1.0, -3.0]), rtol=1e-12)


def test_gaussian_mixture_logpdf_vs_direct_sum():
    w = np.array([0.2, 0.5, 0.3])
    covs = [np.array([[1.0, 0.2], [0.2, 0.5]]), np.eye(2) * 0.1, np.array([[3.0, -1.0], [-1.0, 2.0]])]
    means = [np.zeros(2), np.array([1.0, 1.0]), np.array([-2.0, 0.5])]
    mix = GaussianMixtureNoise(w, covs, means)
    v = np.random.default_rng(4).normal(size=(5, 7, 2)) * 2
    direct = np.log(sum(wj * multivariate_normal(m, C).pdf(v) for wj, m, C in zip(w, means, covs)))
    np.testing.assert_allclose(mix.logpdf(v), direct, rtol=1e-12)
    # far in the tails the log-sum-exp stays finite where the direct sum underflows
    assert np.isfinite(mix.logpdf(np.array([[200.0, -300.0]]))).all()
    # moments by the law of total variance
    mean = sum(wj * m for wj, m in zip(w, means))
    cov = sum(wj * (C + np.outer(m, m)) for wj, m, C in zip(w, means, covs)) - np.outer(mean, mean)
    np.testing.assert_allclose(mix.mean, mean, rtol=1e-14)
    np.testing.assert_allclose(mix.cov, cov, rtol=1e-14)


def test_gaussian_mixture_zero_weight_component_is_ignored():
    mix = GaussianMixtureNoise([1.0, 0.0], [np.eye(1), np.eye(1) * 9])
    np.testing.assert_allclose(mix.logpdf(np.array([[0.7]])), multivariate_normal(0, 1).logpdf(0.7), rtol=1e-13)


@pytest.mark.parametrize("shape", [(100, 1000), (8, 1), (1, 1), (4097,), (4098,), (4099,), (8193,), (3, 5000),
                                   (7, 2, 3000), (5,), ()])
@pytest.mark.parametrize("dim", [2, 4, 6])
def test_noise_product_in_row_blocks_is_one_gemm_bit_for_bit(shape, dim):
    """Gaussian draws and densities multiply by the Cholesky factor in row blocks (no BLAS
    thread waits); the bits are those of one 2-D product over all rows, including block ends
    that would leave a one-row block (a lone row takes BLAS's matrix-vector kernel)."""
    from pfrepro.noise import _rows_times_transpose

    rng = np.random.default_rng(dim)
    L = np.linalg.cholesky(random_spd(rng, dim))
    a = rng.standard_normal(shape + (dim,))
    one = (a.reshape(-1, dim) @ L.T).reshape(a.shape)
    assert np.array_equal(_rows_times_transpose(a, L), one)
    noise = GaussianNoise(L @ L.T)
    z = np.random.default_rng(9).standard_normal(shape + (dim,))
    drawn = noise.sample(np.random.default_rng(9), shape)
    assert np.array_equal(drawn, (z.reshape(-1, dim) @ noise._chol.T).reshape(z.shape))
    w = (a.reshape(-1, dim) @ noise._prec_chol.T).reshape(a.shape)
    assert np.array_equal(noise.logpdf(a), -0.5 * (w * w).sum(axis=-1) + noise._log_norm)
