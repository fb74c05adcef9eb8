"""Bootstrap PF: convergence to the Kalman filter on linear-Gaussian models, diagnostics, weights."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from conftest import random_linear_model
from pfrepro.filters import RESAMPLING_SCHEMES, BootstrapParticleFilter, KalmanFilter, normalize_log_weights
from pfrepro.filters.particle import WeightCollapseWarning
from pfrepro.models import LinearGaussianModel

NS = (100, 1000, 10000)


def scalar_model():
    return LinearGaussianModel([[0.9]], [[1.0]], [[1.0]], [[0.5]], [0.0], P0=[[1.0]])


def normalised_errors(model, runs, T, seed, Ns=NS, **pf_kw):
    """RMS over runs and time of (PF mean - KF mean) / KF std, and mean |PF cov - KF cov| / KF scale."""
    sim = model.simulate(T, runs=runs, rng=np.random.default_rng(seed))
    kf = KalmanFilter(model).filter(sim.y)
    sd = np.sqrt(np.diagonal(kf.P, axis1=-2, axis2=-1))
    err_mean, err_cov = [], []
    for i, N in enumerate(Ns):
        pf = BootstrapParticleFilter(model, N, return_cov=True, **pf_kw).filter(
            sim.y, rng=np.random.default_rng([seed, i]))  # all runs in one batched call
        err_mean.append(np.sqrt(np.mean(((pf.x - kf.x) / sd) ** 2)))
        err_cov.append(np.mean(np.abs(pf.P - kf.P) / (sd[..., :, None] * sd[..., None, :])))
    return np.array(err_mean), np.array(err_cov)


def test_pf_converges_to_kf_scalar():
    # measured (seed 1): mean errors ~0.155, 0.046, 0.015 (x sqrt(N): 1.5, 1.5, 1.5);
    # expected ratio per decade sqrt(10) = 3.16
    e, ec = normalised_errors(scalar_model(), runs=40, T=10, seed=1)
    assert e[0] / e[1] > 1.8 and e[1] / e[2] > 1.8 and e[0] / e[2] > 5
    assert e[2] < 0.03
    scaled = e * np.sqrt(NS)  # roughly constant under 1/sqrt(N) convergence
    assert np.all((scaled > 0.5) & (scaled < 4.0)), scaled
    assert ec[0] / ec[2] > 5 and ec[2] < 0.03


def test_pf_converges_to_kf_random_2d():
    # measured (seed 2): ~0.25, 0.10, 0.03
    e, ec = normalised_errors(random_linear_model(31, 2, 1), runs=20, T=8, seed=2)
    assert e[0] / e[2] > 4 and e[1] > e[2]
    assert e[2] < 0.08
    assert ec[0] / ec[2] > 4 and ec[2] < 0.06


@pytest.mark.parametrize("scheme", RESAMPLING_SCHEMES)
@pytest.mark.parametrize("ess_threshold", [None, 0.5])
def test_every_scheme_tracks_kf(scheme, ess_threshold):
    e, _ = normalised_errors(scalar_model(), runs=20, T=10, seed=3, Ns=(2000,), resampling=scheme,
                             ess_threshold=ess_threshold)
    assert e[0] < 0.1  # measured ~0.03-0.05; a broken scheme gives O(1)


def kf_log_evidence(model, y):
    """Exact log p(y_1:T) of a linear-Gaussian model, one run, by the prediction-error decomposition."""
    x, P, total = model.m0.copy(), model.P0.copy(), 0.0
    for yk in y:
        x, P = model.F @ x, model.F @ P @ model.F.T + model.Q
        S = model.H @ P @ model.H.T + model.R
        total += multivariate_normal(model.H @ x, S).logpdf(yk)
        K = P @ model.H.T @ np.linalg.inv(S)
        x, P = x + K @ (yk - model.H @ x), (np.eye(len(x)) - K @ model.H) @ P
    return total


def test_log_evidence_matches_kalman():
    model = scalar_model()
    sim = model.simulate(10, runs=20, rng=np.random.default_rng(4))
    pf = BootstrapParticleFilter(model, 5000).filter(sim.y, rng=np.random.default_rng(5))
    exact = np.array([kf_log_evidence(model, sim.y[r]) for r in range(sim.runs)])
    d = pf.diagnostics["log_evidence"] - exact
    # measured over seeds: per-run sd ~0.05, max |d| < 0.2, mean |d.mean()| < 0.013; a
    # missing or double-counted normaliser is off by O(1) (log N = 8.5) per step
    assert np.max(np.abs(d)) < 0.4
    assert abs(d.mean()) < 0.05


def test_diagnostics_shapes_and_ranges():
    model = scalar_model()
    N, runs, T = 200, 3, 12
    sim = model.simulate(T, runs=runs, rng=np.random.default_rng(6))
    res = BootstrapParticleFilter(model, N, return_cov=True).filter(sim.y, rng=np.random.default_rng(7))
    assert res.x.shape == (runs, T, 1) and res.P.shape == (runs, T, 1, 1)
    d = res.diagnostics
    assert d["ess"].shape == (runs, T) and d["resampled"].shape == (runs, T)
    assert d["log_evidence"].shape == (runs,) and d["collapsed"].shape == (runs, T)
    assert np.all((d["ess"] >= 1 - 1e-9) & (d["ess"] <= N + 1e-9))
    assert d["resampled"].all() and d["n_collapsed"] == 0
    assert np.all(res.P > 0)


def test_ess_threshold_controls_resampling():
    model = scalar_model()
    sim = model.simulate(15, runs=4, rng=np.random.default_rng(8))
    never = BootstrapParticleFilter(model, 300, ess_threshold=0.0).filter(sim.y, rng=np.random.default_rng(9))
    assert not never.diagnostics["resampled"].any()
    always = BootstrapParticleFilter(model, 300, ess_threshold=1.0).filter(sim.y, rng=np.random.default_rng(9))
    assert always.diagnostics["resampled"].all()  # ESS < N unless weights are exactly equal
    half = BootstrapParticleFilter(model, 300, ess_threshold=0.5).filter(sim.y, rng=np.random.default_rng(9))
    d = half.diagnostics
    np.testing.assert_array_equal(d["resampled"], d["ess"] < 150)


def test_without_resampling_weights_carry_over():
    """With ess_threshold=0 the PF is SIS: the log evidence is still the exact sum over steps of
    log sum_i w_{k-1}^i p(y_k|x_k^i); for a short horizon it stays close to the KF's."""
    model = scalar_model()
    sim = model.simulate(3, runs=5, rng=np.random.default_rng(10))
    pf = BootstrapParticleFilter(model, 20000, ess_threshold=0.0).filter(sim.y, rng=np.random.default_rng(11))
    exact = np.array([kf_log_evidence(model, sim.y[r]) for r in range(sim.runs)])
    np.testing.assert_allclose(pf.diagnostics["log_evidence"], exact, atol=0.1)  # measured max 0.045


def test_single_run_input_and_n_equals_one():
    model = scalar_model()
    sim = model.simulate(5, runs=1, rng=np.random.default_rng(12))
    res = BootstrapParticleFilter(model, 1).filter(sim.y[0, :, 0], rng=np.random.default_rng(0))
    assert res.x.shape == (1, 5, 1) and np.all(np.isfinite(res.x))
    np.testing.assert_allclose(res.diagnostics["ess"], 1.0)


def test_normalize_log_weights():
    logw = np.array([[0.0, np.log(3.0), -np.inf],
                     [1e5, 1e5 + np.log(3.0), np.nan],   # huge offsets: no overflow; NaN -> zero weight
                     [-np.inf, -np.inf, -np.inf],         # collapse
                     [np.nan, np.nan, np.nan]])
    w, log_sum, collapsed = normalize_log_weights(logw)
    np.testing.assert_allclose(w[0], [0.25, 0.75, 0.0], rtol=1e-14)
    np.testing.assert_allclose(w[1], [0.25, 0.75, 0.0], rtol=1e-10)  # log 3 added to 1e5 loses ~1e-11
    np.testing.assert_allclose(w[2:], 1.0 / 3.0, rtol=1e-14)
    np.testing.assert_allclose(log_sum[:2], [np.log(4.0), 1e5 + np.log(4.0)], rtol=1e-13)
    assert np.all(np.isneginf(log_sum[2:]))
    np.testing.assert_array_equal(collapsed, [False, False, True, True])


def test_collapse_is_reported_not_crashing():
    model = LinearGaussianModel([[0.5]], [[1.0]], [[1.0]], [[1e-4]], [0.0], P0=[[1.0]])
    y = np.zeros((3, 4, 1))
    # run 0: log-likelihoods ~ -5e15 for every particle, finite in the log domain: no collapse
    y[0, 1] = 1e6
    # run 1: the squared residual overflows, every log-weight is -inf: a genuine collapse
    y[1, 2] = 1e200
    with pytest.warns(WeightCollapseWarning, match="1 of 12 run-steps"):
        res = BootstrapParticleFilter(model, 50).filter(y, rng=np.random.default_rng(0))
    assert np.all(np.isfinite(res.x))
    coll = res.diagnostics["collapsed"]
    assert coll[1, 2] and coll.sum() == 1 and res.diagnostics["n_collapsed"] == 1
    ev = res.diagnostics["log_evidence"]
    assert np.isfinite(ev[0]) and np.isneginf(ev[1]) and np.isfinite(ev[2])
