"""Tests of the posterior Cramér–Rao bound (pfrepro.bounds)."""
import numpy as np
import pytest

from pfrepro.bounds import pcrb_linear_dynamics
from pfrepro.filters import KalmanFilter, UnscentedKalmanFilter
from pfrepro.models import CWPA, BearingsOnly, LinearGaussianModel
from pfrepro.montecarlo import truth_rng


def _linear_model(seed=3, d=4, m=2):
    rng = np.random.default_rng(seed)
    F = np.eye(d) + 0.1 * rng.standard_normal((d, d))
    H = rng.standard_normal((m, d))
    A = rng.standard_normal((d, d))
    B = rng.standard_normal((m, m))
    return LinearGaussianModel(F, H, Q=A @ A.T / d + 0.1 * np.eye(d), R=B @ B.T / m + 0.2 * np.eye(m),
                               x0=rng.standard_normal(d), m0=np.zeros(d), P0=2.0 * np.eye(d))


@pytest.mark.parametrize("model", [_linear_model(), CWPA.zhang2016("gaussian")], ids=["random", "cwpa"])
def test_linear_gaussian_pcrb_is_kalman_covariance(model):
    """With linear h, H_k is constant: the PCRB (J_0 = P0^-1) is the KF posterior covariance."""
    T = 30
    bound = pcrb_linear_dynamics(model, T, runs=3, rng=truth_rng(1), init="prior", return_cov=True)
    y = model.simulate(T, 1, truth_rng(2)).y
    P = KalmanFilter(model).filter(y).P[0]
    np.testing.assert_allclose(bound, P, rtol=1e-9, atol=1e-12)
    diag = pcrb_linear_dynamics(model, T, runs=3, rng=truth_rng(1), init="prior")
    np.testing.assert_allclose(diag, np.diagonal(P, axis1=1, axis2=2), rtol=1e-9, atol=1e-12)


def test_fixed_start_is_kalman_with_known_x0():
    """init="fixed" (J_0^-1 = 0) is the KF started with P0 -> 0."""
    model = _linear_model(seed=5)
    T = 20
    bound = pcrb_linear_dynamics(model, T, runs=2, rng=truth_rng(1), init="fixed")
    P = KalmanFilter(model, m0=model.x0, P0=1e-12 * np.eye(model.dim_x)).filter(
        model.simulate(T, 1, truth_rng(2)).y).P[0]
    np.testing.assert_allclose(bound, np.diagonal(P, axis1=1, axis2=2), rtol=1e-6, atol=1e-10)


def test_bot_bound_is_below_a_clairvoyant_ukf_and_deterministic():
    """BOT: a UKF that knows x0 cannot beat the x0-known bound (beyond Monte Carlo error),
    and the bound is reproducible from the generator."""
    model = BearingsOnly.zhang2016()
    T, runs = 60, 400
    b1 = pcrb_linear_dynamics(model, T, runs, truth_rng(7), init="fixed")
    b2 = pcrb_linear_dynamics(model, T, runs, truth_rng(7), init="fixed")
    np.testing.assert_array_equal(b1, b2)
    assert b1.shape == (T, 4) and np.all(b1 > 0)
    sim = model.simulate(T, runs, truth_rng(8))
    x = UnscentedKalmanFilter(model, m0=model.x0, P0=1e-9 * np.eye(4)).filter(sim.y).x
    mse_t = np.mean((x - sim.x[:, 1:]) ** 2, axis=0)
    assert np.all(mse_t.mean(axis=0) > 0.85 * b1.mean(axis=0))
    # the prior start carries less information early on than a known x0
    bp = pcrb_linear_dynamics(model, T, runs, truth_rng(7), init="prior")
    assert np.all(bp[0] > b1[0])


def test_input_checks():
    model = BearingsOnly.zhang2016()
    with pytest.raises(ValueError):
        pcrb_linear_dynamics(model, 5, 10, truth_rng(0), init="nope")
    with pytest.raises(TypeError):
        pcrb_linear_dynamics(CWPA.zhang2016("mixture"), 5, 10, truth_rng(0))


def test_prior_info_bound_uses_p0_on_the_datas_truths():
    """init="prior_info": J_0 = P0^-1 with the truths the data have (fixed x0). With linear h it is the
    KF covariance (as "prior", the truths do not enter); on BOT it lies above the x0-known bound at
    every step (prior information is less than knowing x0) and, with a prior that knows almost
    everything (P0 -> 0), it tends to the x0-known bound on the same truths."""
    lin = _linear_model()
    a = pcrb_linear_dynamics(lin, 10, 3, truth_rng(1), init="prior_info")
    b = pcrb_linear_dynamics(lin, 10, 3, truth_rng(1), init="prior")
    np.testing.assert_allclose(a, b, rtol=1e-9)
    m = BearingsOnly.zhang2016()
    info = pcrb_linear_dynamics(m, 40, 50, truth_rng(4), init="prior_info")
    known = pcrb_linear_dynamics(m, 40, 50, truth_rng(4), init="fixed")
    assert np.all(info > known)
    sharp = BearingsOnly(P0=(1e-10, 1e-10, 1e-10, 1e-10))
    np.testing.assert_allclose(pcrb_linear_dynamics(sharp, 40, 50, truth_rng(4), init="prior_info"), known,
                               rtol=1e-3, atol=1e-8)
    with pytest.raises(ValueError):
        pcrb_linear_dynamics(m, 5, 5, truth_rng(4), init="x0")
