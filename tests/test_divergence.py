"""Issue 21, divergence: caught where it starts, the run marked and stopped, other runs untouched
to the last bit, one warning with the count; every filter on an outlier behaves as documented."""
import re
import warnings

import numpy as np
import pytest

from pfrepro.filters import FilterDivergenceError, FilterDivergenceWarning, GaussianParticleFlowFilter
from pfrepro.models import StateSpaceModel, wrap_angle
from pfrepro.montecarlo import filter_streams, truth_streams


class RangeBearing(StateSpaceModel):
    """Nearly-constant-velocity target, range and bearing from a sensor at the origin (the
    user's model of issue 21: the target passes ~1.5 m from the sensor)."""

    def __init__(self, x0=(30.0, 1.5, -1.0, 0.0), P0=(4.0, 4.0, 0.1, 0.1)):
        I2, Z2 = np.eye(2), np.zeros((2, 2))
        self.F = np.block([[I2, I2], [Z2, I2]])
        Q = 0.05 * np.block([[I2 / 3, I2 / 2], [I2 / 2, I2]])
        super().__init__(dim_x=4, dim_y=2, Q=Q, measurement_noise=np.diag([1.0, 0.02**2]),
                         x0=x0, m0=x0, P0=np.diag(P0))

    def f(self, x, k):
        return x @ self.F.T

    def h(self, x):
        return np.stack([np.hypot(x[..., 0], x[..., 1]), np.arctan2(x[..., 1], x[..., 0])], axis=-1)

    def residual_y(self, y, y_pred):
        d = y - y_pred
        return np.concatenate([d[..., :1], wrap_angle(d[..., 1:])], axis=-1)


SEED, RUNS, T = 5, 24, 40


@pytest.fixture(scope="module")
def near_pass():
    model = RangeBearing()
    sim = model.simulate(T, RUNS, truth_streams(SEED, RUNS))
    gpff = GaussianParticleFlowFilter(model, 100, field="eq43", on_divergence="drop")
    return model, sim, gpff, gpff.filter(sim.y, filter_streams(SEED, "GPFF", RUNS))


def test_divergence_is_caught_before_garbage_and_the_run_is_nan_from_there(near_pass):
    model, sim, gpff, res = near_pass
    d = res.diagnostics["diverged_at"]
    assert res.diagnostics["n_diverged"] == int((d > 0).sum()) > 0     # the scenario does diverge
    for r in range(RUNS):
        if d[r]:
            assert np.all(np.isnan(res.x[r, d[r] - 1:]))
            good = res.x[r, :d[r] - 1]
        else:
            good = res.x[r]
        assert np.all(np.isfinite(good))
        # no huge finite numbers: every estimate it returns is within 1 km of the truth
        assert np.max(np.abs(good[..., :2] - sim.x[r, 1:len(good) + 1, :2])) < 1e3


def test_a_diverging_run_changes_no_other_run_by_one_bit(near_pass):
    model, sim, gpff, res = near_pass
    d = res.diagnostics["diverged_at"]
    for r in sorted(set(np.flatnonzero(d).tolist()) | {0, RUNS - 1}):
        alone = gpff.filter(sim.y[r:r + 1], filter_streams(SEED, "GPFF", 1, start=r))
        np.testing.assert_array_equal(alone.x[0], res.x[r])
        assert alone.diagnostics["diverged_at"][0] == d[r]
    # the batch without the diverging runs: the same numbers for the others
    keep = np.flatnonzero(d == 0)
    lo, hi = keep[0], keep[0] + 1
    while hi < RUNS and d[hi] == 0:
        hi += 1
    part = gpff.filter(sim.y[lo:hi], filter_streams(SEED, "GPFF", hi - lo, start=lo))
    np.testing.assert_array_equal(part.x, res.x[lo:hi])


def test_default_keeps_other_runs_and_warns_once_with_the_count(near_pass):
    model, sim, gpff, res = near_pass
    n = res.diagnostics["n_diverged"]
    default = GaussianParticleFlowFilter(model, 100, field="eq43")
    assert default.on_divergence == "warn"
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        got = default.filter(sim.y, filter_streams(SEED, "GPFF", RUNS))
    div = [w for w in rec if issubclass(w.category, FilterDivergenceWarning)]
    assert len(div) == 1 and f"{n} of {RUNS} runs diverged" in str(div[0].message)
    assert not [w for w in rec if w.category is RuntimeWarning]
    np.testing.assert_array_equal(got.x, res.x)
    with pytest.raises(FilterDivergenceError, match="diverged at step"):
        GaussianParticleFlowFilter(model, 100, field="eq43", on_divergence="raise").filter(
            sim.y, filter_streams(SEED, "GPFF", RUNS))


def test_growth_threshold_is_checked():
    model = RangeBearing()
    for bad in (1.0, 0.5, float("nan"), "big"):
        with pytest.raises((ValueError, TypeError), match="max_growth"):
            GaussianParticleFlowFilter(model, 10, max_growth=bad)
    with pytest.raises(ValueError, match="on_divergence"):
        GaussianParticleFlowFilter(model, 10, on_divergence="ignore")


def test_every_filter_on_a_1e200_outlier_behaves_as_documented():
    """Issue 21: GPFF raised numpy's singular-matrix error, the theta-grid reference scipy's
    "finite values" error, the grid filter was silent, the dual EKF returned 5e199 then NaN.
    Now: filters that weight (grid, theta grid, PFs) ignore the measurement, flag it and give
    one WeightCollapseWarning; the flow and the dual EKF mark the run diverged (NaN from that
    step) with one FilterDivergenceWarning; no other run changes."""
    from pfrepro.experiments.dpf_hou2008 import model_51
    from pfrepro.filters import GridFilter
    from pfrepro.filters.dual_ekf import DualExtendedKalmanFilter
    from pfrepro.filters.particle import WeightCollapseWarning
    from pfrepro.filters.theta_grid import ThetaGridReference
    from pfrepro.models import UNGM

    m, pm = UNGM.zhang2016(), model_51()
    y = m.simulate(10, 3, np.random.default_rng(0)).y
    py = pm.simulate(10, 3, np.random.default_rng(0)).y
    y_bad, py_bad = y.copy(), py.copy()
    y_bad[1, 4] = 1e200
    py_bad[1, 4] = 1e200
    cases = [
        ("GPFF", lambda yy: GaussianParticleFlowFilter(m, 50).filter(yy, filter_streams(1, "g", 3)), y, y_bad,
         FilterDivergenceWarning, "diverged_at", 5),
        ("Grid", lambda yy: GridFilter(m, bounds=(-40, 40), n_grid=1601).filter(yy), y, y_bad,
         WeightCollapseWarning, "collapsed", None),
        # the dual EKF's test is the EKF's (non-finite estimates): the 1e200 estimate of step 5
        # overflows at step 6, where the run is stopped
        ("DEKF", lambda yy: DualExtendedKalmanFilter(pm, 0.5, 0.1).filter(yy), py, py_bad,
         FilterDivergenceWarning, "diverged_at", 6),
        ("ThetaGrid", lambda yy: ThetaGridReference(pm, n_theta=21, n_grid=201).filter(yy), py, py_bad,
         WeightCollapseWarning, "collapsed", None),
    ]
    for name, run, clean, bad, kind, key, at in cases:
        ref = run(clean)
        with warnings.catch_warnings(record=True) as rec:
            warnings.simplefilter("always")
            got = run(bad)
        assert [w.category for w in rec] == [kind], (name, [str(w.message) for w in rec])
        flag = np.asarray(got.diagnostics[key])
        if key == "diverged_at":
            assert flag.tolist() == [0, at, 0], name
            assert np.all(np.isnan(got.x[1, at - 1:])) and np.all(np.isfinite(got.x[1, :at - 1])), name
        else:
            assert flag[1, 4] and flag.sum() == 1, name
            assert np.all(np.isfinite(got.x)), name
        for r in (0, 2):                                  # the other runs: the same bits
            np.testing.assert_array_equal(got.x[r], ref.x[r], err_msg=name)


def test_dual_ekf_raises_like_the_ekf_when_asked():
    from pfrepro.experiments.dpf_hou2008 import model_51
    from pfrepro.filters.dual_ekf import DualExtendedKalmanFilter

    pm = model_51()
    y = pm.simulate(8, 2, np.random.default_rng(0)).y
    y[0, 3] = 1e200
    with pytest.raises(FilterDivergenceError, match="DEKF"):
        DualExtendedKalmanFilter(pm, 0.5, 0.1, on_divergence="raise").filter(y)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        DualExtendedKalmanFilter(pm, 0.5, 0.1, on_divergence="drop").filter(y)   # silent, marked


def test_gpff_divergence_at_step_1_is_counted_and_drop_is_silent():
    """A run lost at the first step (diverged_at = 1, the smallest marker) counts in n_diverged
    and in the warning; 'drop' gives the same numbers without a warning; 'raise' names step 1."""
    from pfrepro.models import UNGM

    m = UNGM.zhang2016()
    y = m.simulate(6, 3, np.random.default_rng(0)).y
    y[1, 0] = 1e200
    streams = lambda: filter_streams(1, "g", 3)   # noqa: E731
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        res = GaussianParticleFlowFilter(m, 50).filter(y, streams())
    msgs = [str(w.message) for w in rec if issubclass(w.category, FilterDivergenceWarning)]
    assert len(msgs) == 1 and "1 of 3 runs diverged (first at step 1)" in msgs[0], msgs
    assert res.diagnostics["diverged_at"].tolist() == [0, 1, 0] and res.diagnostics["n_diverged"] == 1
    assert np.all(np.isnan(res.x[1])) and np.all(np.isfinite(res.x[[0, 2]]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        drop = GaussianParticleFlowFilter(m, 50, on_divergence="drop").filter(y, streams())
    np.testing.assert_array_equal(drop.x, res.x)
    assert drop.diagnostics["n_diverged"] == 1
    with pytest.raises(FilterDivergenceError, match=r"step 1 in runs \[1\]"):
        GaussianParticleFlowFilter(m, 50, on_divergence="raise").filter(y, streams())
    # every run lost at step 1: all NaN, counted, no crash
    y[:, 0] = 1e200
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gone = GaussianParticleFlowFilter(m, 50, return_cov=True).filter(y, streams())
    assert gone.diagnostics["n_diverged"] == 3 and np.all(np.isnan(gone.x)) and np.all(np.isnan(gone.P))


def test_gpff_prior_statistics_of_a_broken_run_is_nan_in_that_run_only():
    """A run whose cloud has no covariance square root (NaN particle) gets NaN moments in its
    own slot; the batch does not raise and the other run's numbers are those it has alone."""
    from pfrepro.models import BearingsOnly

    m = BearingsOnly.zhang2016()
    g = GaussianParticleFlowFilter(m, 20)
    x = g.sample_prior(np.random.default_rng(0), (2, 20))
    x[1, 3] = np.nan
    with np.errstate(all="ignore"):
        out = g.prior_statistics(x)
    alone = g.prior_statistics(x[:1])
    for a, b in zip(out, alone):
        np.testing.assert_array_equal(a[:1], b)
        assert np.all(np.isnan(a[1]))


def test_gpff_raise_names_at_most_ten_runs():
    from pfrepro.models import UNGM

    y = np.full((12, 2, 1), 1e200)
    with pytest.raises(FilterDivergenceError, match=r"step 1 in runs \[0, 1, 2, 3, 4, 5, 6, 7, 8, 9\] \("):
        GaussianParticleFlowFilter(UNGM.zhang2016(), 10, on_divergence="raise").filter(y, filter_streams(1, "g", 12))


# -- the Kalman family: one behaviour for every filter (issue 34, item 4) -------------------------
def _ungm_outlier(runs=3, T=10, bad_run=1, at=5):
    from pfrepro.models import UNGM

    m = UNGM.zhang2016()
    y = m.simulate(T, runs, np.random.default_rng(0)).y
    y_bad = y.copy()
    y_bad[bad_run, at - 1] = 1e200
    return m, y, y_bad


def _kalman_family(m):
    from pfrepro.filters import ExtendedKalmanFilter, UnscentedKalmanFilter
    from pfrepro.filters.ekf_variants import PreviousEstimateJacobianEKF

    return {"EKF": lambda **kw: ExtendedKalmanFilter(m, **kw),
            "UKF": lambda **kw: UnscentedKalmanFilter(m, **kw),
            "EKF (B at previous estimate)": lambda **kw: PreviousEstimateJacobianEKF(m, **kw)}


@pytest.mark.parametrize("name", ["EKF", "UKF", "EKF (B at previous estimate)"])
def test_kalman_filters_warn_once_mark_the_run_and_keep_the_others(name):
    """Before: FilterDivergenceError for the whole batch (every run lost). Now as GPFF/DEKF:
    one warning naming the filter and the run, NaN from the step on, the others bit-identical."""
    m, y, y_bad = _ungm_outlier()
    make = _kalman_family(m)[name]
    ref = make().filter(y)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        got = make().filter(y_bad)
    msgs = [str(w.message) for w in rec]
    assert [w.category for w in rec] == [FilterDivergenceWarning], msgs
    assert msgs[0].startswith(f"{name}: 1 of 3 runs diverged") and "in runs [1]" in msgs[0]
    d = got.diagnostics
    assert d["diverged"].tolist() == [False, True, False] and d["n_diverged"] == 1
    at = d["diverged_at"][1]
    assert d["diverged_at"].tolist() == [0, at, 0] and at >= 5
    assert np.all(np.isnan(got.x[1, at - 1:])) and np.all(np.isfinite(got.x[1, :at - 1]))
    assert np.all(np.isnan(got.P[1, at - 1:])) and np.all(np.isnan(d["log_likelihood"][1, at - 1:]))
    for r in (0, 2):
        np.testing.assert_array_equal(got.x[r], ref.x[r])
        np.testing.assert_array_equal(got.P[r], ref.P[r])
    assert ref.diagnostics["n_diverged"] == 0 and not ref.diagnostics["diverged"].any()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        drop = make(on_divergence="drop").filter(y_bad)
    np.testing.assert_array_equal(drop.x, got.x)
    with pytest.raises(FilterDivergenceError, match=re.escape(name) + r": 1 of 3 runs diverged .* in runs \[1\]"):
        make(on_divergence="raise").filter(y_bad)
    with pytest.raises(ValueError, match="on_divergence"):
        make(on_divergence="ignore")


def test_one_diverging_ekf_run_loses_nothing_in_run_monte_carlo():
    """Before: one EKF run's divergence raised out of run_monte_carlo and every filter's results
    were lost. Now the call returns; the EKF's lost run is NaN and counted, the rest is kept."""
    from pfrepro.filters import BootstrapParticleFilter, ExtendedKalmanFilter, UnscentedKalmanFilter
    from pfrepro.models import Simulation
    from pfrepro.montecarlo import run_monte_carlo

    m, y, y_bad = _ungm_outlier(runs=4, T=12, bad_run=2)
    sim = m.simulate(12, 4, np.random.default_rng(0))
    filters = {"EKF": ExtendedKalmanFilter(m), "UKF": UnscentedKalmanFilter(m),
               "PF": BootstrapParticleFilter(m, 50)}
    clean = run_monte_carlo(m, filters, 12, 4, 3, sim=sim)
    with pytest.warns(FilterDivergenceWarning, match=r"EKF: 1 of 4 runs diverged .* in runs \[2\]"):
        mc = run_monte_carlo(m, filters, 12, 4, 3, sim=Simulation(sim.x, y_bad))
    assert mc.n_diverged()["EKF"] == 1 and mc.results["EKF"].diagnostics["diverged"].tolist() == [0, 0, 1, 0]
    np.testing.assert_array_equal(mc.results["EKF"].x[[0, 1, 3]], clean.results["EKF"].x[[0, 1, 3]])
    assert set(mc.results) == set(filters) and np.all(np.isfinite(mc.results["PF"].x))


def test_imm_kalman_marks_a_diverged_run_and_keeps_the_others():
    from pfrepro.filters import ExtendedKalmanFilter
    from pfrepro.filters.imm import IMMKalman
    from pfrepro.models import UNGM, JumpMarkovSystem

    ms = [UNGM(alpha=0.5), UNGM(alpha=0.4)]
    sysm = JumpMarkovSystem(ms, [[0.9, 0.1], [0.1, 0.9]])
    y = sysm.simulate(10, 3, np.random.default_rng(1)).y
    y_bad = y.copy()
    y_bad[0, 3] = 1e200
    make = lambda **kw: IMMKalman(sysm, [ExtendedKalmanFilter(m) for m in ms], name="IMM-EKF", **kw)  # noqa: E731
    ref = make().filter(y)
    with pytest.warns(FilterDivergenceWarning, match=r"IMM-EKF: 1 of 3 runs diverged .* in runs \[0\]"):
        got = make().filter(y_bad)
    at = got.diagnostics["diverged_at"][0]
    assert at >= 4 and got.diagnostics["diverged_at"].tolist() == [at, 0, 0]
    assert np.all(np.isnan(got.x[0, at - 1:])) and np.all(np.isnan(got.diagnostics["mode_probs"][0, at - 1:]))
    np.testing.assert_array_equal(got.x[1:], ref.x[1:])
    with pytest.raises(FilterDivergenceError, match="IMM-EKF"):
        make(on_divergence="raise").filter(y_bad)
