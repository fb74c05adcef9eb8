"""KF and EKF against filterpy on the same data, incl. one batched call vs per-run filterpy loops."""
from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import ExtendedKalmanFilter as FpEKF
from filterpy.kalman import KalmanFilter as FpKF

from conftest import random_linear_model
from pfrepro.filters import ExtendedKalmanFilter, KalmanFilter, kalman_update
from pfrepro.models import CWPA, UNGM, BearingsOnly

RTOL, ATOL = 1e-9, 1e-10


def filterpy_kf(model, y):
    """filterpy's KalmanFilter on one run ``y`` (T, dim_y): posterior means and covariances."""
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


class _ModelEKF(FpEKF):
    """filterpy's EKF with the model's nonlinear f in predict_x (F is set to the Jacobian by the caller)."""

    def __init__(self, model):
        super().__init__(model.dim_x, model.dim_y)
        self.model, self.k = model, 0
        self.x, self.P = model.m0.copy(), model.P0.copy()
        self.Q, self.R = model.Q, model.R

    def predict_x(self, u=0):
        self.x = self.model.f(self.x, self.k)


def filterpy_ekf(model, y):
    ekf = _ModelEKF(model)
    xs, Ps = [], []
    for k, yk in enumerate(y, start=1):
        ekf.k = k
        ekf.F = model.jacobian_f(ekf.x, k)  # Jacobian at the previous posterior mean
        ekf.predict()
        ekf.update(yk, HJacobian=model.jacobian_h, Hx=model.h, residual=model.residual_y)
        xs.append(ekf.x.copy())
        Ps.append(ekf.P.copy())
    return np.array(xs), np.array(Ps)


def _compare(ours, theirs_per_run):
    xs = np.array([t[0] for t in theirs_per_run])
    Ps = np.array([t[1] for t in theirs_per_run])
    assert ours.x.shape == xs.shape and ours.P.shape == Ps.shape
    np.testing.assert_allclose(ours.x, xs, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(ours.P, Ps, rtol=RTOL, atol=ATOL)
    return max(np.max(np.abs(ours.x - xs)), np.max(np.abs(ours.P - Ps)))


@pytest.mark.parametrize("seed, nx, ny", [(1, 3, 2), (2, 4, 1), (3, 2, 3)])
def test_kf_matches_filterpy_random_linear_batched(seed, nx, ny):
    model = random_linear_model(seed, nx, ny)
    sim = model.simulate(40, runs=4, rng=np.random.default_rng(seed))
    ours = KalmanFilter(model).filter(sim.y)  # one batched call
    _compare(ours, [filterpy_kf(model, sim.y[r]) for r in range(sim.runs)])


def test_kf_matches_filterpy_cwpa():
    model = CWPA.zhang2016()
    sim = model.simulate(60, runs=3, rng=np.random.default_rng(7))
    ours = KalmanFilter(model).filter(sim.y)
    _compare(ours, [filterpy_kf(model, sim.y[r]) for r in range(sim.runs)])


@pytest.mark.parametrize("make_model, T", [
    (UNGM.zhang2016, 50),
    (BearingsOnly.zhang2016, 60),
    (CWPA.zhang2016, 40),
    (lambda: random_linear_model(4), 40),
], ids=["UNGM", "BOT", "CWPA", "random-linear"])
def test_ekf_matches_filterpy_batched(make_model, T):
    model = make_model()
    sim = model.simulate(T, runs=4, rng=np.random.default_rng(11))
    ours = ExtendedKalmanFilter(model).filter(sim.y)
    _compare(ours, [filterpy_ekf(model, sim.y[r]) for r in range(sim.runs)])


def test_ekf_equals_kf_on_linear_model(linear_model):
    sim = linear_model.simulate(30, runs=3, rng=np.random.default_rng(5))
    kf = KalmanFilter(linear_model).filter(sim.y)
    ekf = ExtendedKalmanFilter(linear_model).filter(sim.y)
    np.testing.assert_allclose(ekf.x, kf.x, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(ekf.P, kf.P, rtol=1e-12, atol=1e-12)


def test_batch_equals_single_runs(linear_model):
    sim = linear_model.simulate(25, runs=5, rng=np.random.default_rng(8))
    kf = KalmanFilter(linear_model)
    batched = kf.filter(sim.y)
    for r in range(sim.runs):
        single = kf.filter(sim.y[r])
        np.testing.assert_allclose(batched.x[r], single.x[0], rtol=1e-13, atol=1e-13)


def test_bot_ekf_uses_wrapped_residual():
    """A measurement shifted by 2 pi is the same bearing: the EKF must not notice."""
    model = BearingsOnly.zhang2016()
    sim = model.simulate(20, runs=2, rng=np.random.default_rng(3))
    ekf = ExtendedKalmanFilter(model)
    a = ekf.filter(sim.y)
    b = ekf.filter(sim.y + 2 * np.pi * np.array([1.0, -1.0]))
    np.testing.assert_allclose(a.x, b.x, rtol=1e-9, atol=1e-9)


def test_kf_covariances_symmetric_pd(linear_model):
    sim = linear_model.simulate(30, runs=2, rng=np.random.default_rng(9))
    P = KalmanFilter(linear_model).filter(sim.y).P
    np.testing.assert_array_equal(P, np.swapaxes(P, -1, -2))
    assert np.all(np.linalg.eigvalsh(P) > 0)


def test_kalman_update_scalar_by_hand():
    # prior N(1, 4), y = 3 with H = 1, R = 1: K = 0.8, x = 2.6, P = 0.8
    x, P, S = kalman_update(np.array([[1.0]]), np.array([[[4.0]]]), np.array([[2.0]]),
                            np.array([[1.0]]), np.array([[1.0]]))
    np.testing.assert_allclose(x, [[2.6]], rtol=1e-14)
    np.testing.assert_allclose(P, [[[0.8]]], rtol=1e-14)
    np.testing.assert_allclose(S, [[[5.0]]], rtol=1e-14)


def test_kf_rejects_nonlinear_model():
    with pytest.raises(TypeError, match="linear dynamics"):
        KalmanFilter(UNGM.zhang2016())


def test_ekf_predict_evaluates_the_jacobian_at_step_k():
    """A transition whose Jacobian depends on k (f = k x): P- = k^2 P + Q, by hand (every shipped
    model's Jacobian is time-invariant, so the step passed to jacobian_f was unpinned)."""
    from pfrepro.filters import ExtendedKalmanFilter
    from pfrepro.models import StateSpaceModel

    class Scaled(StateSpaceModel):
        def __init__(self):
            super().__init__(dim_x=1, dim_y=1, Q=0.5, measurement_noise=1.0, x0=[1.0], m0=[1.0], P0=[[2.0]])

        def f(self, x, k):
            return k * x

        def jacobian_f(self, x, k):
            return np.broadcast_to(np.array([[float(k)]]), x.shape[:-1] + (1, 1)).copy()

        def h(self, x):
            return x

        def jacobian_h(self, x):
            return np.ones(x.shape[:-1] + (1, 1))

    ekf = ExtendedKalmanFilter(Scaled())
    x, P = ekf.predict(np.array([[1.5]]), np.array([[[2.0]]]), 3)
    np.testing.assert_allclose(x, [[4.5]])
    np.testing.assert_allclose(P, [[[9 * 2.0 + 0.5]]])
