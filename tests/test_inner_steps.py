"""Inner steps of the existing filters, pinned by hand-computed cases and invariants (issue 14).

End-to-end accuracy tests cannot see a wrong inner formula whose effect is below the Monte
Carlo noise (or that even improves the result). Each test here checks ONE step against a
number computed by hand (written out in the test) or against an invariant the step must
keep, with model stubs whose dynamics and likelihood the test controls:

* bootstrap PF, ESS-threshold branch: which weights a resampled / non-resampled run carries
  into the next step (checked through the next step's estimate and log evidence);
* the flow integrator: one Euler / midpoint / RK4 step on a field that depends on lambda,
  on uniform and exponential grids (value and the lambdas at which the field is evaluated);
* GPFF's particle covariance, eq (52): the paper's 1/(N-1) normalisation;
* ESPF's Metropolis-Hastings move: with a flat likelihood it leaves the transition prior
  invariant (statistical test, tolerances from the sample size);
* CMS-PF's weight recursion, eq (3) / Step 2.5: w_k ∝ w_{k-1} p(z_k | x_k) with non-uniform
  w_{k-1}, for predicted and for map particles.

Each test was checked against the wrong formula once (see the issue-14 note).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfrepro import flow
from pfrepro.filters import BootstrapParticleFilter, CMSParticleFilter
from pfrepro.filters import espf as espf_module
from pfrepro.chaos import ChaosCarrier
from pfrepro.filters.cmspf import OracleCMSParticleFilter, map_particles, select_top_likelihood
from pfrepro.filters.espf import EvolutionSamplingParticleFilter
from pfrepro.filters.gpff import GaussianParticleFlowFilter, particle_moments
from pfrepro.filters.particle import WeightCollapseWarning
from pfrepro.models import UNGM, LinearGaussianModel


# ------------------------------------------------------------------------------ stubs
class ScriptedModel:
    """Model stub: the transition puts particle i at ``positions[i]`` whatever its past, and
    the log-likelihood at step k is the scripted table ``loglik[k - 1]`` (runs, N).

    The step index is read from the measurement (y_k = k), so the stub has no hidden
    state. Because the transition forgets the ancestors, the weighted estimate at step k is
    sum_i w_{k-1}^i l_k^i c_i / sum_i w_{k-1}^i l_k^i with w_{k-1} the weights the filter
    carried out of step k-1: uniform after resampling, the normalised weights otherwise.
    """

    dim_x = 1
    dim_y = 1

    def __init__(self, positions, loglik):
        self.positions = np.asarray(positions, float)      # (N,)
        self.loglik = np.asarray(loglik, float)            # (T, runs, N)
        self.m0 = np.zeros(1)
        self.P0 = np.eye(1)

    def sample_transition(self, x, k, rng):
        return np.broadcast_to(self.positions[:, None], x.shape).copy()

    def log_likelihood(self, y, x):
        k = int(round(float(y[0, 0])))
        assert np.all(y[:, 0] == k), "stub: every run must carry y_k = k"
        return self.loglik[k - 1]


def scripted_measurements(runs, T):
    return np.broadcast_to(np.arange(1.0, T + 1)[None, :, None], (runs, T, 1)).copy()


# ------------------------------------------------------------------------------ 1. PF
# positions c_i and scripted likelihoods for two runs and two steps
C = np.array([1.0, 2.0, 5.0, 10.0])
W1 = np.array([[0.97, 0.01, 0.01, 0.01],        # run 0: ESS = 1/0.9412 = 1.06 < 0.5 N -> resample
               [0.40, 0.30, 0.20, 0.10]])       # run 1: ESS = 1/0.30 = 3.33 >= 0.5 N -> keep
L2 = np.array([1.0, 2.0, 3.0, 4.0])             # step-2 likelihoods, both runs


def _pf_on_script(ess_threshold):
    loglik = np.stack([np.log(W1), np.log(np.broadcast_to(L2, (2, 4)))])   # (T=2, runs=2, N=4)
    model = ScriptedModel(C, loglik)
    pf = BootstrapParticleFilter(model, 4, ess_threshold=ess_threshold)
    return pf.filter(scripted_measurements(2, 2), rng=np.random.default_rng(0))


def _step2_estimate(carried):
    """sum_i w_{k-1}^i l_2^i c_i / sum_i w_{k-1}^i l_2^i (by hand, for a (4,) carried weight)."""
    v = carried * L2
    return float(v @ C / v.sum())


# by hand: uniform carry -> (1*1 + 2*2 + 3*5 + 4*10) / 10 = 60/10 = 6.0
#          carry W1[1]   -> (.4*1*1 + .3*2*2 + .2*3*5 + .1*4*10) / (.4 + .6 + .6 + .4) = 8.6/2 = 4.3
#          carry W1[0]   -> (.97 + .04 + .15 + .4) / (.97 + .02 + .03 + .04) = 1.56/1.06
UNIFORM_CARRY, RUN1_CARRY, RUN0_CARRY = 6.0, 4.3, 1.56 / 1.06


def test_hand_numbers_of_the_pf_script():
    assert _step2_estimate(np.full(4, 0.25)) == pytest.approx(UNIFORM_CARRY)
    assert _step2_estimate(W1[1]) == pytest.approx(RUN1_CARRY)
    assert _step2_estimate(W1[0]) == pytest.approx(RUN0_CARRY)


def test_pf_partial_resampling_carries_uniform_and_kept_weights():
    """ESS threshold 0.5, two runs: only run 0 resamples at step 1. Run 0 must enter step 2
    with equal weights, run 1 with its own step-1 weights."""
    res = _pf_on_script(0.5)
    d = res.diagnostics
    np.testing.assert_allclose(d["ess"][:, 0], [1 / np.sum(W1[0] ** 2), 1 / np.sum(W1[1] ** 2)])
    np.testing.assert_array_equal(d["resampled"][:, 0], [True, False])
    # step 1: the weighted mean with weights W1 (the scripted likelihoods are normalised)
    np.testing.assert_allclose(res.x[:, 0, 0], W1 @ C)
    # step 2: the weights carried into it
    np.testing.assert_allclose(res.x[:, 1, 0], [UNIFORM_CARRY, RUN1_CARRY], rtol=1e-12)
    # log evidence: log sum_i w1_i (step 1, prior weights 1/N) + log sum_i carried_i l2_i
    ev = np.log(W1.sum(axis=1) / 4) + np.log([np.mean(L2), W1[1] @ L2])
    np.testing.assert_allclose(d["log_evidence"], ev, rtol=1e-12)


@pytest.mark.parametrize("ess_threshold, carried", [
    (None, [UNIFORM_CARRY, UNIFORM_CARRY]),     # every run resamples (the all-runs branch)
    (0.0, [RUN0_CARRY, RUN1_CARRY]),            # no run resamples (SIS)
])
def test_pf_all_or_no_runs_resampling_carry(ess_threshold, carried):
    res = _pf_on_script(ess_threshold)
    np.testing.assert_array_equal(res.diagnostics["resampled"][:, 0], ess_threshold is None)
    np.testing.assert_allclose(res.x[:, 1, 0], carried, rtol=1e-12)


class ScriptedModel2D(ScriptedModel):
    """2-D variant: step 1 puts particle i at ``positions[i]`` (N, 2); later steps keep the
    particles where resampling left them (identity transition), so the next step's estimate
    shows which particles a run resampled."""

    dim_x = 2

    def __init__(self, positions, loglik):
        super().__init__(positions, loglik)
        self.m0, self.P0 = np.zeros(2), np.eye(2)

    def sample_transition(self, x, k, rng):
        if k == 1:
            return np.broadcast_to(self.positions, x.shape).copy()
        return np.array(x)


C2 = np.array([[1.0, -1.0], [3.0, 2.0], [10.0, 7.0], [-4.0, 5.0]])


def _pf2d(runs, ess_threshold, resampling="systematic"):
    """Step 1: run 0 (and every run but the last) has weights (1/2, 1/2, 0, 0) -> ESS 2;
    the last run W1[1] -> ESS 3.33. Step 2: flat likelihood, so its estimate is the plain mean
    of the particles carried out of step 1 (resampled or not) under the carried weights."""
    w1 = np.tile([0.5, 0.5, 0.0, 0.0], (runs, 1))
    w1[-1] = W1[1]
    with np.errstate(divide="ignore"):
        loglik = np.stack([np.log(w1), np.zeros((runs, 4))])
    pf = BootstrapParticleFilter(ScriptedModel2D(C2, loglik), 4, ess_threshold=ess_threshold,
                                 resampling=resampling)
    return pf.filter(scripted_measurements(runs, 2), rng=np.random.default_rng(5))


@pytest.mark.filterwarnings("error")  # zero weights: log(0) = -inf is expected, not a RuntimeWarning
def test_pf_partial_resampling_moves_the_resampled_runs_particles_2d():
    """Threshold 0.6 (2.4 particles): the (1/2, 1/2, 0, 0) runs resample, the last run keeps its
    particles and weights. Systematic resampling of (1/2, 1/2, 0, 0) gives exactly two copies of
    particles 0 and 1, so their step-2 estimate is (c_0 + c_1) / 2 = (2, 0.5); the last run's is
    W1[1] @ C2 = (0.4 + 0.9 + 2 - 0.4, -0.4 + 0.6 + 1.4 + 0.5) = (2.9, 2.1)."""
    res = _pf2d(3, 0.6)
    np.testing.assert_array_equal(res.diagnostics["resampled"][:, 0], [True, True, False])
    np.testing.assert_allclose(res.x[:2, 1], [[2.0, 0.5], [2.0, 0.5]], rtol=1e-12)
    np.testing.assert_allclose(res.x[2, 1], [2.9, 2.1], rtol=1e-12)
    # the step-1 estimates are the weighted means before resampling
    np.testing.assert_allclose(res.x[:, 0], [[2.0, 0.5], [2.0, 0.5], [2.9, 2.1]], rtol=1e-12)


@pytest.mark.filterwarnings("error")
def test_pf_without_resampling_carries_zero_weights_silently():
    """Threshold 0: nobody resamples; zero weights are carried as log 0 = -inf without a warning,
    and with a flat step-2 likelihood the step-2 estimate equals the step-1 weighted mean."""
    res = _pf2d(3, 0.0)
    assert not res.diagnostics["resampled"].any()
    np.testing.assert_allclose(res.x[:, 1], res.x[:, 0], rtol=1e-12)
    np.testing.assert_allclose(res.x[:, 1], [[2.0, 0.5], [2.0, 0.5], [2.9, 2.1]], rtol=1e-12)


@pytest.mark.parametrize("ess_threshold", [None, 0.6])
def test_pf_uses_the_requested_resampling_scheme(ess_threshold):
    """Systematic resampling of (1/2, 1/2, 0, 0) always gives counts (2, 2, 0, 0); multinomial
    gives Binomial(4, 1/2) counts, i.e. a step-2 estimate other than (2, 0.5) with
    probability 10/16 per run: over 30 runs all equal has probability (6/16)^30 = 2e-13."""
    runs = 31
    sysm = _pf2d(runs, ess_threshold, "systematic").x[:-1, 1]
    mult = _pf2d(runs, ess_threshold, "multinomial").x[:-1, 1]
    np.testing.assert_allclose(sysm, np.broadcast_to([2.0, 0.5], sysm.shape), rtol=1e-12)
    assert np.sum(np.any(np.abs(mult - [2.0, 0.5]) > 1e-9, axis=1)) >= 5
    # each multinomial estimate is the mean of 4 copies of c_0 / c_1: (j c_0 + (4 - j) c_1) / 4
    j = (mult[:, 0] - 3.0) / -0.5
    np.testing.assert_allclose(j, np.round(j), atol=1e-9)


def test_pf_resamples_only_strictly_below_the_threshold():
    """Flat likelihood: the weights stay exactly 1/4, ESS = 1 / (4/16) = 4 = 1.0 * N exactly;
    the rule is ESS < threshold * N, so threshold 1.0 never resamples."""
    loglik = np.zeros((3, 2, 4))
    pf = BootstrapParticleFilter(ScriptedModel(C, loglik), 4, ess_threshold=1.0)
    d = pf.filter(scripted_measurements(2, 3), rng=np.random.default_rng(0)).diagnostics
    np.testing.assert_array_equal(d["ess"], 4.0)
    assert not d["resampled"].any()


def test_pf_diagnostics_types_and_optional_covariance():
    res = _pf_on_script(0.5)
    assert res.P is None                                   # return_cov=False: no covariance
    for key in ("resampled", "collapsed"):
        assert res.diagnostics[key].dtype == bool, key
    loglik = np.stack([np.log(W1), np.log(np.broadcast_to(L2, (2, 4)))])
    res = BootstrapParticleFilter(ScriptedModel(C, loglik), 4, ess_threshold=0.0, return_cov=True).filter(
        scripted_measurements(2, 2), rng=np.random.default_rng(0))
    # weighted covariance of the step-1 particles under W1: sum_i w_i (c_i - mean)^2
    np.testing.assert_allclose(res.P[:, 0, 0, 0], [W1[r] @ (C - W1[r] @ C) ** 2 for r in range(2)])


class _NaNModel(ScriptedModel):
    def sample_transition(self, x, k, rng):
        return np.full(x.shape, np.nan) if k == 2 else super().sample_transition(x, k, rng)


def test_pf_divergence_error_names_the_step():
    from pfrepro.filters.base import FilterDivergenceError

    model = _NaNModel(C, np.zeros((3, 1, 4)))
    # the NaN is drawn by the transition to x_2, so step 2 is the one named
    with pytest.raises(FilterDivergenceError, match="non-finite at step 2"):
        BootstrapParticleFilter(model, 4).filter(scripted_measurements(1, 3), rng=np.random.default_rng(0))


# ------------------------------------------------------------------------------ 2. flow integrator
def lam_field(calls=None):
    """f(x, lambda) = (1 + 2 lambda) x + 3 lambda^2: depends on lambda in both terms, so a step
    taken at lambda_j differs from one taken at lambda_{j+1}; records the lambdas it is called at."""
    def field(x, lam):
        if calls is not None:
            calls.append(float(lam))
        return (1.0 + 2.0 * lam) * x + 3.0 * lam ** 2
    return field


def _f(x, lam):  # the same field, written out again for the hand computations
    return (1.0 + 2.0 * lam) * x + 3.0 * lam ** 2


@pytest.mark.parametrize("kind", ["uniform", "exponential"])
@pytest.mark.parametrize("j", [0, 3])
def test_one_integrator_step_by_hand(kind, j):
    grid = flow.lambda_schedule(5, kind, ratio=1.5)
    l0, l1 = grid[j], grid[j + 1]
    h = l1 - l0
    x0 = np.array([[[0.7], [-1.3]], [[2.0], [0.1]]])     # (runs, N, d) = (2, 2, 1)
    # Euler: x + h f(x, l0)
    euler = x0 + h * ((1 + 2 * l0) * x0 + 3 * l0 ** 2)
    # midpoint: x + h f(x + h/2 f(x, l0), l0 + h/2)
    lm = l0 + h / 2
    xm = x0 + h / 2 * ((1 + 2 * l0) * x0 + 3 * l0 ** 2)
    midpoint = x0 + h * ((1 + 2 * lm) * xm + 3 * lm ** 2)
    # classical RK4
    k1 = (1 + 2 * l0) * x0 + 3 * l0 ** 2
    k2 = (1 + 2 * lm) * (x0 + h / 2 * k1) + 3 * lm ** 2
    k3 = (1 + 2 * lm) * (x0 + h / 2 * k2) + 3 * lm ** 2
    k4 = (1 + 2 * l1) * (x0 + h * k3) + 3 * l1 ** 2
    rk4 = x0 + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    expected_calls = {"euler": [l0], "midpoint": [l0, lm], "rk4": [l0, lm, lm, l1]}
    for method, want in (("euler", euler), ("midpoint", midpoint), ("rk4", rk4)):
        calls = []
        got = flow.integrate_flow(x0, lam_field(calls), grid[j:j + 2], method)
        np.testing.assert_allclose(got, want, rtol=1e-14, atol=1e-14, err_msg=method)
        np.testing.assert_allclose(calls, expected_calls[method], rtol=0, atol=1e-15, err_msg=method)
    # the test can tell the lambdas apart: the step taken at l1 is a different number
    assert np.max(np.abs(euler - (x0 + h * _f(x0, l1)))) > 1e-3


@pytest.mark.parametrize("kind", ["uniform", "exponential"])
@pytest.mark.parametrize("method", ["euler", "midpoint", "rk4"])
def test_integration_over_a_grid_chains_the_steps(kind, method):
    """The whole grid = the one-step map applied on consecutive pairs of lambdas, in order,
    and the input is not modified in place."""
    grid = flow.lambda_schedule(4, kind, ratio=2.0)
    x0 = np.array([[0.5], [-2.0]])
    x0_copy = x0.copy()
    calls = []
    got = flow.integrate_flow(x0, lam_field(calls), grid, method)
    x = x0_copy.copy()
    for a, b in zip(grid[:-1], grid[1:]):
        x = flow.integrate_flow(x, lam_field(), np.array([a, b]), method)
    np.testing.assert_allclose(got, x, rtol=1e-14)
    np.testing.assert_array_equal(x0, x0_copy)
    per_step = {"euler": 1, "midpoint": 2, "rk4": 4}[method]
    assert len(calls) == per_step * (len(grid) - 1)
    np.testing.assert_allclose(calls[::per_step], grid[:-1], atol=1e-15)   # each step starts at lambda_j


def test_euler_two_exponential_steps_by_hand():
    """Exponential grid, n = 2, ratio 3: lambda = 0, 1/4, 1. From x = 1:
    step 1 at lambda 0: x = 1 + 1/4 * (1*1 + 0) = 1.25;
    step 2 at lambda 1/4: x = 1.25 + 3/4 * (1.5 * 1.25 + 3/16) = 1.25 + 0.75 * 2.0625 = 2.796875."""
    grid = flow.lambda_schedule(2, "exponential", ratio=3.0)
    np.testing.assert_allclose(grid, [0.0, 0.25, 1.0])
    got = flow.integrate_flow(np.array([1.0]), lam_field(), grid, "euler")
    assert got[0] == pytest.approx(2.796875, rel=1e-15)


# ------------------------------------------------------------------------------ 3. GPFF eq (52)
def test_particle_covariance_is_eq52_by_hand():
    """Eq (52) prints P = 1/(N-1) sum_i (x_i - x_hat)(x_i - x_hat)^T with x_hat the sample mean (51).

    By hand, N = 4 particles in 2-D: x = (0, 1), (1, 0), (2, 4), (5, 3);
    mean (2, 2); deviations (-2, -1), (-1, -2), (0, 2), (3, 1);
    sums of products: xx = 4 + 1 + 0 + 9 = 14, yy = 1 + 4 + 4 + 1 = 10, xy = 2 + 2 + 0 + 3 = 7;
    divided by N - 1 = 3."""
    x = np.array([[[0.0, 1.0], [1.0, 0.0], [2.0, 4.0], [5.0, 3.0]]])
    m, P = particle_moments(x)
    np.testing.assert_allclose(m, [[2.0, 2.0]])
    np.testing.assert_allclose(P, [[[14 / 3, 7 / 3], [7 / 3, 10 / 3]]], rtol=1e-15)


def test_particle_covariance_matches_np_cov_per_run():
    rng = np.random.default_rng(52)
    x = rng.standard_normal((3, 7, 3)) @ np.array([[1.0, 0.5, 0.0], [0.0, 2.0, 0.3], [0.0, 0.0, 0.1]])
    m, P = particle_moments(x)
    for r in range(3):
        np.testing.assert_allclose(m[r], x[r].mean(axis=0), rtol=1e-14)
        np.testing.assert_allclose(P[r], np.cov(x[r], rowvar=False, ddof=1), rtol=1e-12)


def test_gpff_uses_eq52_for_its_prior_statistics():
    """The filter's prior statistics (eqs 47-52) start from the eq-52 covariance: for a linear h
    the UT is exact, so Pxy = P H^T and Pyy = H P H^T with P = np.cov(ddof=1)."""
    H = np.array([[1.0, -0.5]])
    model = LinearGaussianModel(np.eye(2), H, np.eye(2), [[0.3]], [0.0, 0.0])
    gpff = GaussianParticleFlowFilter(model, n_particles=5)
    x = np.random.default_rng(3).standard_normal((2, 5, 2))
    m, P, y_hat, Pyy, Pxy = gpff.prior_statistics(x)
    for r in range(2):
        C = np.cov(x[r], rowvar=False, ddof=1)
        np.testing.assert_allclose(P[r], C, rtol=1e-12)
        np.testing.assert_allclose(Pxy[r], C @ H.T, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(Pyy[r], H @ C @ H.T, rtol=1e-10)
        np.testing.assert_allclose(y_hat[r], H @ x[r].mean(axis=0), rtol=1e-10, atol=1e-12)


def test_gpff_exact_update_by_hand():
    """integrator="exact", scalar model x -> y = x + v, R = 1, particles (0, 1, 2, 5): eq (52) gives
    m = 2, P = 14/3; the Kalman posterior for y = 4 has mean 2 + (14/3)/(17/3) * 2 = 62/17 and the
    exact flow map is x -> 62/17 + sqrt(R / (R + P)) (x - m) = 62/17 + sqrt(3/17) (x - 2)
    (increasing: the flow never mirrors the cloud); its sample variance is 14/17 = P R / (P + R)."""
    model = LinearGaussianModel([[1.0]], [[1.0]], [[1.0]], [[1.0]], [0.0])
    gpff = GaussianParticleFlowFilter(model, n_particles=4, integrator="exact")
    x = np.array([[[0.0], [1.0], [2.0], [5.0]]])
    moved = gpff.update(x, np.array([[4.0]]))
    np.testing.assert_allclose(moved[0, :, 0], 62 / 17 + np.sqrt(3 / 17) * (x[0, :, 0] - 2), rtol=1e-12)
    assert np.var(moved[0, :, 0], ddof=1) == pytest.approx(14 / 17, rel=1e-12)


class QuadraticMeasurement(LinearGaussianModel):
    """Scalar random walk measured through h(x) = x^2 / 20 (the UNGM's h), R = 0.5."""

    def __init__(self):
        super().__init__([[1.0]], [[1.0]], [[1.0]], [[0.5]], [0.0])

    def h(self, x):
        return x ** 2 / 20.0


def test_gpff_eq41_field_is_not_the_linearised_eq43_field():
    """field="eq43" replaces h(x) by its statistical linearisation, so its map is affine in x:
    equally spaced prior particles stay equally spaced (zero second differences). field="eq41"
    evaluates h at every particle, so for a quadratic h the map is not affine."""
    x = np.linspace(-1.0, 3.0, 9)[None, :, None]
    y = np.array([[2.0]])
    d2 = {}
    for field in ("eq41", "eq43"):
        moved = GaussianParticleFlowFilter(QuadraticMeasurement(), 9, field=field).update(x, y)[0, :, 0]
        d2[field] = np.max(np.abs(np.diff(moved, 2)))
        assert np.all(np.diff(moved) > 0)
    assert d2["eq43"] < 1e-12
    assert d2["eq41"] > 1e-3, d2


class WrappedLinear(LinearGaussianModel):
    """y = x + v measured as an angle: innovations wrapped to (-pi, pi] (like the BOT model)."""

    def residual_y(self, y, y_pred):
        from pfrepro.models.bot import wrap_angle

        return wrap_angle(y - y_pred)


def test_gpff_ut_deviations_use_the_models_residual():
    """Prior statistics (eqs 47-50) for particles m -+ 2 sqrt(2), m = 0.5 (eq 52: P = 16), with the
    UT alpha = 1, beta = 2, kappa = 0 in 1-D: lambda = 0, Wm = (0, 1/2, 1/2), Wc = (2, 1/2, 1/2),
    sigma points m, m + 4, m - 4; y_hat = m; wrapped deviations dy = (0, 4 - 2 pi, 2 pi - 4), so
    Pyy = (2 pi - 4)^2 and Pxy = 4 (4 - 2 pi) (16 and 16 without the wrap)."""
    model = WrappedLinear([[1.0]], [[1.0]], [[1.0]], [[0.5]], [0.0])
    gpff = GaussianParticleFlowFilter(model, n_particles=2)
    x = np.array([[[0.5 - 2 * np.sqrt(2)], [0.5 + 2 * np.sqrt(2)]]])
    m, P, y_hat, Pyy, Pxy = gpff.prior_statistics(x)
    np.testing.assert_allclose(P[0, 0, 0], 16.0, rtol=1e-12)
    np.testing.assert_allclose(y_hat[0], [0.5], rtol=1e-12)
    np.testing.assert_allclose(Pyy[0, 0, 0], (2 * np.pi - 4) ** 2, rtol=1e-12)
    np.testing.assert_allclose(Pxy[0, 0, 0], 4 * (4 - 2 * np.pi), rtol=1e-12)


@pytest.mark.parametrize("field", ["eq41", "eq43"])
def test_gpff_flow_innovations_use_the_models_residual(field):
    """With wrapped innovations a measurement y and y - 2 pi are the same angle, so the flow must
    move the particles identically (cloud around 0.3, y = 2.9: innovation 2.6 either way)."""
    model = WrappedLinear([[1.0]], [[1.0]], [[1.0]], [[0.5]], [0.0])
    gpff = GaussianParticleFlowFilter(model, n_particles=5, field=field)
    x = 0.3 + 0.1 * np.array([[[-2.0], [-1.0], [0.0], [1.0], [2.0]]])
    a = gpff.update(x, np.array([[2.9]]))
    b = gpff.update(x, np.array([[2.9 - 2 * np.pi]]))
    np.testing.assert_allclose(a, b, rtol=1e-10)
    assert np.all(a > x)                            # moved towards the measurement (+2.6)


def _linear_2d(Q=None):
    """2-D linear model with correlated prior and a 1 x 2 H, so the flow map is not symmetric."""
    F = np.array([[1.0, 0.1], [0.0, 1.0]])
    Q = np.array([[0.2, 0.05], [0.05, 0.1]]) if Q is None else Q
    return LinearGaussianModel(F, [[1.0, 0.5]], Q, [[0.3]], [0.0, 0.0],
                               P0=np.array([[2.0, 0.8], [0.8, 1.0]]))


def test_gpff_eq43_probe_map_matches_eq41_for_linear_h_in_2d():
    """For linear h the eq41 field (every particle stepped) and the eq43 field (d + 1 probes and
    an affine map) are the same flow; in 2-D with correlated P the map's matrix is not symmetric,
    so a transposed map would differ."""
    model = _linear_2d()
    rng = np.random.default_rng(7)
    x = rng.standard_normal((3, 40, 2)) @ np.array([[1.5, 0.0], [0.9, 0.6]]).T
    y = rng.standard_normal((3, 1))
    for integrator in ("euler", "rk4"):
        a = GaussianParticleFlowFilter(model, 40, field="eq41", integrator=integrator).update(x, y)
        b = GaussianParticleFlowFilter(model, 40, field="eq43", integrator=integrator).update(x, y)
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-10, err_msg=integrator)


@pytest.mark.parametrize("field", ["eq41", "eq43"])
def test_gpff_honours_the_integrator(field):
    """Against the exact affine map (linear model), 20 uniform steps: the error falls with the
    integrator's order (measured: Euler 0.51, midpoint 0.10, RK4 0.0012), so the integrator the
    filter was given is the one it uses (a filter that always used Euler would tie all three)."""
    model = _linear_2d()
    rng = np.random.default_rng(8)
    x = rng.standard_normal((2, 30, 2)) @ np.array([[1.5, 0.0], [0.9, 0.6]]).T
    y = np.array([[1.0], [-2.0]])
    exact = GaussianParticleFlowFilter(model, 30, integrator="exact").update(x, y)
    err = {i: np.max(np.abs(GaussianParticleFlowFilter(model, 30, field=field, integrator=i).update(x, y) - exact))
           for i in ("euler", "midpoint", "rk4")}
    assert err["rk4"] < 0.1 * err["midpoint"] and err["midpoint"] < 0.5 * err["euler"], err


def _gpff_by_hand(gpff, y, seed, drop_run_at=None):
    """The filter's recursion written out: draw the prior, then per step transition, update,
    estimate = particle mean, P = eq (52) covariance of the moved particles."""
    rng = np.random.default_rng(seed)
    runs, T, _ = y.shape
    x = gpff.sample_prior(rng, (runs, gpff.n_particles))
    xs, Ps = [], []
    for k in range(1, T + 1):
        x = gpff.model.sample_transition(x, k, rng)
        x = gpff.update(x, y[:, k - 1])
        xs.append(x.mean(axis=1))
        Ps.append(particle_moments(x)[1])
    return np.stack(xs, 1), np.stack(Ps, 1)


@pytest.mark.parametrize("integrator", ["euler", "exact"])
def test_gpff_filter_is_transition_then_update(integrator):
    model = _linear_2d()
    y = np.random.default_rng(9).standard_normal((2, 3, 1)) * 2
    gpff = GaussianParticleFlowFilter(model, 25, integrator=integrator, return_cov=True)
    res = gpff.filter(y, rng=np.random.default_rng(10))
    xs, Ps = _gpff_by_hand(gpff, y, 10)
    np.testing.assert_allclose(res.x, xs, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(res.P, Ps, rtol=1e-12, atol=1e-12)
    assert GaussianParticleFlowFilter(model, 25, integrator=integrator).filter(
        y, rng=np.random.default_rng(10)).P is None


class _BlowUpRun1(LinearGaussianModel):
    """Run 1's particles become infinite in the transition to step 2 (while 2 runs are alive)."""

    def sample_transition(self, x, k, rng):
        out = super().sample_transition(x, k, rng)
        if k == 2 and out.shape[0] == 2:
            out[1] = np.inf
        return out


def test_gpff_drop_keeps_filtering_the_healthy_run():
    """on_divergence="drop": run 1's prior cloud is infinite at step 2 (its eq-52 covariance cannot
    be formed), so it is dropped before the update; run 0 is then updated with ITS measurement of
    step 2 and filtered on; run 1's estimates are NaN from step 2 and diverged_at = (0, 2)."""
    base = _linear_2d()
    model = _BlowUpRun1(base.F, base.H, base.Q, base.R, [0.0, 0.0], P0=base.P0)
    y = np.arange(1.0, 9.0).reshape(2, 4, 1)                   # distinct y per run and step
    gpff = GaussianParticleFlowFilter(model, 20, on_divergence="drop", return_cov=True)
    with np.errstate(invalid="ignore"):
        res = gpff.filter(y, rng=np.random.default_rng(11))
    np.testing.assert_array_equal(res.diagnostics["diverged_at"], [0, 2])
    assert res.diagnostics["n_diverged"] == 1
    assert np.all(np.isfinite(res.x[1, 0])) and np.all(np.isnan(res.x[1, 1:]))
    assert np.all(np.isnan(res.P[1, 1:]))
    # run 0 by hand: the same calls, with run 1 removed from step 2's update on
    rng = np.random.default_rng(11)
    x = gpff.sample_prior(rng, (2, 20))
    x = gpff.update(model.sample_transition(x, 1, rng), y[:, 0])
    np.testing.assert_allclose(res.x[:, 0], x.mean(axis=1), rtol=1e-12)
    x = model.sample_transition(x, 2, rng)[:1]
    for k in (2, 3, 4):
        if k > 2:
            x = model.sample_transition(x, k, rng)
        x = gpff.update(x, y[:1, k - 1])
        np.testing.assert_allclose(res.x[0, k - 1], x.mean(axis=1)[0], rtol=1e-12)
        np.testing.assert_allclose(res.P[0, k - 1], particle_moments(x)[1][0], rtol=1e-12)


def test_gpff_raise_names_the_step_and_run():
    from pfrepro.filters.base import FilterDivergenceError

    base = _linear_2d()
    model = _BlowUpRun1(base.F, base.H, base.Q, base.R, [0.0, 0.0], P0=base.P0)
    with pytest.raises(FilterDivergenceError, match=r"step 2 in runs \[1\]"):
        GaussianParticleFlowFilter(model, 20, on_divergence="raise").filter(np.ones((2, 3, 1)),
                                                                          rng=np.random.default_rng(0))


def test_gpff_documented_defaults_and_settings_reach_the_filter():
    """The class docstring's defaults (the paper's N = 100, 20 uniform Euler steps; our UT
    alpha = 1, beta = 2, kappa = 0; eq41; raise; no covariance) and the overrides are used."""
    model = _linear_2d()
    g = GaussianParticleFlowFilter(model)
    assert (g.n_particles, g.n_steps, g.integrator, g.field, g.on_divergence, g.return_cov) == \
        (100, 20, "euler", "eq43", "warn", False)  # eq43: the default that works on every shipped model
    assert (g.points.alpha, g.points.beta, g.points.kappa) == (1.0, 2.0, 0.0)
    np.testing.assert_array_equal(g.grid, flow.lambda_schedule(20, "uniform"))
    np.testing.assert_array_equal(GaussianParticleFlowFilter(model, schedule="exponential").grid,
                                  flow.lambda_schedule(20, "exponential", 1.2))
    m0, P0 = np.array([1.0, -2.0]), np.array([[3.0, 0.5], [0.5, 2.0]])
    g = GaussianParticleFlowFilter(model, n_steps=7, schedule="exponential", ratio=2.0, m0=m0, P0=P0,
                                   alpha=0.5, beta=1.0, kappa=1.0, return_cov=True)
    np.testing.assert_array_equal(g.grid, flow.lambda_schedule(7, "exponential", 2.0))
    np.testing.assert_array_equal(g.m0, m0)
    np.testing.assert_array_equal(g.P0, P0)
    assert (g.points.alpha, g.points.beta, g.points.kappa, g.return_cov) == (0.5, 1.0, 1.0, True)
    assert "exponential" in repr(g) and "n_steps=7" in repr(g)


def test_gpff_errors_name_the_argument():
    model = _linear_2d()
    with pytest.raises(ValueError, match=r"n_particles >= 2 \(eq 52 divides by N - 1\)"):
        GaussianParticleFlowFilter(model, n_particles=1)
    with pytest.raises(ValueError, match="n_particles must be >= 1"):
        GaussianParticleFlowFilter(model, n_particles=0)
    with pytest.raises(ValueError, match="n_steps must be >= 1"):
        GaussianParticleFlowFilter(model, n_steps=0)
    with pytest.raises(ValueError, match="unknown integrator 'heun'.*'euler'.*'exact'"):
        GaussianParticleFlowFilter(model, integrator="heun")
    with pytest.raises(TypeError, match="integrator='exact'\\) needs a model with a measurement matrix H"):
        GaussianParticleFlowFilter(UNGM.zhang2016(), integrator="exact")
    with pytest.raises(ValueError, match=r"particles must be \(runs, N, d\), got shape \(3, 2\)"):
        particle_moments(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="need at least 2 particles for a sample covariance"):
        particle_moments(np.zeros((1, 1, 2)))
    m, P = particle_moments(np.array([[[0.0], [2.0]]]))          # N = 2 is enough: 1/(N-1) = 1
    assert P[0, 0, 0] == 2.0


class _NoH:
    """A nonlinear model without a matrix H (only what the constructor reads)."""

    dim_x, dim_y = 1, 1
    m0, P0 = np.zeros(1), np.eye(1)


# ------------------------------------------------------------------------------ 4. ESPF MH move
class FlatLikelihoodModel:
    """x_k = c + w, w ~ N(0, Q) (the transition forgets x_{k-1}), flat likelihood.

    ``seen`` records the particles handed to ``f`` (at step 2: the output of step 1)."""

    dim_x = 2
    dim_y = 1

    def __init__(self, c, Q):
        self.c = np.asarray(c, float)
        self.Q = np.asarray(Q, float)
        self.m0 = self.c.copy()
        self.P0 = self.Q.copy()
        self.seen = {}

    def f(self, x, k):
        self.seen[k] = np.array(x)
        return np.broadcast_to(self.c, x.shape).copy()

    def log_likelihood(self, y, x):
        return np.zeros(x.shape[:-1])


def test_espf_mh_move_leaves_the_transition_prior_invariant(monkeypatch):
    """With a flat likelihood the MH target is the transition prior N(c, Q) itself; the
    resampled particles are exact draws from it, so after one MH step the moved particles must
    still be N(c, Q) draws. The selection step is replaced by "keep the MCMC block" (indices
    N..2N-1 of the pool) so the filter's output at step 1 is exactly the MH output.

    n = runs * N = 16000 whitened 2-D samples: each whitened coordinate has mean 0 (se 1/sqrt(n)),
    variance 1 (se sqrt(2/n)), their correlation 0 (se 1/sqrt(n)); tolerance 4.5 se on each
    (two-sided p = 7e-6 per check), and a KS test of each coordinate against N(0, 1) at
    p > 1e-4. A one-step kernel that is not invariant moves the variance by O(1)."""
    c = np.array([3.0, -1.0])
    Q = np.array([[2.0, 0.6], [0.6, 0.5]])
    runs, N = 4, 4000
    model = FlatLikelihoodModel(c, Q)
    kept = []

    def keep_mcmc_block(neg_pool_ll, n_keep):
        assert neg_pool_ll.shape == (runs, 3 * N) and n_keep == N
        kept.append(True)
        return np.broadcast_to(np.arange(N, 2 * N), (runs, N)).copy()

    monkeypatch.setattr(espf_module, "_select_negated", keep_mcmc_block)
    f = EvolutionSamplingParticleFilter(model, N, mcmc_scale=1.5)
    res = f.filter(np.zeros((runs, 2, 1)), rng=np.random.default_rng(2011))
    assert kept
    moved = model.seen[2]                                  # (runs, N, 2): output of step 1
    acc = res.diagnostics["acceptance"][:, 0]
    assert np.all((acc > 0.2) & (acc < 0.8)), acc          # the move really moves particles
    z = np.linalg.solve(np.linalg.cholesky(Q), (moved - c).reshape(-1, 2).T).T
    n = z.shape[0]
    tol = 4.5
    assert np.all(np.abs(z.mean(axis=0)) < tol / np.sqrt(n)), z.mean(axis=0)
    assert np.all(np.abs(z.var(axis=0, ddof=1) - 1) < tol * np.sqrt(2 / n)), z.var(axis=0, ddof=1)
    assert abs(np.corrcoef(z.T)[0, 1]) < tol / np.sqrt(n)
    for i in range(2):
        assert stats.kstest(z[:, i], "norm").pvalue > 1e-4


class FlatSpy1D:
    """1-D: x_k = c + w, w ~ N(0, q); flat likelihood; records every call (k, y, x shape)."""

    dim_x = 1
    dim_y = 1

    def __init__(self, c=2.0, q=0.5):
        self.c, self.Q = c, np.array([[q]])
        self.m0, self.P0 = np.array([c]), self.Q.copy()
        self.f_calls, self.ll_calls = [], []

    def f(self, x, k):
        self.f_calls.append((k, np.array(x)))
        return np.full(x.shape, self.c)

    def log_likelihood(self, y, x):
        self.ll_calls.append((np.array(y), x.shape))
        return np.zeros(x.shape[:-1])


@pytest.mark.parametrize("scale", [None, 1.5])
def test_espf_mh_acceptance_rate_is_the_random_walk_formula(scale):
    """Flat likelihood, 1-D: the resampled particles are exact N(c, q) draws (systematic
    resampling of equal weights keeps each once) and the move is random-walk MH with step
    s sqrt(q) on the target N(c, q). In whitened units its acceptance probability at
    stationarity is E min(1, exp(-(y^2 - x^2)/2)) = (2/pi) arctan(2/s) (0.705 for the default
    s = 1, 0.590 for s = 1.5). n = 16000 iid accept events: tolerance 4.5 sqrt(p(1-p)/n)."""
    runs, N = 4, 4000
    kw = {} if scale is None else {"mcmc_scale": scale}
    s = 1.0 if scale is None else scale
    res = EvolutionSamplingParticleFilter(FlatSpy1D(), N, **kw).filter(np.zeros((runs, 1, 1)),
                                                                      rng=np.random.default_rng(21))
    p = 2 / np.pi * np.arctan(2 / s)
    acc = res.diagnostics["acceptance"][:, 0].mean()
    assert abs(acc - p) < 4.5 * np.sqrt(p * (1 - p) / (runs * N)), (acc, p)


def test_espf_step_k_uses_y_k_and_pools_3n_candidates():
    """Per step k = 1..T: f(., k) once, and three likelihood calls with y_k -- the N resampled /
    predicted particles, the N MH proposals and the N SBX children (N odd: (N-1)/2 pairs give
    N - 1 children, the unpaired particle is copied)."""
    for N in (6, 7):
        model = FlatSpy1D()
        y = np.arange(1.0, 7.0).reshape(2, 3, 1)
        res = EvolutionSamplingParticleFilter(model, N).filter(y, rng=np.random.default_rng(0))
        assert [k for k, _ in model.f_calls] == [1, 2, 3]
        assert len(model.ll_calls) == 9
        for i, (yy, shape) in enumerate(model.ll_calls):
            np.testing.assert_array_equal(yy, y[:, i // 3])
            assert shape == (2, N, 1), (N, i, shape)
        assert res.diagnostics["likelihood_evaluations"] == 3 * N * 3
        np.testing.assert_allclose(res.diagnostics["origin_share"].sum(axis=-1), 1.0)


def test_espf_uses_the_requested_resampling_scheme(monkeypatch):
    """Flat likelihood; the selection is replaced by "keep the resampled block" (pool indices
    0..N-1). Systematic resampling of equal weights keeps every particle once (N distinct
    values); multinomial draws duplicates (expected distinct share 1 - 1/e = 0.63)."""
    N = 200
    monkeypatch.setattr(espf_module, "_select_negated",
                        lambda neg, n: np.broadcast_to(np.arange(n), (neg.shape[0], n)).copy())
    distinct = {}
    for scheme in ("systematic", "multinomial"):
        model = FlatSpy1D()
        EvolutionSamplingParticleFilter(model, N, resampling=scheme).filter(np.zeros((2, 2, 1)),
                                                                           rng=np.random.default_rng(3))
        kept = model.f_calls[1][1]                          # step-1 output, seen by f at step 2
        distinct[scheme] = [len(np.unique(kept[r])) for r in range(2)]
    assert distinct["systematic"] == [N, N]
    assert all(d < 0.8 * N for d in distinct["multinomial"]), distinct


def test_sbx_children_by_hand():
    """Deb & Agrawal's spread factor: b = (2u)^(1/(eta+1)) for u <= 1/2, (1/(2(1-u)))^(1/(eta+1))
    otherwise. eta = 1: u = 1/8 -> b = 1/2; u = 7/8 -> b = 2; u = 15/16 -> b = sqrt(8).
    eta = 0 (allowed): u = 1/4 -> 1/2, u = 3/4 -> 2, u = 15/16 -> 8.
    Children 0.5[(1 +- b) p1 + (1 -+ b) p2] with p1 = 1, p2 = 3."""
    p1, p2 = np.full(5, 1.0), np.full(5, 3.0)
    for eta, u, b in ((1.0, [1 / 8, 7 / 8, 0.5, 0.5, 15 / 16], [0.5, 2.0, 1.0, 1.0, np.sqrt(8)]),
                      (0.0, [0.25, 0.75, 0.5, 0.5, 15 / 16], [0.5, 2.0, 1.0, 1.0, 8.0])):
        c1, c2 = espf_module.sbx_children(p1, p2, np.array(u), eta)
        b = np.array(b)
        np.testing.assert_allclose(c1, 0.5 * ((1 + b) * 1 + (1 - b) * 3), rtol=1e-12)
        np.testing.assert_allclose(c2, 0.5 * ((1 - b) * 1 + (1 + b) * 3), rtol=1e-12)
    with pytest.raises(ValueError, match=r"u must lie in \(0, 1\)"):
        espf_module.sbx_children(p1[:1], p2[:1], np.array([1.0]), 2.0)
    with pytest.raises(ValueError, match="SBX distribution index must be >= 0"):
        espf_module.sbx_children(p1[:1], p2[:1], np.array([0.5]), -0.5)


def test_espf_settings_reach_the_filter_and_errors_name_them():
    model = FlatSpy1D()
    m0, P0 = np.array([5.0]), np.array([[3.0]])
    f = EvolutionSamplingParticleFilter(model, 2, sbx_eta=0.0, m0=m0, P0=P0)   # N = 2, eta = 0 allowed
    np.testing.assert_array_equal(f.m0, m0)
    np.testing.assert_array_equal(f.P0, P0)
    with pytest.raises(ValueError, match=r"ESPF needs n_particles >= 2 \(crossover pairs\)"):
        EvolutionSamplingParticleFilter(model, 1)
    with pytest.raises(ValueError, match="n_particles must be >= 1"):
        EvolutionSamplingParticleFilter(model, 0)
    with pytest.raises(ValueError, match="mcmc_scale must be positive"):
        EvolutionSamplingParticleFilter(model, 4, mcmc_scale=0.0)
    with pytest.raises(ValueError, match="sbx_eta must be >= 0"):
        EvolutionSamplingParticleFilter(model, 4, sbx_eta=-1.0)
    with pytest.raises(TypeError, match="ESPF needs a model with additive Gaussian process noise Q"):
        EvolutionSamplingParticleFilter(_NoH(), 4)


# ------------------------------------------------------------------------------ 5. CMS-PF eq (3)
class IdentityGaussModel:
    """x_k = x_{k-1} exactly (no noise); log p(z | x) = -(z - x)^2 / 2 (scalar)."""

    dim_x = 1
    dim_y = 1
    m0 = np.zeros(1)
    P0 = np.eye(1)

    def sample_transition(self, x, k, rng):
        return np.array(x, float)

    def log_likelihood(self, y, x):
        return -0.5 * (y[:, None, 0] - x[..., 0]) ** 2


W_PREV = np.array([0.1, 0.2, 0.3, 0.4])
X_PREV = np.array([[[0.0], [1.0], [2.0], [3.0]]])


def _cms_step(y, r, use_map=True):
    f = CMSParticleFilter(IdentityGaussModel(), 4, eta=0.5, big_fraction=0.1)
    assert f.n_big == 1
    return f.step(X_PREV, np.log(W_PREV)[None], np.array([[y]]), 1, np.asarray(r, float)[None, :, None],
                  np.random.default_rng(0), use_map=use_map)


def _sorted_by_x(st):
    o = np.argsort(st.x[0, :, 0])
    return st.x[0, o, 0], np.exp(st.logw[0, o])


def test_cms_weights_keep_the_previous_weights_of_predicted_particles():
    """z = 1.5 and carrier r = 100: the map particles land ~150 away and are never kept, so the
    kept set is the 4 predicted particles x = 0, 1, 2, 3 with likelihoods
    exp(-1.125), exp(-0.125), exp(-0.125), exp(-1.125). Eq (3) by hand:
    w ∝ (0.1 e^-1, 0.2, 0.3, 0.4 e^-1) = (0.0367879, 0.2, 0.3, 0.1471518) / 0.6839397,
    estimate = (0.2 + 0.6 + 1.2 e^-1) / 0.6839397 = 1.8151531.
    Dropping w_{k-1} (uniform previous weights) would give 1.5 by symmetry."""
    st = _cms_step(1.5, [100.0] * 4)
    assert np.all(st.selected[0] < 4)
    x, w = _sorted_by_x(st)
    np.testing.assert_allclose(x, [0, 1, 2, 3])
    e = np.exp(-1.0)
    raw = np.array([0.1 * e, 0.2, 0.3, 0.4 * e])
    np.testing.assert_allclose(w, raw / raw.sum(), rtol=1e-12)
    np.testing.assert_allclose(w, [0.0537883, 0.2924234, 0.4386352, 0.2151531], atol=1e-7)
    assert st.estimate[0, 0] == pytest.approx((0.2 + 0.6 + 1.2 * e) / (0.5 + 0.5 * e), rel=1e-12)
    assert st.estimate[0, 0] == pytest.approx(1.8151531, abs=1e-7)
    # the same recursion without the map (the "without mapping" panels of Figs. 4-5)
    plain = _cms_step(1.5, [100.0] * 4, use_map=False)
    np.testing.assert_allclose(np.exp(plain.logw[0]), raw / raw.sum(), rtol=1e-12)
    assert plain.estimate[0, 0] == pytest.approx(1.8151531, abs=1e-7)


def test_cms_weights_of_a_kept_map_particle_inherit_the_big_particles_weight():
    """z = 2.6: the big particle (largest w_{k-1} p(z|x)) is x = 3 (w_prev 0.4), the small one
    x = 0, spread 3, eta = 0.5. Carrier r_1 = -0.4/1.5 puts map particle 1 (centre: the big
    particle) at 3 - 0.4 = 2.6 (likelihood 1); r = 10 sends the other three ~15 away.
    Kept: map 2.6 (prev 0.4, lik 1), x = 3 (0.4, e^-0.08), x = 2 (0.3, e^-0.18),
    x = 1 (0.2, e^-1.28); x = 0 (lik e^-3.38) is dropped. Eq (3): w ∝ prev * lik."""
    st = _cms_step(2.6, [10.0, -0.4 / 1.5, 10.0, 10.0])
    assert sorted(st.selected[0].tolist()) == [1, 2, 3, 5]           # x1 = 1, 2, 3 and map 1
    x, w = _sorted_by_x(st)
    np.testing.assert_allclose(x, [1.0, 2.0, 2.6, 3.0], rtol=1e-12)
    raw = np.array([0.2 * np.exp(-1.28), 0.3 * np.exp(-0.18), 0.4, 0.4 * np.exp(-0.08)])
    np.testing.assert_allclose(w, raw / raw.sum(), rtol=1e-10)
    assert st.estimate[0, 0] == pytest.approx(raw @ x / raw.sum(), rel=1e-12)


def test_cms_filter_carries_weights_between_steps():
    """Two steps through ``filter`` with no resampling (n_th = 0): the weights leaving step 1
    are the w_{k-1} of step 2. Identity dynamics, z_1 = z_2 = 1.5, r = 100 (map never kept),
    prior draws x_0 = m0 + z: step 2's weights are ∝ exp(-(1.5 - x)^2) (two likelihood
    factors), not exp(-(1.5 - x)^2 / 2) (one)."""
    f = CMSParticleFilter(IdentityGaussModel(), 6, eta=0.5, n_th=0.0)
    r = np.full((2, 1, 6, 1), 100.0)
    y = np.full((1, 2, 1), 1.5)
    res = f.filter(y, rng=np.random.default_rng(4), r=r)
    x0 = f.sample_prior(np.random.default_rng(4), (1, 6))[0, :, 0]   # same first draw as the filter
    for k, est in ((1, res.x[0, 0, 0]), (2, res.x[0, 1, 0])):
        w = np.exp(-0.5 * k * (1.5 - x0) ** 2)
        assert est == pytest.approx(w @ x0 / w.sum(), rel=1e-12)
    assert not res.diagnostics["resampled"].any()


def test_cms_filter_outputs_by_hand_without_resampling():
    """Three steps, n_th = 0 (no resampling), identity dynamics, z = (1.5, 0.5, 2.0), r = 100
    (the map particles land far away and are never kept): the weights after step k are
    ∝ prod_{j<=k} exp(-(z_j - x)^2 / 2) over the prior draws x (eq 3 applied k times); the
    estimate is their weighted mean (eq 4), P the weighted covariance about it, ess the
    rounded 1 / sum w^2 (Step 3), map_share 0."""
    f = CMSParticleFilter(IdentityGaussModel(), 6, eta=0.5, n_th=0.0, big_fraction=0.34)
    z = np.array([1.5, 0.5, 2.0])
    res = f.filter(np.broadcast_to(z[None, :, None], (2, 3, 1)).copy(), rng=np.random.default_rng(6),
                   r=np.full((3, 2, 6, 1), 100.0))
    x0 = f.sample_prior(np.random.default_rng(6), (2, 6))[..., 0]
    lw = np.zeros((2, 6))
    for k in range(3):
        lw = lw - 0.5 * (z[k] - x0) ** 2
        w = np.exp(lw - lw.max(axis=1, keepdims=True))
        w /= w.sum(axis=1, keepdims=True)
        est = np.sum(w * x0, axis=1)
        np.testing.assert_allclose(res.x[:, k, 0], est, rtol=1e-12)
        np.testing.assert_allclose(res.P[:, k, 0, 0], np.sum(w * (x0 - est[:, None]) ** 2, axis=1), rtol=1e-10)
        np.testing.assert_array_equal(res.diagnostics["ess"][:, k], np.round(1 / np.sum(w * w, axis=1)))
    d = res.diagnostics
    np.testing.assert_array_equal(d["map_share"], 0.0)
    assert d["resampled"].dtype == bool and not d["resampled"].any()
    assert d["likelihood_evaluations"] == 2 * 6 * 3 and d["n_big"] == 2


class PositionScripted(ScriptedModel2D):
    """Like ScriptedModel2D, but the likelihood is looked up by POSITION: a particle exactly at
    ``positions[i]`` gets ``loglik[k-1][run, i]``; anything else (a map particle) -1e6."""

    def log_likelihood(self, y, x):
        k = int(round(float(y[0, 0])))
        eq = np.all(x[..., None, :] == self.positions, axis=-1)           # (runs, M, N)
        table = np.take_along_axis(self.loglik[k - 1][:, None, :].repeat(x.shape[1], 1),
                                   eq.argmax(-1)[..., None], axis=-1)[..., 0]
        return np.where(eq.any(-1), table, -1e6)


@pytest.mark.filterwarnings("error")
def test_cms_step3_resamples_only_runs_below_n_th():
    """Step 3 with n_th = 0.6 (2.4 particles), three runs. Step 1 weights: runs 0-1 (1/2, 1/2, ~0, ~0)
    -> N_eff = round(2.0) = 2 < 2.4 -> resample (systematic: exactly two copies of c_0 and c_1);
    run 2 W1[1] -> round(3.33) = 3 -> keep. Step 2 likelihood flat: runs 0-1 estimate
    (c_0 + c_1) / 2 = (2, 0.5) with uniform weights; run 2 keeps W1[1]: (2.9, 2.1)."""
    w1 = np.tile([0.5, 0.5, 1e-200, 1e-200], (3, 1))
    w1[-1] = W1[1]
    loglik = np.stack([np.log(w1), np.zeros((3, 4))])
    f = CMSParticleFilter(PositionScripted(C2, loglik), 4, eta=0.5, n_th=0.6, big_fraction=0.25)
    res = f.filter(scripted_measurements(3, 2), rng=np.random.default_rng(1), r=np.full((2, 3, 4, 2), 100.0))
    d = res.diagnostics
    np.testing.assert_array_equal(d["ess"][:, 0], [2, 2, 3])
    np.testing.assert_array_equal(d["resampled"][:, 0], [True, True, False])
    np.testing.assert_allclose(res.x[:, 0], [[2.0, 0.5], [2.0, 0.5], [2.9, 2.1]], rtol=1e-12)
    np.testing.assert_allclose(res.x[:, 1], [[2.0, 0.5], [2.0, 0.5], [2.9, 2.1]], rtol=1e-12)
    np.testing.assert_array_equal(d["ess"][:, 1], [4, 4, 3])            # resampled runs: 4 equal weights
    np.testing.assert_array_equal(d["map_share"], 0.0)



def test_cms_step3_threshold_is_strict():
    """Flat likelihood: 4 equal weights, N_eff = 4 = 1.0 * N; Step 3 resamples only when
    N_eff < n_th N, so n_th = 1 does not resample here."""
    loglik = np.zeros((2, 2, 4))
    f = CMSParticleFilter(PositionScripted(C2, loglik), 4, n_th=1.0)
    d = f.filter(scripted_measurements(2, 2), rng=np.random.default_rng(0), r=np.full((2, 2, 4, 2), 100.0)).diagnostics
    np.testing.assert_array_equal(d["ess"], 4)
    assert not d["resampled"].any()


def test_map_particles_by_hand_two_pairs():
    """Step 2.2 with n_big = 2 and a small particle away from 0 (so big - small != big + small).
    x = (1, 2, 4, 7, 11), w_{k-1} p(z|x) ∝ (0.3, 0.1, 0.05, 0.15, 0.4): big = (11, 1) (largest
    first), small = (4, 2) (smallest first); spreads 11 - 4 = 7, 1 - 2 = -1; x_hat =
    0.3 + 0.2 + 0.2 + 1.05 + 4.4 = 6.15. Centres cycle (x_hat, big_1, big_2); x_hat takes the
    best pair's spread: map j = centre + eta r_j spread with eta = 0.5, r = 1:
    (6.15 + 3.5, 11 + 3.5, 1 - 0.5, 6.15 + 3.5, 11 + 3.5); their w_{k-1} is that of the big
    particle at the centre (of the best particle for x_hat)."""
    x = np.array([[[1.0], [2.0], [4.0], [7.0], [11.0]]])
    lw = np.log(np.array([[0.3, 0.1, 0.05, 0.15, 0.4]]))
    logw_prev = np.log(np.array([[0.1, 0.2, 0.3, 0.15, 0.25]]))
    x2, lwm, idx = map_particles(x, lw, logw_prev, np.ones((1, 5, 1)), eta=0.5, n_big=2)
    np.testing.assert_allclose(x2[0, :, 0], [9.65, 14.5, 0.5, 9.65, 14.5], rtol=1e-12)
    np.testing.assert_allclose(np.exp(lwm[0]), [0.25, 0.25, 0.1, 0.25, 0.25], rtol=1e-12)
    np.testing.assert_array_equal(idx, [0, 1, 2, 0, 1])
    # a NaN weight counts as -inf: that particle is the smallest
    lw_nan = lw.copy()
    lw_nan[0, 1] = np.nan
    x2, _, _ = map_particles(x, lw_nan, logw_prev, np.ones((1, 3, 1)), eta=1.0, n_big=1)
    assert x2[0, 1, 0] == pytest.approx(11 + (11 - 2))


def test_select_top_likelihood_edges():
    """n_keep = M keeps everything (sorted by decreasing likelihood); on a large random row the
    kept set is exactly the n_keep largest; errors name the argument."""
    ll = np.array([[0.5, -1.0, 3.0, 2.0]])
    np.testing.assert_array_equal(select_top_likelihood(ll, 4), [[2, 3, 0, 1]])
    assert sorted(select_top_likelihood(ll, 4, sort=False)[0]) == [0, 1, 2, 3]
    rng = np.random.default_rng(17)
    big = rng.standard_normal((5, 1000))
    for n_keep in (1, 2, 37, 500, 999):
        got = select_top_likelihood(big, n_keep, sort=False)
        want = np.argsort(-big, axis=1)[:, :n_keep]
        for r in range(5):
            assert set(got[r]) == set(want[r]), n_keep
    with pytest.raises(ValueError, match="cannot keep 5 of 4 candidates"):
        select_top_likelihood(ll, 5)
    with pytest.raises(ValueError, match="n_keep must be >= 1"):
        select_top_likelihood(ll, 0)
    with pytest.raises(ValueError, match=r"loglik must be \(runs, M\), got shape \(4,\)"):
        select_top_likelihood(ll[0], 1)


def test_oracle_cms_centres_the_map_on_the_true_state():
    """The oracle's Step 2.2 centre is x_true (not x_hat / big particles): with eta = 1e-9 every
    map particle sits on x_true = z = 1.5 (the likelihood's peak) to 1e-8, so at step 1 the N kept
    particles are all map particles and the estimate is 1.5 (the particles then stay there)."""
    f = OracleCMSParticleFilter(IdentityGaussModel(), 5, eta=1e-9, n_th=0.0)
    res = f.filter(np.full((2, 3, 1), 1.5), rng=np.random.default_rng(2), x_true=np.full((2, 4, 1), 1.5))
    np.testing.assert_allclose(res.x, 1.5, atol=1e-7)
    np.testing.assert_array_equal(res.diagnostics["map_share"][:, 0], 1.0)   # later: ties with x_pred


def test_cms_settings_reach_the_filter():
    """n_big = min(max(1, round(big_fraction N)), N // 2); m0/P0 overrides; a carrier instance is
    used as given; N = 2 is allowed."""
    model = IdentityGaussModel()
    for N, bf, want in ((20, 0.1, 2), (20, 0.01, 1), (20, 0.5, 10), (5, 1.0, 2), (2, 0.5, 1)):
        assert CMSParticleFilter(model, N, big_fraction=bf).n_big == want, (N, bf)
    c = ChaosCarrier("chebyshev")
    f = CMSParticleFilter(model, 4, carrier=c, m0=[2.0], P0=[[3.0]])
    assert f.carrier is c
    np.testing.assert_array_equal(f.m0, [2.0])
    np.testing.assert_array_equal(f.P0, [[3.0]])
    with pytest.raises(ValueError, match=r"CMSParticleFilter needs n_particles >= 2 \(big and small"):
        CMSParticleFilter(model, 1)
    with pytest.raises(ValueError, match="big_fraction"):
        CMSParticleFilter(model, 4, big_fraction=1.5)
    with pytest.raises(ValueError, match="n_th"):
        CMSParticleFilter(model, 4, n_th=-0.1)


@pytest.mark.parametrize("scheme", ["systematic", "stratified", "multinomial", "residual"])
def test_resample_uses_the_named_scheme(scheme):
    """resample(w, rng, scheme) = sorted ancestors of resample_counts(w, rng, scheme) with the same
    stream; the default is systematic; the named wrappers are their scheme."""
    from pfrepro.filters import resampling as rs

    w = np.random.default_rng(1).dirichlet(np.full(50, 0.3), size=3)
    got = rs.resample(w, np.random.default_rng(2), scheme)
    np.testing.assert_array_equal(got, rs.indices_from_counts(rs.resample_counts(w, np.random.default_rng(2), scheme)))
    wrapper = getattr(rs, f"{scheme}_resample")
    np.testing.assert_array_equal(wrapper(w, np.random.default_rng(2)), got)
    np.testing.assert_array_equal(rs.resample(w, np.random.default_rng(2)),
                                  rs.resample(w, np.random.default_rng(2), "systematic"))
    if scheme != "systematic":   # the schemes really differ on these weights and this stream
        assert np.any(got != rs.resample(w, np.random.default_rng(2), "systematic"))


class TiltedSpy1D(FlatSpy1D):
    """FlatSpy1D with an exponential-tilt likelihood log p(z | x) = a x: the posterior of the
    prior N(c, q) is N(c + q a, q), a Gaussian of the same variance."""

    a = 1.0

    def log_likelihood(self, y, x):
        return self.a * x[..., 0]


def test_espf_mh_acceptance_with_a_likelihood():
    """With log p(z|x) = a x the MH target p(z|x) N(x; c, q) is N(c + q a, q): the same shape as
    the flat case, so at stationarity the acceptance is again (2/pi) arctan(2/s). The resampled
    particles are a weighted (SIR) sample of that target (N = 4000 per run, ESS ~ 0.6 N), so the
    rate holds up to its sampling error; tolerance 5 sqrt(p(1-p)/n). A sign error on either
    likelihood term shifts log alpha by ~ a (x' + x) ~ 5 and the rate to ~1."""
    runs, N = 4, 4000
    res = EvolutionSamplingParticleFilter(TiltedSpy1D(), N).filter(np.zeros((runs, 1, 1)),
                                                                  rng=np.random.default_rng(22))
    p = 2 / np.pi * np.arctan(2.0)
    acc = res.diagnostics["acceptance"][:, 0].mean()
    assert abs(acc - p) < 5 * np.sqrt(p * (1 - p) / (runs * N)), (acc, p)


def test_espf_mcmc_block_is_consistent_with_its_moves(monkeypatch):
    """Tilted likelihood a x, selection replaced by "keep the MCMC block" and recorded: the MCMC
    block's log-likelihoods are those of the moved particles (a x_m), they differ from the
    resampled block's exactly where a move was accepted (share = the acceptance diagnostic), and
    the estimate of step k is the mean of the particles step k + 1 starts from."""
    runs, N = 3, 500
    pools = []

    def keep_mcmc_block(neg_pool_ll, n_keep):
        pools.append(-neg_pool_ll)                  # the pool's log-likelihoods (held negated)
        return np.broadcast_to(np.arange(N, 2 * N), (runs, N)).copy()

    monkeypatch.setattr(espf_module, "_select_negated", keep_mcmc_block)
    model = TiltedSpy1D()
    res = EvolutionSamplingParticleFilter(model, N).filter(np.zeros((runs, 3, 1)), rng=np.random.default_rng(4))
    acc = res.diagnostics["acceptance"]
    assert np.all((acc > 0.5) & (acc < 0.9)), acc               # every step's column filled
    for k in (1, 2):
        moved = model.f_calls[k][1]                             # output of step k, seen by f at k + 1
        ll_r, ll_m = pools[k - 1][:, :N], pools[k - 1][:, N:2 * N]
        np.testing.assert_allclose(ll_m, model.a * moved[..., 0], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(np.mean(ll_m != ll_r, axis=1), acc[:, k - 1], atol=1e-12)
        np.testing.assert_allclose(res.x[:, k - 1, 0], moved[..., 0].mean(axis=1), rtol=1e-12)
    np.testing.assert_array_equal(res.diagnostics["origin_share"], np.broadcast_to([0.0, 1.0, 0.0], (runs, 3, 3)))


def test_espf_crossover_children_are_kept_and_runs_are_independent():
    """With a likelihood, SBX children compete: about a third of the kept particles are children
    (measured 0.33 with N = 200; > 0.1 required). Per-run streams: run 0 is bit-identical in a
    batch of 1 and of 3 (every draw, including the SBX pairing, is per run)."""
    from pfrepro.rng import RunStreams

    res = EvolutionSamplingParticleFilter(TiltedSpy1D(), 200).filter(np.zeros((3, 4, 1)), rng=np.random.default_rng(0))
    assert res.diagnostics["origin_share"][..., 2].min() > 0.1
    y = np.random.default_rng(5).standard_normal((3, 4, 1))
    f = EvolutionSamplingParticleFilter(TiltedSpy1D(), 7)
    one = f.filter(y[:1], rng=RunStreams.from_entropy(9, 1))
    three = f.filter(y, rng=RunStreams.from_entropy(9, 3))
    np.testing.assert_array_equal(one.x[0], three.x[0])
    np.testing.assert_array_equal(one.diagnostics["acceptance"][0], three.diagnostics["acceptance"][0])


def test_cms_step_reports_its_internals():
    """CMSStep (Figs. 4-6 of the paper) carries the predicted particles and likelihoods, the map
    particles and likelihoods and the pooled indices; without the map, no map particles and the
    identity selection."""
    st = _cms_step(2.6, [10.0, -0.4 / 1.5, 10.0, 10.0])
    np.testing.assert_array_equal(st.x_pred, X_PREV)                       # identity dynamics
    np.testing.assert_allclose(st.ll_pred[0], -0.5 * (2.6 - X_PREV[0, :, 0]) ** 2)
    assert st.x_map.shape == (1, 4, 1)
    np.testing.assert_allclose(st.x_map[0, 1, 0], 2.6)
    np.testing.assert_allclose(st.ll_map[0], -0.5 * (2.6 - st.x_map[0, :, 0]) ** 2)
    plain = _cms_step(2.6, [10.0] * 4, use_map=False)
    np.testing.assert_array_equal(plain.x_pred, X_PREV)
    np.testing.assert_array_equal(plain.x, X_PREV)
    np.testing.assert_allclose(plain.ll_pred[0], -0.5 * (2.6 - X_PREV[0, :, 0]) ** 2)
    assert plain.x_map.shape == (1, 0, 1) and plain.ll_map.shape == (1, 0)
    np.testing.assert_array_equal(plain.selected, [[0, 1, 2, 3]])


def test_cms_step3_uses_the_requested_resampling_scheme():
    """As for the PF: Step 3 resampling of (1/2, 1/2, ~0, ~0) is always (2, 2, 0, 0) with the
    systematic scheme (step-2 estimate (2, 0.5)); multinomial gives other counts in most runs."""
    runs = 31
    w1 = np.tile([0.5, 0.5, 1e-200, 1e-200], (runs, 1))
    loglik = np.stack([np.log(w1), np.zeros((runs, 4))])
    est = {}
    for scheme in ("systematic", "multinomial"):
        f = CMSParticleFilter(PositionScripted(C2, loglik), 4, n_th=0.6, resampling=scheme)
        est[scheme] = f.filter(scripted_measurements(runs, 2), rng=np.random.default_rng(3),
                               r=np.full((2, runs, 4, 2), 100.0)).x[:, 1]
    np.testing.assert_allclose(est["systematic"], np.broadcast_to([2.0, 0.5], (runs, 2)), rtol=1e-12)
    assert np.sum(np.any(np.abs(est["multinomial"] - [2.0, 0.5]) > 1e-9, axis=1)) >= 5


class LostMeasurementModel(IdentityGaussModel):
    """IdentityGaussModel, except that a measurement z > 100 has likelihood 0 at every x (log -inf):
    every candidate's weight underflows at that step of that run."""

    def log_likelihood(self, y, x):
        return np.where(y[:, None, 0] > 100, -np.inf, super().log_likelihood(y, x))


def test_cms_weight_collapse_on_the_map_path_is_recorded():
    """Run 0 gets z_1 = 1e3 (likelihood 0 everywhere), run 1 z_1 = 1.5; z_2 = 1.5 for both. With the
    map on (the default path), run 0's step 1 collapses: diagnostics['collapsed'] is True at (0, 0)
    only, n_collapsed = 1, one WeightCollapseWarning naming 1 of 4 run-steps, and the collapsed
    run's weights are reset to uniform (its step-1 estimate is the plain mean of the kept
    particles, so its ess is N)."""
    f = CMSParticleFilter(LostMeasurementModel(), 6, eta=0.5, n_th=0.0)
    y = np.array([[[1e3], [1.5]], [[1.5], [1.5]]])
    with pytest.warns(WeightCollapseWarning, match="weight collapse in 1 of 4 run-steps"):
        res = f.filter(y, rng=np.random.default_rng(3), r=np.full((2, 2, 6, 1), 100.0))
    d = res.diagnostics
    np.testing.assert_array_equal(d["collapsed"], [[True, False], [False, False]])
    assert d["collapsed"].dtype == bool and d["n_collapsed"] == 1 and type(d["n_collapsed"]) is int
    assert d["ess"][0, 0] == 6 and d["ess"][1, 0] < 6
    assert np.all(np.isfinite(res.x))


def test_cms_resampling_draws_from_each_runs_own_stream():
    """Step 3 resamples only the runs below the threshold, each from its own stream: with per-run
    streams, run i of a batch of 3 is bit-identical to run i filtered alone (stream i), although
    the runs resample at different steps."""
    from pfrepro.rng import RunStreams

    m = UNGM.ning2011(1.0)
    sim = m.simulate(8, 3, np.random.default_rng(11))
    f = CMSParticleFilter(m, 20, n_th=0.9)          # the kept N have near-flat weights: ess 11-20 here
    batch = f.filter(sim.y, rng=RunStreams.from_entropy(9, 3))
    rs = batch.diagnostics["resampled"]
    assert rs.any() and not np.all(rs == rs[:1])                    # resampling differs between runs
    for i in range(3):
        one = f.filter(sim.y[i:i + 1], rng=RunStreams.from_entropy(9, 1, start=i))
        np.testing.assert_array_equal(one.x[0], batch.x[i])
        np.testing.assert_array_equal(one.diagnostics["resampled"][0], rs[i])


def test_cms_runs_under_strict_floating_point_errors():
    """Tails are handled in the log domain and numpy's over/underflow flags are silenced inside
    the filter: a caller who turned every floating-point warning into an error
    (np.errstate(all='raise')) gets the same numbers. With a wide prior (P0 = 1e4) the weights
    of particles ~100 away underflow in exp (this raised FloatingPointError when the filter left
    'under' out of its errstate)."""
    f = CMSParticleFilter(IdentityGaussModel(), 6, P0=[[1e4]], n_th=0.0)
    y = np.full((2, 3, 1), 1.5)
    loose = f.filter(y, rng=np.random.default_rng(0))
    with np.errstate(all="raise"):
        strict = f.filter(y, rng=np.random.default_rng(0))
    np.testing.assert_array_equal(strict.x, loose.x)
    np.testing.assert_array_equal(strict.P, loose.P)
    assert np.all(np.isfinite(strict.x))


def test_cms_and_oracle_error_messages_are_exact():
    model = IdentityGaussModel()
    with pytest.raises(ValueError, match=r"^CMSParticleFilter needs n_particles >= 2 \(big and small particles\)$"):
        CMSParticleFilter(model, 1)
    f = CMSParticleFilter(model, 4)
    y = np.ones((2, 3, 1))
    bad = np.zeros((3, 2, 4, 1))
    bad[1, 0, 2, 0] = np.nan
    with pytest.raises(ValueError, match=r"^precomputed carrier r contains NaN or inf$"):
        f.filter(y, rng=np.random.default_rng(0), r=bad)
    with pytest.raises(ValueError, match=r"^precomputed carrier r must have shape \(T, runs, N, dim_x\) = "
                                         r"\(3, 2, 4, 1\), got \(3, 2, 5, 1\)$"):
        f.filter(y, rng=np.random.default_rng(0), r=np.zeros((3, 2, 5, 1)))
    o = OracleCMSParticleFilter(model, 4)
    with pytest.raises(ValueError, match=r"^x_true must have shape \(runs, T \+ 1, dim_x\) = \(2, 4, 1\), "
                                         r"got \(2, 3, 1\)$"):
        o.filter(y, rng=np.random.default_rng(0), x_true=np.zeros((2, 3, 1)))
    with pytest.raises(ValueError, match=r"^x_true contains NaN or inf$"):
        o.filter(y, rng=np.random.default_rng(0), x_true=np.full((2, 4, 1), np.inf))


# ------------------------------------------------------------------------------ shared base (filters/base.py)
@pytest.mark.parametrize("m", [1, 2, 3])
def test_gaussian_loglik_is_the_multivariate_normal_logpdf(m):
    """log N(nu; 0, S) per run, against scipy, for m = 1, 2, 3 (the constant is -m/2 log 2 pi: a
    wrong constant is invisible at m = 1 only). IMM mode probabilities will rest on this."""
    from pfrepro.filters.base import gaussian_loglik

    rng = np.random.default_rng(m)
    A = rng.standard_normal((4, m, m))
    S = A @ np.swapaxes(A, -1, -2) + 0.5 * np.eye(m)
    nu = rng.standard_normal((4, m))
    want = [stats.multivariate_normal(np.zeros(m), S[r]).logpdf(nu[r]) for r in range(4)]
    np.testing.assert_allclose(gaussian_loglik(nu, S), want, rtol=1e-12)


def test_kalman_family_log_evidence_is_the_per_run_sum():
    from pfrepro.filters import KalmanFilter

    model = _linear_2d()
    y = np.random.default_rng(12).standard_normal((3, 5, 1))
    d = KalmanFilter(model).filter(y).diagnostics
    assert d["log_evidence"].shape == (3,)
    np.testing.assert_allclose(d["log_evidence"], d["log_likelihood"].sum(axis=1), rtol=1e-12)


def test_filter_prior_override_is_checked_against_dim_x():
    model = _linear_2d()
    with pytest.raises(ValueError, match="P0"):
        BootstrapParticleFilter(model, 10, P0=np.eye(3))
    with pytest.raises(ValueError, match="m0"):
        BootstrapParticleFilter(model, 10, m0=np.zeros(3))
