"""Singular and zero process noise (issue 8): discrete white-noise acceleration models
Q = G G^T q of rank 1, and Q = 0, against references that know the answer."""
from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter as FpKF

from pfrepro.filters import (BootstrapParticleFilter, ExtendedKalmanFilter, GaussianParticleFlowFilter,
                             GridFilter, KalmanFilter, UnscentedKalmanFilter)
from pfrepro.filters.sigma_points import safe_cholesky
from pfrepro.models import UNGM, LinearGaussianModel, ModelContractError
from pfrepro.montecarlo import filter_streams, truth_streams


def cv_model(q=0.5, dt=1.0, **kw):
    """Constant velocity, 1 axis, discrete white-noise acceleration: Q = G G^T q, rank 1."""
    F = np.array([[1.0, dt], [0.0, 1.0]])
    G = np.array([[dt**2 / 2], [dt]])
    return LinearGaussianModel(F, [[1.0, 0.0]], G @ G.T * q, [[1.0]], [0.0, 1.0],
                               P0=np.diag([4.0, 1.0]), **kw)


def ca_model(q=0.1, dt=0.5):
    """Constant acceleration, 1 axis, discrete white-noise jerk: Q = G G^T q, rank 1 of 3."""
    F = np.array([[1.0, dt, dt**2 / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    G = np.array([[dt**2 / 2], [dt], [1.0]])
    H = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    return LinearGaussianModel(F, H, G @ G.T * q, np.diag([1.0, 0.25]), [0.0, 1.0, 0.1],
                               P0=np.diag([1.0, 1.0, 0.5]))


def filterpy_kf(model, y):
    kf = FpKF(dim_x=model.dim_x, dim_z=model.dim_y)
    kf.x, kf.P = model.m0.copy(), model.P0.copy()
    kf.F, kf.H, kf.Q, kf.R = model.F, model.H, model.Q, model.R
    xs, Ps = [], []
    for yk in y:
        kf.predict()
        kf.update(yk)
        xs.append(np.ravel(kf.x).copy())
        Ps.append(kf.P.copy())
    return np.array(xs), np.array(Ps)


@pytest.mark.parametrize("make", [cv_model, ca_model, lambda: cv_model(q=0.0)], ids=["CV", "CA", "CV Q=0"])
def test_kf_with_singular_q_matches_filterpy(make):
    model = make()
    assert np.linalg.matrix_rank(model.Q) < model.dim_x          # the point of the test
    sim = model.simulate(40, 3, truth_streams(3, 3))
    ours = KalmanFilter(model).filter(sim.y)
    for r in range(sim.runs):
        xs, Ps = filterpy_kf(model, sim.y[r])
        scale = np.max(np.abs(xs))
        np.testing.assert_allclose(ours.x[r], xs, rtol=1e-12, atol=1e-12 * scale)
        np.testing.assert_allclose(ours.P[r], Ps, rtol=1e-12, atol=1e-12 * np.max(np.abs(Ps)))
        # P stays symmetric positive definite although Q is singular
        assert np.all(np.linalg.eigvalsh(ours.P[r]) > 0)


@pytest.mark.parametrize("make", [cv_model, ca_model, lambda: cv_model(q=0.0)], ids=["CV", "CA", "CV Q=0"])
def test_ekf_and_ukf_equal_kf_on_singular_q_linear_model(make):
    """EKF and UKF are exact on a linear model: they must equal the KF with singular Q too."""
    model = make()
    sim = model.simulate(30, 2, truth_streams(4, 2))
    kf = KalmanFilter(model).filter(sim.y)
    for filt in (ExtendedKalmanFilter(model), UnscentedKalmanFilter(model)):
        res = filt.filter(sim.y)
        np.testing.assert_allclose(res.x, kf.x, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(res.P, kf.P, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(res.diagnostics["log_likelihood"], kf.diagnostics["log_likelihood"],
                                   rtol=1e-9, atol=1e-9)


def test_zero_q_simulates_f_exactly():
    """Q = 0: the truth is x_k = f(x_{k-1}, k) bit for bit, and no process noise is drawn."""
    model = cv_model(q=0.0)
    sim = model.simulate(25, 4, np.random.default_rng(0))
    for k in range(1, 26):
        assert np.array_equal(sim.x[:, k], model.f(sim.x[:, k - 1], k))
    # nonlinear f as well, and the measurements are still noisy
    ung = UNGM(Q=0.0)
    s2 = ung.simulate(30, 2, np.random.default_rng(1))
    for k in range(1, 31):
        assert np.array_equal(s2.x[:, k], ung.f(s2.x[:, k - 1], k))
    assert np.std(s2.y[..., 0] - ung.h(s2.x[:, 1:])[..., 0]) > 0.5
    # only the measurement noise is drawn: the same rng then gives the same y-noise as
    # a draw of T standard normals per run
    rng = np.random.default_rng(1)
    z = np.stack([rng.standard_normal((2, 1)) for _ in range(30)], axis=1)
    np.testing.assert_allclose(s2.y - ung.h(s2.x[:, 1:]), z, rtol=0, atol=1e-12)


def test_singular_q_draws_stay_in_its_range():
    model = cv_model(q=2.0)
    x = np.zeros((5000, 2))
    w = model.sample_transition(x, 1, np.random.default_rng(2))       # f(0) = 0: w only
    G = np.array([0.5, 1.0])
    resid = w - np.outer(w @ G / (G @ G), G)                          # component off span(G)
    assert np.max(np.abs(resid)) < 1e-12
    np.testing.assert_allclose(np.cov(w.T), model.Q, rtol=0.08, atol=0.02)


def test_pf_on_singular_q_converges_to_kf():
    model = cv_model(q=0.5)
    sim = model.simulate(30, 4, truth_streams(5, 4))
    kf = KalmanFilter(model).filter(sim.y)
    err = {}
    for N in (100, 20_000):
        pf = BootstrapParticleFilter(model, N).filter(sim.y, filter_streams(5, f"PF{N}", 4))
        # error of the PF mean in units of the KF posterior std
        z = (pf.x - kf.x) / np.sqrt(np.diagonal(kf.P, axis1=-2, axis2=-1))
        err[N] = np.sqrt(np.mean(z**2))
    assert err[20_000] < 0.05, err
    assert err[20_000] < err[100] / 4, err        # ~ 1/sqrt(N): sqrt(200) ~ 14


def test_gpff_on_singular_and_zero_q_linear_model():
    for q in (0.5, 0.0):
        model = cv_model(q=q)
        sim = model.simulate(30, 3, truth_streams(6, 3))
        kf = KalmanFilter(model).filter(sim.y)
        for integ in ("exact", "euler"):
            g = GaussianParticleFlowFilter(model, 2000, integrator=integ).filter(sim.y, filter_streams(6, "g", 3))
            assert g.diagnostics["n_diverged"] == 0
            z = (g.x - kf.x) / np.sqrt(np.diagonal(kf.P, axis1=-2, axis2=-1))
            assert np.sqrt(np.mean(z**2)) < 0.15, (q, integ)


def test_grid_filter_refuses_singular_q():
    with pytest.raises(ModelContractError, match="GridFilter needs .*transition density.*UNGM has a singular"):
        GridFilter(UNGM(Q=0.0))


def test_ukf_ekf_run_with_zero_q_on_nonlinear_model():
    model = UNGM(Q=0.0, P0=1.0)
    sim = model.simulate(40, 3, truth_streams(7, 3))
    for filt in (ExtendedKalmanFilter(model), UnscentedKalmanFilter(model)):
        res = filt.filter(sim.y)
        assert np.all(np.isfinite(res.x)) and np.all(res.P > 0)


def test_safe_cholesky_on_rank_deficient_and_zero_matrices():
    G = np.array([[1.0], [2.0], [0.5]])
    for A in (G @ G.T, np.zeros((3, 3)), np.diag([1.0, 0.0, 1e-300])):
        L = safe_cholesky(A[None].repeat(2, axis=0))
        np.testing.assert_allclose(L @ np.swapaxes(L, -1, -2), A[None].repeat(2, axis=0), atol=1e-5 * max(1, A.max()))
    with pytest.raises(np.linalg.LinAlgError, match="not positive semi-definite"):
        safe_cholesky(np.diag([1.0, -0.5]))
