"""Issue 8, "bad input: a clear error or a right answer, never a silent NaN" -- one regression
test per item found by trying the package as a new user would, plus defaults that work on every
model the package ships."""
from __future__ import annotations

import numpy as np
import pytest

from pfrepro.filters import (BootstrapParticleFilter, CMSParticleFilter, EvolutionSamplingParticleFilter,
                             ExtendedKalmanFilter, GaussianParticleFlowFilter, GridFilter, KalmanFilter,
                             UnscentedKalmanFilter, resample)
from pfrepro.filters.ekf_variants import PreviousEstimateJacobianEKF
from pfrepro.filters.particle import WeightCollapseWarning
from pfrepro.metrics import mc_summary
from pfrepro.models import (CWPA, UNGM, BearingsOnly, LinearGaussianModel, ModelContractError,
                            StochasticVolatility)

# ----------------------------------------------------------------------------- grid filter
GRID = dict(bounds=(-40.0, 40.0), n_grid=1601)


@pytest.mark.parametrize("kw, msg", [(dict(P0=-1.0), "P0 is not positive definite"),
                                     (dict(P0=0.0), "P0 is not positive definite"),
                                     (dict(m0=np.nan), "m0 contains NaN"),
                                     (dict(m0=[0.0, 1.0]), "m0 must have length 1"),
                                     (dict(P0=np.eye(2)), "P0 must be 1x1")])
def test_grid_filter_validates_m0_P0_overrides(kw, msg):
    with pytest.raises(ValueError, match=msg):
        GridFilter(UNGM.zhang2016(), **GRID, **kw)


def test_grid_filter_reads_1x1_P0_as_scalar():
    m = UNGM.zhang2016()
    sim = m.simulate(20, 2, np.random.default_rng(0))
    a = GridFilter(m, **GRID, m0=0.5, P0=[[2.0]]).filter(sim.y)
    b = GridFilter(m, **GRID, m0=[0.5], P0=2.0).filter(sim.y)
    c = GridFilter(m, **GRID).filter(sim.y)
    np.testing.assert_array_equal(a.x, b.x)
    assert not np.allclose(a.x[:, 0], c.x[:, 0])       # the override is used


def test_grid_filter_outlier_is_not_nan_and_is_reported():
    """y = 1e200: every log-likelihood overflows to -inf (the old guard s <= 0 missed the NaN
    of -inf - -inf). The measurement is ignored (posterior = prediction) and flagged."""
    m = UNGM.zhang2016()
    sim = m.simulate(10, 2, np.random.default_rng(1))
    y = sim.y.copy()
    y[1, 4, 0] = 1e200
    with pytest.warns(WeightCollapseWarning, match="1 of 20 run-steps"):   # reported loudly, once
        res = GridFilter(m, **GRID).filter(y)
    assert np.all(np.isfinite(res.x)) and np.all(np.isfinite(res.P))
    assert res.diagnostics["collapsed"][1, 4] and res.diagnostics["n_collapsed"] == 1
    # posterior at the outlier step = the prediction from step 4's posterior (run 1), and
    # the other run is untouched
    ref = GridFilter(m, **GRID).filter(sim.y)
    np.testing.assert_array_equal(res.x[0], ref.x[0])
    with pytest.warns(WeightCollapseWarning, match="1 of 5 run-steps"):
        no_update = GridFilter(m, **GRID).filter(np.concatenate([sim.y[1:, :4], y[1:, 4:5]], axis=1))
    assert no_update.diagnostics["collapsed"][0, 4]
    np.testing.assert_allclose(res.x[1, :5], no_update.x[0], rtol=1e-12)


def test_grid_filter_large_finite_outlier_is_finite():
    """y = 1e6 needs |x| ~ 4472, far off the grid: the posterior goes to the grid edge, finite."""
    m = UNGM.zhang2016()
    sim = m.simulate(5, 1, np.random.default_rng(2))
    y = sim.y.copy()
    y[0, 2, 0] = 1e6
    res = GridFilter(m, **GRID).filter(y)
    assert np.all(np.isfinite(res.x)) and not res.diagnostics["collapsed"].any()
    assert abs(res.x[0, 2, 0]) > 39.0


def test_grid_log_domain_normalisation_hand_computed():
    """The direct product pred * exp(loglik - max) is 0 at every node (the likelihood peaks
    where the prediction is 0, and underflows where it is not): the log-domain fallback gives
    post ∝ pred * lik exactly; a row with no finite likelihood keeps the prediction."""
    pred = np.array([[0.0, 0.5, 0.5, 0.0], [0.25, 0.25, 0.5, 0.0]])
    ll = np.array([[0.0, -2000.0, -2001.0, -np.inf], [-np.inf, np.nan, -np.inf, 0.0]])
    post, coll = GridFilter._log_domain_posterior(pred, ll, k=1)
    e = np.exp(-1.0)
    np.testing.assert_allclose(post[0], [0.0, 1 / (1 + e), e / (1 + e), 0.0], rtol=1e-15)
    np.testing.assert_array_equal(post[1], pred[1])
    np.testing.assert_array_equal(coll, [False, True])
    with pytest.raises(FloatingPointError, match="predictive density vanished"):
        GridFilter._log_domain_posterior(np.zeros((1, 4)), np.zeros((1, 4)), k=3)


# ----------------------------------------------------------------------------- GPFF defaults
def test_gpff_default_field_is_the_linearised_one():
    assert GaussianParticleFlowFilter(UNGM.zhang2016()).field == "eq43"


def test_gpff_defaults_do_not_diverge_on_ungm_where_eq41_does():
    m = UNGM.zhang2016()
    sim = m.simulate(60, 5, np.random.default_rng(3))
    ok = GaussianParticleFlowFilter(m).filter(sim.y, np.random.default_rng(4))
    assert ok.diagnostics["n_diverged"] == 0 and np.all(np.isfinite(ok.x))
    lit = GaussianParticleFlowFilter(m, field="eq41", on_divergence="drop").filter(sim.y, np.random.default_rng(4))
    assert lit.diagnostics["n_diverged"] == 5       # why eq41 is not the default


PRESETS = {"UNGM()": UNGM, "UNGM.zhang2016": UNGM.zhang2016, "UNGM.li2012_model1": UNGM.li2012_model1,
           "UNGM.li2012_model2": UNGM.li2012_model2, "UNGM.ning2011": UNGM.ning2011,
           "CWPA.zhang2016": CWPA.zhang2016, "CWPA.zhang2016(mixture)": lambda: CWPA.zhang2016("mixture"),
           "BearingsOnly.zhang2016": BearingsOnly.zhang2016, "StochasticVolatility()": StochasticVolatility}
FILTERS = {"KF": KalmanFilter, "EKF": ExtendedKalmanFilter, "EKF (B at previous estimate)": PreviousEstimateJacobianEKF,
           "UKF": UnscentedKalmanFilter, "GPFF": GaussianParticleFlowFilter, "Grid": GridFilter,
           "PF": lambda m: BootstrapParticleFilter(m, 200), "CMS-PF": lambda m: CMSParticleFilter(m, 200),
           "ESPF": lambda m: EvolutionSamplingParticleFilter(m, 200)}
# (filter, preset) pairs the model contract refuses; every other pair must run with defaults
LINEAR = {"CWPA.zhang2016", "CWPA.zhang2016(mixture)"}
SCALAR = {p for p in PRESETS if p.startswith(("UNGM", "Stochastic"))}


def _refused(fname, pname):
    if fname == "KF":
        return pname not in LINEAR
    if fname == "Grid":
        return pname not in SCALAR
    return fname in {"EKF", "EKF (B at previous estimate)", "UKF", "GPFF"} and pname == "StochasticVolatility()"


@pytest.mark.parametrize("pname", PRESETS)
def test_every_filter_with_defaults_runs_on_every_shipped_preset(pname):
    model = PRESETS[pname]()
    sim = model.simulate(50, 4, np.random.default_rng(5))
    for fname, make in FILTERS.items():
        if _refused(fname, pname):
            with pytest.raises(ModelContractError):
                make(model)
            continue
        res = make(model).filter(sim.y, np.random.default_rng(6))
        assert res.x.shape == (4, 50, model.dim_x), fname
        assert np.all(np.isfinite(res.x)), (fname, pname)
        assert res.diagnostics.get("n_diverged", 0) == 0, (fname, pname)


# ----------------------------------------------------------------------------- runs = 0
@pytest.mark.parametrize("make", [KalmanFilter, ExtendedKalmanFilter, UnscentedKalmanFilter,
                                  lambda m: GaussianParticleFlowFilter(m, 10),
                                  lambda m: EvolutionSamplingParticleFilter(m, 10),
                                  lambda m: BootstrapParticleFilter(m, 10)])
def test_zero_runs_is_a_clear_error(make):
    m = CWPA.zhang2016()
    with pytest.raises(ValueError, match=r"y holds no runs \(shape \(0, 5, 2\)\)"):
        make(m).filter(np.zeros((0, 5, 2)), np.random.default_rng(0))


# ----------------------------------------------------------------------------- rng
@pytest.mark.parametrize("rng", [None, 0, np.random.RandomState(0)])
def test_resample_refuses_non_generator_rng(rng):
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        resample(np.ones((2, 5)), rng)


@pytest.mark.parametrize("rng", [None, 0, np.random.RandomState(0)])
def test_simulate_refuses_non_generator_rng(rng):
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        UNGM().simulate(5, 1, rng=rng)


# ----------------------------------------------------------------------------- y shapes
@pytest.mark.parametrize("make", [ExtendedKalmanFilter, UnscentedKalmanFilter, GridFilter,
                                  lambda m: GaussianParticleFlowFilter(m, 10),
                                  lambda m: BootstrapParticleFilter(m, 10)])
def test_2d_y_for_scalar_measurements_is_refused_as_ambiguous(make):
    m = UNGM.zhang2016()
    f = make(m)
    with pytest.raises(ValueError, match=r"y of shape \(5, 1\) is ambiguous .*dim_y = 1.*\(runs, T\) or \(T, dim_y\)"):
        f.filter(np.zeros((5, 1)), np.random.default_rng(0))
    # the unambiguous spellings of the same data are accepted and agree
    a = f.filter(np.zeros(5), np.random.default_rng(0))
    b = f.filter(np.zeros((1, 5, 1)), np.random.default_rng(0))
    assert a.x.shape == b.x.shape == (1, 5, 1)
    np.testing.assert_array_equal(a.x, b.x)


def test_2d_y_is_one_run_when_dim_y_exceeds_one():
    m = CWPA.zhang2016()
    sim = m.simulate(8, 2, np.random.default_rng(0))
    np.testing.assert_array_equal(KalmanFilter(m).filter(sim.y[1]).x[0], KalmanFilter(m).filter(sim.y).x[1])


# ----------------------------------------------------------------------------- model parameters
@pytest.mark.parametrize("make, msg", [
    (lambda: UNGM(alpha=np.nan), "alpha must be finite"),
    (lambda: UNGM(beta=np.inf), "beta must be finite"),
    (lambda: UNGM(omega="x"), "omega must be a real number"),
    (lambda: UNGM(time_offset=0.5), "time_offset must be an integer"),
    (lambda: LinearGaussianModel([[np.nan]], [[1.0]], 1.0, 1.0, [0.0]), "F contains NaN"),
    (lambda: LinearGaussianModel([[1.0]], [[np.nan]], 1.0, 1.0, [0.0]), "H contains NaN"),
    (lambda: BearingsOnly(sensors=(1, 2, 3)), r"sensors must have shape \(n, 2\), got shape \(1, 3\)"),
    (lambda: BearingsOnly(sensors=[[0.0, np.nan]]), "sensors contains NaN"),
    (lambda: BearingsOnly(dt=-0.1), "dt must be positive"),
    (lambda: CWPA(dt=np.nan), "dt must be finite"),
    (lambda: CWPA(qc=-1.0), "qc must be >= 0"),
    (lambda: StochasticVolatility(sigma=0.0), "sigma must be positive"),
])
def test_bad_model_parameters_are_refused(make, msg):
    with pytest.raises((ValueError, TypeError), match=msg):
        make()


def test_bot_with_one_or_three_sensors_is_fine():
    assert BearingsOnly(sensors=(1, 2)).dim_y == 1
    assert BearingsOnly(sensors=[(1, 2), (3, 4), (5, -6)]).dim_y == 3


# ----------------------------------------------------------------------------- mc_summary
def test_mc_summary_refuses_nan_unless_told():
    with pytest.raises(ValueError, match="1 NaN of 3"):
        mc_summary([1.0, np.nan, 2.0])
    s = mc_summary([1.0, np.nan, 2.0], nan_policy="omit")
    assert s.mean == 1.5 and s.n == 2
    with pytest.raises(ValueError, match="infinite"):
        mc_summary([1.0, np.inf])
    with pytest.raises(ValueError, match="nan_policy"):
        mc_summary([1.0], nan_policy="propagate")
    with pytest.raises(ValueError, match="no values"):
        mc_summary([np.nan], nan_policy="omit")
