"""The model contract (issue 8): which model capabilities each filter uses, and a clear
ModelContractError at construction when a model lacks one -- instead of running on the
placeholder h and R of a model whose measurement is not y = h(x) + v."""
from __future__ import annotations

import numpy as np
import pytest

from pfrepro.filters import (BootstrapParticleFilter, CMSParticleFilter, ExtendedKalmanFilter,
                             GaussianParticleFlowFilter, GridFilter, KalmanFilter, UnscentedKalmanFilter)
from pfrepro.filters.ekf_variants import PreviousEstimateJacobianEKF
from pfrepro.models import (CWPA, UNGM, LinearGaussianModel, ModelContractError, StateSpaceModel,
                            StochasticVolatility, has_capability, missing_capabilities)
from pfrepro.montecarlo import filter_streams, truth_streams


@pytest.fixture(scope="module")
def sv():
    return StochasticVolatility(phi=0.95, sigma=0.3, beta=0.7)


def test_error_is_a_type_error_naming_filter_model_and_capability(sv):
    assert issubclass(ModelContractError, TypeError)
    with pytest.raises(ModelContractError) as e:
        ExtendedKalmanFilter(sv)
    msg = str(e.value)
    assert msg.startswith("ExtendedKalmanFilter needs a model with additive measurement noise y = h(x) + v")
    assert "jacobian_h" in msg and "StochasticVolatility has non-additive measurement noise" in msg


@pytest.mark.parametrize("F", [KalmanFilter, ExtendedKalmanFilter, PreviousEstimateJacobianEKF,
                               UnscentedKalmanFilter, GaussianParticleFlowFilter])
def test_gaussian_filters_refuse_non_additive_measurement(sv, F):
    """Before issue 8 these ran on the base class's placeholder h/R and returned the prior."""
    with pytest.raises(ModelContractError, match=f"{F.__name__} needs .*StochasticVolatility .*non-additive measurement noise"):
        F(sv)


def test_particle_and_grid_filters_accept_sv_and_agree(sv):
    """PF and CMS-PF use only sample_transition and log_likelihood; the grid filter only a scalar
    state, a transition density and log_likelihood. The grid posterior mean is exact (up to grid
    error): a large PF converges to it."""
    sim = sv.simulate(60, 3, truth_streams(11, 3))
    grid = GridFilter(sv, bounds=(-6.0, 6.0), n_grid=1201).filter(sim.y)
    assert np.all(np.isfinite(grid.x)) and grid.diagnostics["n_collapsed"] == 0
    pf = BootstrapParticleFilter(sv, 20_000).filter(sim.y, filter_streams(11, "PF", 3))
    z = (pf.x - grid.x) / np.sqrt(grid.P[..., 0])
    assert np.sqrt(np.mean(z**2)) < 0.05
    cms = CMSParticleFilter(sv, 200).filter(sim.y, np.random.default_rng(11))
    assert np.all(np.isfinite(cms.x))
    # the measurement carries information: the posterior differs from the prior
    assert np.max(np.abs(grid.x[..., 0])) > 0.3


def test_sv_likelihood_and_simulation():
    """log p(y | x) is the N(0, beta^2 e^x) density; y | x has that variance."""
    m = StochasticVolatility(phi=0.9, sigma=0.4, beta=0.5)
    x = np.array([[[-1.0], [0.0], [0.7]]])
    y = np.array([[0.3]])
    var = 0.25 * np.exp(x[..., 0])
    np.testing.assert_allclose(m.log_likelihood(y, x), -0.5 * np.log(2 * np.pi * var) - 0.5 * 0.09 / var, rtol=1e-13)
    xs = np.full((200_000, 1), 0.7)
    ys = m.sample_measurement(xs, np.random.default_rng(3))
    assert abs(ys.var() / (0.25 * np.exp(0.7)) - 1) < 0.02
    assert not has_capability(m, "additive_measurement") and has_capability(m, "likelihood")


def test_capabilities_are_detected_without_calling_the_methods():
    calls = []

    class Spy(StateSpaceModel):
        def __init__(self):
            super().__init__(1, 1, 1.0, 1.0, [0.0], [0.0], 1.0)

        def f(self, x, k):
            calls.append("f")
            return x

        def h(self, x):
            calls.append("h")
            return x

    m = Spy()
    UnscentedKalmanFilter(m)
    BootstrapParticleFilter(m, 10)
    GridFilter(m, bounds=(-10, 10), n_grid=201)
    assert calls == []
    with pytest.raises(ModelContractError, match="Spy does not implement jacobian_h; it does not implement jacobian_f"):
        ExtendedKalmanFilter(m)
    assert missing_capabilities(m, ("f", "h", "jacobian_f", "linear")) == ["jacobian_f", "linear"]


def test_model_without_h_is_refused_with_the_right_reason():
    class NoH(StateSpaceModel):
        def __init__(self):
            super().__init__(1, 1, 1.0, 1.0, [0.0], [0.0], 1.0)

        def f(self, x, k):
            return x

    with pytest.raises(ModelContractError, match="NoH does not implement h"):
        UnscentedKalmanFilter(NoH())
    with pytest.raises(ModelContractError, match="NoH has no log_likelihood"):
        BootstrapParticleFilter(NoH(), 10)


def test_model_without_any_transition_is_refused_by_pf():
    class Nothing(StateSpaceModel):
        def __init__(self):
            super().__init__(1, 1, 1.0, 1.0, [0.0], [0.0], 1.0)

        def h(self, x):
            return x

    with pytest.raises(ModelContractError, match="BootstrapParticleFilter needs .*transition sampler"):
        BootstrapParticleFilter(Nothing(), 10)


def test_custom_transition_sampler_is_enough_for_a_pf():
    """A model that overrides sample_transition (no f) runs in the PF, is refused by the UKF."""

    class Jumpy(StateSpaceModel):
        def __init__(self):
            super().__init__(1, 1, 1.0, 1.0, [0.0], [0.0], 1.0)

        def sample_transition(self, x, k, rng):
            return x + rng.standard_t(3, x.shape)

        def h(self, x):
            return x

    m = Jumpy()
    sim = m.simulate(10, 2, np.random.default_rng(0))
    assert np.all(np.isfinite(BootstrapParticleFilter(m, 50).filter(sim.y, np.random.default_rng(1)).x))
    with pytest.raises(ModelContractError, match="Jumpy does not implement f"):
        UnscentedKalmanFilter(m)


def test_grid_filter_refuses_vector_state_and_singular_q():
    with pytest.raises(ModelContractError, match=r"GridFilter needs a model with a scalar state.*CWPA has dim_x = 6"):
        GridFilter(CWPA.zhang2016())
    with pytest.raises(ModelContractError, match="singular process-noise covariance Q"):
        GridFilter(UNGM(Q=0.0))


def test_gpff_exact_integrator_needs_h_matrix():
    with pytest.raises(ModelContractError, match=r"integrator='exact'\) needs a model with a measurement matrix H; UNGM"):
        GaussianParticleFlowFilter(UNGM.zhang2016(), 10, integrator="exact")


def test_kf_refuses_nonlinear_model_and_accepts_linear():
    with pytest.raises(ModelContractError, match="KalmanFilter needs .*F and H.*UNGM has no matrices"):
        KalmanFilter(UNGM())
    KalmanFilter(LinearGaussianModel([[1.0]], [[1.0]], 1.0, 1.0, [0.0]))


def test_simulate_uses_the_sample_measurement_hook():
    class Poisson(StochasticVolatility):
        """Counts with log-intensity x: only sample_measurement and log_likelihood change."""

        def sample_measurement(self, x, rng):
            return rng.poisson(np.exp(x)).astype(float)

    sim = Poisson().simulate(50, 2, np.random.default_rng(0))
    assert np.all(sim.y == np.round(sim.y)) and np.all(sim.y >= 0)


def test_documented_requirements_are_the_ones_checked():
    """The contract table (models/base.py docstring, CONTRIBUTING.md) against the code."""
    from pfrepro.filters import EvolutionSamplingParticleFilter
    from pfrepro.models import CAPABILITIES

    expected = {
        KalmanFilter: {"linear", "additive_measurement"},
        ExtendedKalmanFilter: {"f", "jacobian_f", "jacobian_h", "additive_measurement"},
        PreviousEstimateJacobianEKF: {"f", "jacobian_f", "jacobian_h", "additive_measurement"},
        UnscentedKalmanFilter: {"f", "additive_measurement"},
        GaussianParticleFlowFilter: {"transition_sampler", "additive_measurement"},
        BootstrapParticleFilter: {"transition_sampler", "likelihood"},
        CMSParticleFilter: {"transition_sampler", "likelihood"},
        GridFilter: {"scalar_state", "transition_density", "likelihood"},
    }
    for F, req in expected.items():
        assert set(F.model_requirements) == req, F.__name__
        assert set(F.model_requirements) <= set(CAPABILITIES)
    # ESPF evaluates N(x; f, Q): at least the generic needs (its own check is in espf.py)
    assert {"transition_sampler", "likelihood"} <= set(EvolutionSamplingParticleFilter.model_requirements) \
        or "transition_density" in EvolutionSamplingParticleFilter.model_requirements


# -- output shapes, checked at the first call (issue 34, item 6) ----------------------------------
class _Scalar(StateSpaceModel):
    """UNGM-like scalar model; ``bad`` names the one method that returns a wrong shape."""

    def __init__(self, bad=None):
        super().__init__(1, 1, 1.0, 1.0, [0.1], [0.0], 5.0)
        self.bad = bad

    def f(self, x, k):
        out = 0.5 * x + 25 * x / (1 + x**2) + 8 * np.cos(1.2 * k)
        return np.atleast_1d(out.mean()) if self.bad == "f" else out    # one value for the whole cloud

    def jacobian_f(self, x, k):
        J = (0.5 + 25 * (1 - x**2) / (1 + x**2) ** 2)[..., None]
        return J[..., 0] if self.bad == "jacobian_f" else J

    def h(self, x):
        return np.concatenate([x, x], axis=-1) / 20 if self.bad == "h" else x**2 / 20

    def jacobian_h(self, x):
        return (x / 10)[..., None]

    def log_likelihood(self, y, x):
        ll = super().log_likelihood(y, x)
        return ll.sum(axis=-1) if self.bad == "log_likelihood" else ll


def test_f_returning_one_value_for_the_whole_cloud_is_refused_at_the_first_call():
    """Before: simulate and every filter ran silently on the broadcast value (a PF off by ~1)."""
    # (simulate may hand the model (runs, dim_x) or (runs, 1, dim_x): either is one state per run)
    with pytest.raises(ModelContractError, match=r"_Scalar\.f returned shape \(1,\) for x of shape \(3, (1, )?1\); "
                                                 r"the model contract expects \(3, (1, )?1\) \(x\.shape\)"):
        _Scalar("f").simulate(5, 3, np.random.default_rng(0))
    y = _Scalar().simulate(5, 3, np.random.default_rng(0)).y
    with pytest.raises(ModelContractError, match=r"_Scalar\.f returned shape \(1,\) for x of shape \(3, 50, 1\)"):
        BootstrapParticleFilter(_Scalar("f"), 50).filter(y, filter_streams(1, "PF", 3))


@pytest.mark.parametrize("bad, where, expect", [
    ("h", "simulate", r"_Scalar\.h returned shape \(3, (1, )?2\) for x of shape \(3, (1, )?1\); the model contract "
                      r"expects \(3, (1, )?1\)"),
    ("jacobian_f", "EKF", r"_Scalar\.jacobian_f returned shape \(3, 1\) for x of shape \(3, 1\); .* "
                          r"expects \(3, 1, 1\) \(x\.shape\[:-1\] \+ \(dim_x, dim_x\)\)"),
    ("log_likelihood", "PF", r"_Scalar\.log_likelihood returned shape \(3,\) for x of shape \(3, 40, 1\); .* "
                             r"expects \(3, 40\)"),
])
def test_wrong_shapes_name_the_method_and_the_expected_shape(bad, where, expect):
    """Before: a numpy broadcast error, a misleading LinAlgError, or silently wrong numbers."""
    y = _Scalar().simulate(5, 3, np.random.default_rng(0)).y
    m = _Scalar(bad)
    with pytest.raises(ModelContractError, match=expect):
        if where == "simulate":
            m.simulate(5, 3, np.random.default_rng(0))
        elif where == "EKF":
            ExtendedKalmanFilter(m).filter(y)
        else:
            BootstrapParticleFilter(m, 40).filter(y, filter_streams(1, "PF", 3))


def test_good_models_pass_and_are_checked_once_per_kind_of_input():
    m = _Scalar()
    sim = m.simulate(4, 2, np.random.default_rng(0))
    assert {key[0] for key in m._contract_seen} >= {"f", "h"}   # simulate's states checked
    ExtendedKalmanFilter(m).filter(sim.y)
    UnscentedKalmanFilter(m).filter(sim.y)                     # sigma points: 3 axes
    BootstrapParticleFilter(m, 20).filter(sim.y, filter_streams(1, "PF", 2))
    assert {("f", 2), ("f", 3), ("h", 3), ("jacobian_f", 2), ("log_likelihood", 3)} <= m._contract_seen
    # a shared Jacobian (one matrix for every state) is allowed: the linear models return F
    lin = LinearGaussianModel([[1.0, 0.1], [0.0, 1.0]], [[1.0, 0.0]], np.eye(2) * 0.01, 1.0, [0.0, 1.0])
    ExtendedKalmanFilter(lin).filter(lin.simulate(5, 2, np.random.default_rng(1)).y)
    # the wrapper keeps the method's name and source for the reader
    import inspect
    assert _Scalar.f.__name__ == "f" and "one value for the whole cloud" in inspect.getsource(_Scalar.f)
