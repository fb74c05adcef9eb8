"""UKF against filterpy's UnscentedKalmanFilter + MerweScaledSigmaPoints (same alpha, beta, kappa).

filterpy (2.0.0, as installed) ends ``predict`` with
``self.sigmas_f = self.points_fn.sigma_points(self.x, self.P)``: it *redraws* sigma
points from the predicted N(x-, P-) for the update. So plain filterpy is compared with our
``redraw=True``; for ``redraw=False`` the propagated points f(X_{k-1}) are put back into
``ukf.sigmas_f`` between predict and update.
"""
from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints
from filterpy.kalman import UnscentedKalmanFilter as FpUKF

from conftest import random_linear_model
from pfrepro.filters import KalmanFilter, ScaledSigmaPoints, UnscentedKalmanFilter
from pfrepro.filters.sigma_points import safe_cholesky, unscented_transform
from pfrepro.models import CWPA, UNGM, BearingsOnly

RTOL, ATOL = 1e-9, 1e-10
PARAMS = [(1.0, 2.0, 0.0), (0.5, 2.0, 1.0), (1e-1, 2.0, 3.0)]  # (alpha, beta, kappa)


def filterpy_ukf(model, y, alpha, beta, kappa, redraw):
    n = model.dim_x
    points = MerweScaledSigmaPoints(n, alpha=alpha, beta=beta, kappa=kappa)
    ukf = FpUKF(dim_x=n, dim_z=model.dim_y, dt=1.0, hx=model.h, fx=None, points=points,
                residual_z=model.residual_y)
    ukf.x, ukf.P = model.m0.copy(), model.P0.copy()
    ukf.Q, ukf.R = model.Q, model.R
    xs, Ps = [], []
    for k, yk in enumerate(y, start=1):
        x_prev, P_prev = ukf.x.copy(), ukf.P.copy()

        def fx(x, dt, k=k):
            return model.f(x, k)

        ukf.predict(fx=fx)
        if not redraw:  # reuse the propagated points f(X_{k-1}) instead of filterpy's redrawn ones
            ukf.sigmas_f = np.array([fx(s, 1.0) for s in points.sigma_points(x_prev, P_prev)])
        ukf.update(yk)
        xs.append(ukf.x.copy())
        Ps.append(ukf.P.copy())
    return np.array(xs), np.array(Ps)


MODELS = {
    # UNGM amplifies round-off (posterior variances reach 1e4 and a tiny alpha gives
    # weights like Wm_0 = -24): whole trajectories agree to 1e-10 for ~20 steps; the
    # one-step test below checks every step of a longer run.
    "UNGM": (UNGM.zhang2016, 20),
    "BOT": (BearingsOnly.zhang2016, 60),
    "CWPA": (CWPA.zhang2016, 40),
    "random-linear": (lambda: random_linear_model(21, 3, 2), 40),
}


@pytest.mark.parametrize("redraw", [True, False], ids=["redraw", "reuse"])
@pytest.mark.parametrize("alpha, beta, kappa", PARAMS)
@pytest.mark.parametrize("name", list(MODELS))
def test_ukf_matches_filterpy_batched(name, alpha, beta, kappa, redraw):
    make, T = MODELS[name]
    model = make()
    sim = model.simulate(T, runs=3, rng=np.random.default_rng(17))
    ours = UnscentedKalmanFilter(model, alpha=alpha, beta=beta, kappa=kappa, redraw=redraw).filter(sim.y)
    ref = [filterpy_ukf(model, sim.y[r], alpha, beta, kappa, redraw) for r in range(sim.runs)]
    xs, Ps = np.array([t[0] for t in ref]), np.array([t[1] for t in ref])
    np.testing.assert_allclose(ours.x, xs, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(ours.P, Ps, rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("redraw", [True, False], ids=["redraw", "reuse"])
@pytest.mark.parametrize("alpha, beta, kappa", PARAMS)
def test_ukf_one_step_matches_filterpy_ungm_long_run(alpha, beta, kappa, redraw):
    """Each predict+update from the same (x, P) agrees with filterpy at every step of T = 60."""
    model = UNGM.zhang2016()
    sim = model.simulate(60, runs=2, rng=np.random.default_rng(23))
    ukf = UnscentedKalmanFilter(model, alpha=alpha, beta=beta, kappa=kappa, redraw=redraw)
    ours = ukf.filter(sim.y)
    for r in range(sim.runs):
        for k in range(1, 61):
            x_prev = model.m0 if k == 1 else ours.x[r, k - 2]
            P_prev = model.P0 if k == 1 else ours.P[r, k - 2]
            sub = _OneStep(model, x_prev, P_prev, k)
            xs, Ps = filterpy_ukf(sub, sim.y[r, k - 1 : k], alpha, beta, kappa, redraw)
            np.testing.assert_allclose(ours.x[r, k - 1], xs[0], rtol=RTOL, atol=ATOL)
            np.testing.assert_allclose(ours.P[r, k - 1], Ps[0], rtol=RTOL, atol=ATOL)


class _OneStep:
    """``model`` seen from step k with prior N(x_prev, P_prev): filterpy_ukf then runs step k only."""

    def __init__(self, model, x_prev, P_prev, k):
        self._model, self._k = model, k
        self.dim_x, self.dim_y, self.Q, self.R = model.dim_x, model.dim_y, model.Q, model.R
        self.m0, self.P0 = np.asarray(x_prev, float), np.asarray(P_prev, float)
        self.h, self.residual_y = model.h, model.residual_y

    def f(self, x, k):
        return self._model.f(x, self._k + k - 1)


def test_redraw_flag_matters_on_ungm():
    """The two variants are different filters (so the comparisons above can tell them apart)."""
    model = UNGM.zhang2016()
    sim = model.simulate(30, runs=2, rng=np.random.default_rng(1))
    a = UnscentedKalmanFilter(model, redraw=True).filter(sim.y)
    b = UnscentedKalmanFilter(model, redraw=False).filter(sim.y)
    assert np.max(np.abs(a.x - b.x)) > 1e-3


@pytest.mark.parametrize("alpha, beta, kappa", PARAMS)
def test_ukf_redraw_equals_kf_on_linear_model(alpha, beta, kappa):
    """With fresh points the UT is exact for linear f and h: the UKF is the KF."""
    model = random_linear_model(22, 3, 2)
    sim = model.simulate(30, runs=3, rng=np.random.default_rng(2))
    kf = KalmanFilter(model).filter(sim.y)
    ukf = UnscentedKalmanFilter(model, alpha=alpha, beta=beta, kappa=kappa, redraw=True).filter(sim.y)
    np.testing.assert_allclose(ukf.x, kf.x, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(ukf.P, kf.P, rtol=1e-8, atol=1e-9)
    # reusing the propagated points leaves Q out of Pxy and Pyy: not the KF
    reuse = UnscentedKalmanFilter(model, alpha=alpha, beta=beta, kappa=kappa, redraw=False).filter(sim.y)
    assert np.max(np.abs(reuse.x - kf.x)) > 1e-3


@pytest.mark.parametrize("alpha, beta, kappa", PARAMS + [(1.0, 0.0, 2.0)])
@pytest.mark.parametrize("n", [1, 2, 5])
def test_sigma_points_and_weights_match_filterpy(n, alpha, beta, kappa):
    rng = np.random.default_rng(n)
    A = rng.standard_normal((n, n))
    P = A @ A.T + 0.1 * np.eye(n)
    x = rng.standard_normal(n)
    ours = ScaledSigmaPoints(n, alpha, beta, kappa)
    fp = MerweScaledSigmaPoints(n, alpha=alpha, beta=beta, kappa=kappa)
    np.testing.assert_allclose(ours.Wm, fp.Wm, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(ours.Wc, fp.Wc, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(ours.sigma_points(x, P), fp.sigma_points(x, P), rtol=1e-12, atol=1e-12)
    # the unscented transform of the identity recovers the moments
    m, C, _ = unscented_transform(ours.sigma_points(x, P), ours.Wm, ours.Wc)
    np.testing.assert_allclose(m, x, atol=1e-10)
    np.testing.assert_allclose(C, P, rtol=1e-9, atol=1e-9)


def test_sigma_points_batched_over_runs():
    rng = np.random.default_rng(0)
    pts = ScaledSigmaPoints(3, 0.5, 2.0, 0.0)
    xs = rng.standard_normal((4, 3))
    Ps = np.array([np.eye(3) * (i + 1) + 0.1 for i in range(4)])
    batched = pts.sigma_points(xs, Ps)
    assert batched.shape == (4, 7, 3)
    for i in range(4):
        np.testing.assert_allclose(batched[i], pts.sigma_points(xs[i], Ps[i]), rtol=1e-15)


def test_sigma_point_parameter_validation():
    with pytest.raises(ValueError, match="n must be"):
        ScaledSigmaPoints(0, 1.0, 2.0, 0.0)
    with pytest.raises(ValueError, match="lambda"):
        ScaledSigmaPoints(2, 1.0, 2.0, -2.0)


def test_safe_cholesky_jitters_semidefinite_and_rejects_indefinite():
    L = safe_cholesky(np.array([[1.0, 1.0], [1.0, 1.0]]))  # PSD, singular: jitter rescues it
    np.testing.assert_allclose(L @ L.T, [[1.0, 1.0], [1.0, 1.0]], atol=1e-5)
    with pytest.raises(np.linalg.LinAlgError, match="P is not positive semi-definite"):
        safe_cholesky(np.array([[1.0, 0.0], [0.0, -1.0]]), name="P")


def test_safe_cholesky_exact_factors_per_matrix():
    """The documented ladder, exactly: a positive-definite matrix keeps its plain Cholesky
    factor even when another matrix of the batch fails; a singular PSD one gets the factor of
    A + 1e-12 scale I (the first jitter that works); a zero matrix gets 0; non-finite entries
    raise naming the matrix, or give NaN in their own slot with on_error="nan"."""
    pd_ = np.array([[4.0, 1.0], [1.0, 3.0]])
    sing = np.array([[4.0, 4.0], [4.0, 4.0]])                    # rank 1, scale 4
    L = safe_cholesky(np.stack([pd_, sing, np.zeros((2, 2))]))
    np.testing.assert_array_equal(L[0], np.linalg.cholesky(pd_))
    np.testing.assert_array_equal(L[1], np.linalg.cholesky(sing + 1e-12 * 4.0 * np.eye(2)))
    np.testing.assert_array_equal(L[2], np.zeros((2, 2)))
    # a matrix the first jitters cannot rescue: smallest eigenvalue -1e-9, scale ~0.5, needs 1e-8
    V = np.array([[1.0, 1.0], [1.0, -1.0]]) / np.sqrt(2.0)
    A = V @ np.diag([1.0, -1e-9]) @ V.T
    s = np.max(np.abs(np.diag(A)))
    np.testing.assert_array_equal(safe_cholesky(A[None])[0], np.linalg.cholesky(A + 1e-8 * s * np.eye(2)))
    bad = np.array([[1.0, np.inf], [np.inf, 1.0]])
    with pytest.raises(np.linalg.LinAlgError, match="P contains NaN or infinite entries"):
        safe_cholesky(np.stack([pd_, bad]), name="P")
    out = safe_cholesky(np.stack([pd_, bad]), on_error="nan")
    np.testing.assert_array_equal(out[0], np.linalg.cholesky(pd_))
    assert np.all(np.isnan(out[1]))


def test_ukf_defaults_and_m0_P0_overrides():
    """Documented defaults alpha, beta, kappa = 1, 2, 0 (Wm_0 = 0, Wc_0 = 2 for alpha = 1,
    beta = 2); m0/P0 overrides are the filter's initial distribution."""
    from pfrepro.models import UNGM

    m = UNGM.zhang2016()
    u = UnscentedKalmanFilter(m)
    pts = u.points
    assert (pts.alpha, pts.beta, pts.kappa) == (1.0, 2.0, 0.0)
    np.testing.assert_allclose([pts.Wm[0], pts.Wc[0]], [0.0, 2.0])
    y = m.simulate(4, 1, np.random.default_rng(0)).y
    over = UnscentedKalmanFilter(m, m0=[3.0], P0=[[0.25]])
    np.testing.assert_array_equal(over.m0, [3.0])
    np.testing.assert_array_equal(over.P0, [[0.25]])
    # the first prediction starts from N(3, 0.25): the same as a model whose prior is that
    ref = UnscentedKalmanFilter(UNGM.zhang2016(), m0=[3.0], P0=[[0.25]]).filter(y)
    np.testing.assert_array_equal(over.filter(y).x, ref.x)
    assert not np.array_equal(u.filter(y).x, ref.x)
