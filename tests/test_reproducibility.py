"""Same seed => bit-identical results; per-filter streams are keyed by name, not by order."""
from __future__ import annotations

import numpy as np
import pytest

from pfrepro.filters import RESAMPLING_SCHEMES, BootstrapParticleFilter, KalmanFilter, UnscentedKalmanFilter
from pfrepro.metrics import mse, rmse
from pfrepro.models import CWPA, UNGM, BearingsOnly
from pfrepro.montecarlo import filter_rng, filter_streams, run_monte_carlo, truth_rng, truth_streams


@pytest.mark.parametrize("model", [UNGM.zhang2016(), BearingsOnly.zhang2016(), CWPA.zhang2016("mixture"),
                                   UNGM(truth_init="prior")], ids=["UNGM", "BOT", "CWPA-mix", "UNGM-prior"])
def test_simulate_same_seed_identical(model):
    a = model.simulate(15, runs=4, rng=np.random.default_rng(123))
    b = model.simulate(15, runs=4, rng=np.random.default_rng(123))
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.y, b.y)
    c = model.simulate(15, runs=4, rng=np.random.default_rng(124))
    assert not np.array_equal(a.y, c.y)


@pytest.mark.parametrize("scheme", RESAMPLING_SCHEMES)
@pytest.mark.parametrize("ess_threshold", [None, 0.5])
def test_pf_same_seed_identical(scheme, ess_threshold):
    model = UNGM.zhang2016()
    sim = model.simulate(15, runs=3, rng=np.random.default_rng(0))
    pf = BootstrapParticleFilter(model, 300, resampling=scheme, ess_threshold=ess_threshold, return_cov=True)
    a = pf.filter(sim.y, rng=np.random.default_rng(7))
    b = pf.filter(sim.y, rng=np.random.default_rng(7))
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.P, b.P)
    for key in ("ess", "resampled", "log_evidence", "collapsed"):
        np.testing.assert_array_equal(a.diagnostics[key], b.diagnostics[key])
    c = pf.filter(sim.y, rng=np.random.default_rng(8))
    assert not np.array_equal(a.x, c.x)


def test_stream_keys():
    draw = lambda g: g.random(4)  # noqa: E731
    np.testing.assert_array_equal(draw(filter_rng(5, "PF")), draw(filter_rng(5, "PF")))
    np.testing.assert_array_equal(draw(truth_rng(5)), draw(truth_rng(5)))
    streams = [draw(filter_rng(5, "PF")), draw(filter_rng(5, "PF-2")), draw(filter_rng(6, "PF")),
               draw(truth_rng(5)), draw(truth_rng(6))]
    for i in range(len(streams)):
        for j in range(i):
            assert not np.array_equal(streams[i], streams[j])


def _filters(model):
    return {"PF": BootstrapParticleFilter(model, 200), "KF": KalmanFilter(model),
            "PF-res": BootstrapParticleFilter(model, 200, resampling="residual")}


def test_run_monte_carlo_same_seed_identical():
    model = CWPA.zhang2016()
    a = run_monte_carlo(model, _filters(model), T=12, runs=3, seed=42)
    b = run_monte_carlo(model, _filters(model), T=12, runs=3, seed=42)
    np.testing.assert_array_equal(a.sim.x, b.sim.x)
    np.testing.assert_array_equal(a.sim.y, b.sim.y)
    for name in a.results:
        np.testing.assert_array_equal(a.results[name].x, b.results[name].x)
    # the truth is the truth_streams(seed, runs) per-run streams
    np.testing.assert_array_equal(a.sim.y, model.simulate(12, 3, truth_streams(42, 3)).y)
    # and each filter ran on its own named per-run streams
    np.testing.assert_array_equal(a.results["PF"].x,
                                  _filters(model)["PF"].filter(a.sim.y, rng=filter_streams(42, "PF", 3)).x)
    c = run_monte_carlo(model, _filters(model), T=12, runs=3, seed=43)
    assert not np.array_equal(a.sim.y, c.sim.y)


def test_different_names_get_different_streams():
    model = UNGM.zhang2016()
    pf = BootstrapParticleFilter(model, 200)
    res = run_monte_carlo(model, {"PF-a": pf, "PF-b": pf}, T=10, runs=2, seed=1)
    assert not np.array_equal(res.results["PF-a"].x, res.results["PF-b"].x)


def test_adding_or_reordering_filters_changes_nothing_else():
    model = UNGM.zhang2016()
    base = run_monte_carlo(model, {"PF": BootstrapParticleFilter(model, 200)}, T=10, runs=3, seed=9)
    more = run_monte_carlo(model, {"UKF": UnscentedKalmanFilter(model),
                                   "PF-big": BootstrapParticleFilter(model, 500),
                                   "PF": BootstrapParticleFilter(model, 200)}, T=10, runs=3, seed=9)
    np.testing.assert_array_equal(base.sim.y, more.sim.y)
    np.testing.assert_array_equal(base.results["PF"].x, more.results["PF"].x)
    np.testing.assert_array_equal(base.results["PF"].diagnostics["log_evidence"],
                                  more.results["PF"].diagnostics["log_evidence"])


def test_reused_simulation_and_result_helpers():
    model = UNGM.zhang2016()
    sim = model.simulate(8, runs=2, rng=np.random.default_rng(3))
    res = run_monte_carlo(model, {"PF": BootstrapParticleFilter(model, 100)}, T=8, runs=2, seed=4, sim=sim)
    assert res.sim is sim and res.seed == 4
    np.testing.assert_array_equal(res.x_true, sim.x[:, 1:])
    np.testing.assert_array_equal(res.mse("PF"), mse(sim.x[:, 1:], res.results["PF"].x))
    np.testing.assert_array_equal(res.rmse("PF"), rmse(sim.x[:, 1:], res.results["PF"].x))
    assert set(res.batch_seconds) == {"PF"} and res.seconds_per_run == {}
    with pytest.raises(ValueError, match=r"sim has shape \(2, 8\), expected \(runs, T\) = \(3, 8\)"):
        run_monte_carlo(model, {}, T=8, runs=3, seed=4, sim=sim)


def test_time_per_run_does_not_disturb_results():
    model = UNGM.zhang2016()
    filters = {"PF": BootstrapParticleFilter(model, 100)}
    a = run_monte_carlo(model, filters, T=6, runs=2, seed=2)
    b = run_monte_carlo(model, filters, T=6, runs=2, seed=2, time_per_run=True, timing_repeats=2)
    np.testing.assert_array_equal(a.results["PF"].x, b.results["PF"].x)
    assert set(b.seconds_per_run) == {"PF"} and np.isfinite(b.seconds_per_run["PF"])
