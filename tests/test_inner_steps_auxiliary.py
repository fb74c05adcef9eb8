"""Inner steps of the auxiliary particle filter (issue 35), pinned by a hand-computed case.

One run, N = 4 particles, two steps, a random walk x_k = x_{k-1} + v_k (so the look-ahead point
is mu_k^i = f(x_{k-1}^i) = x_{k-1}^i) and a NONLINEAR measurement y = x^2 + e with triangular
noise e of half-width s = 3/2:

    p(y | x) = max(0, 1 - |y - x^2| / s) / s,

whose values at the half-integer points used here are rational and which is zero outside
|y - x^2| < s (so a look-ahead can drop a particle before it is propagated, the APF's point).
The test scripts the generator's normal draws (the prior cloud and the transition noise); the
first-stage weights are multiples of 1/4, so the offspring counts of systematic, stratified and
residual resampling do not depend on the uniform draw. A spy model records every call, so the
look-ahead points, the resampled cloud and the propagated cloud are read directly.

Hand computation (y_1 = 1, y_2 = 3/2):

step 1  x_0 = [-3/2, 0, 3/2, 2]             mu_1 = x_0, mu^2 = [9/4, 0, 9/4, 4]
        p(y_1 | mu_1) = [1/9, 2/9, 1/9, 0]   first stage lambda_1 = [1/4, 1/2, 1/4, 0]
        counts [1, 2, 1, 0]: resampled [-3/2, 0, 0, 3/2], p(y_1 | mu^a) = [1/9, 2/9, 2/9, 1/9]
        noise [0, 1/2, -1/2, 1]: x_1 = [-3/2, 1/2, -1/2, 5/2], p(y_1 | x_1) = [1/9, 1/3, 1/3, 0]
        second stage p(y|x)/p(y|mu^a) = [1, 3/2, 3/2, 0], w_1 = [1/4, 3/8, 3/8, 0]
        estimate -3/8, ESS 32/11, first-stage ESS 8/3,
        evidence [1/4 sum p(y|mu)] [1/4 sum second] = (1/9)(1) = 1/9
step 2  mu_2 = x_1, p(y_2 | mu_2) = [1/3, 1/9, 1/9, 0]
        first stage w_1 p = [1/12, 1/24, 1/24, 0] / (1/6) = [1/2, 1/4, 1/4, 0]
            (with the weights w_1 NOT carried, i.e. uniform: [3/5, 1/5, 1/5, 0])
        counts [2, 1, 1, 0]: resampled [-3/2, -3/2, 1/2, -1/2], p(y_2 | mu^a) = [1/3, 1/3, 1/9, 1/9]
        noise [-1/2, 0, 1/2, 1]: x_2 = [-2, -3/2, 1, 1/2], p(y_2 | x_2) = [0, 1/3, 4/9, 1/9]
        second stage [0, 1, 4, 1], w_2 = [0, 1/6, 2/3, 1/6]
        estimate -1/4 + 2/3 + 1/12 = 1/2, ESS 1 / (1/36 + 16/36 + 1/36) = 2, first-stage ESS 8/3,
        evidence [sum w_1 p(y|mu)] [1/4 sum second] = (1/6)(6/4) = 1/4
log evidence log(1/9) + log(1/4) = log(1/36).

Each test was checked once against the wrong formula named in its docstring (the formula
applied by hand in src/pfrepro/filters/auxiliary.py, the test seen to fail, the source
reverted).
"""
from __future__ import annotations

import numpy as np
import pytest

from pfrepro.filters.auxiliary import AuxiliaryParticleFilter
from pfrepro.filters.particle import WeightCollapseWarning

S_HALF = 1.5                       # the triangular noise's half-width s


class ScriptedNormals(np.random.Generator):
    """A generator whose ``standard_normal`` returns the scripted arrays in order (shape
    checked); its uniform draws (used by resampling) are a real PCG64's."""

    def __init__(self, *normals):
        super().__init__(np.random.PCG64(0))
        self.normals = [np.asarray(z, float) for z in normals]

    def standard_normal(self, size=None, dtype=np.float64, out=None):
        z = self.normals.pop(0)
        assert z.shape == tuple(size), (z.shape, size)
        return z.copy()


class SquareSpy:
    """x_k = x_{k-1} + v_k (v_k from the generator), y = x^2 + triangular noise of half-width s;
    every call is recorded as (name, k, input array)."""

    dim_x = 1
    dim_y = 1

    def __init__(self):
        self.m0, self.P0 = np.zeros(1), np.eye(1)
        self.calls = []

    def f(self, x, k):
        self.calls.append(("f", k, x.copy()))
        return x.copy()

    def sample_transition(self, x, k, rng):
        self.calls.append(("transition", k, x.copy()))
        return x + rng.standard_normal(x.shape)

    def log_likelihood(self, y, x):
        self.calls.append(("likelihood", float(y[0, 0]), x.copy()))
        r = np.abs(y[:, None, 0] - x[..., 0] ** 2)
        with np.errstate(divide="ignore"):
            return np.log(np.maximum(0.0, 1.0 - r / S_HALF) / S_HALF)

    def inputs(self, name, k):
        return [c[2] for c in self.calls if c[0] == name and c[1] == k]


X0 = [-1.5, 0.0, 1.5, 2.0]
NOISE1 = [0.0, 0.5, -0.5, 1.0]
NOISE2 = [-0.5, 0.0, 0.5, 1.0]
Y = [1.0, 1.5]


def _run(resampling="systematic", T=2):
    model = SquareSpy()
    rng = ScriptedNormals(np.reshape(X0, (1, 4, 1)), np.reshape(NOISE1, (1, 4, 1)),
                          np.reshape(NOISE2, (1, 4, 1)))
    res = AuxiliaryParticleFilter(model, 4, resampling=resampling).filter(
        np.reshape(Y[:T], (1, T, 1)), rng)
    return model, res


def _cloud(a):
    return np.asarray(a)[0, :, 0]


@pytest.mark.parametrize("resampling", ["systematic", "stratified", "residual"])
def test_apf_first_stage_weights_and_ancestors(resampling):
    """Step 1: lambda ∝ w_0 p(y_1 | mu^i) = [1/4, 1/2, 1/4, 0] (first-stage ESS 8/3) and the
    cloud propagated is the look-ahead's resampled one [-3/2, 0, 0, 3/2]; the look-ahead is taken
    at f(x_0) with y_1. Checked against the bootstrap's first stage (lambda = w_{k-1}, no
    look-ahead likelihood): ESS 4 and every particle propagated once."""
    model, res = _run(resampling)
    assert res.diagnostics["first_stage_ess"][0, 0] == pytest.approx(8 / 3, rel=1e-12)
    (f1,) = model.inputs("f", 1)
    np.testing.assert_array_equal(_cloud(f1), X0)
    (g1,) = model.inputs("transition", 1)
    np.testing.assert_allclose(_cloud(g1), [-1.5, 0.0, 0.0, 1.5], rtol=0, atol=1e-15)
    # the first likelihood call is the look-ahead one, with y_1 at mu_1 = x_0
    assert model.calls[1][0] == "likelihood" and model.calls[1][1] == Y[0]
    np.testing.assert_array_equal(_cloud(model.calls[1][2]), X0)


def test_apf_second_stage_weights():
    """Step 1: w_1 ∝ p(y_1 | x_1^j) / p(y_1 | mu^{a^j}) = [1, 3/2, 3/2, 0] / 4: estimate -3/8,
    ESS 32/11. Checked against the second stage without the division (w ∝ p(y | x), estimate
    -3/14) and against dividing by the look-ahead likelihoods in the particles' old order
    (not carried with the ancestors): both fail."""
    _, res = _run(T=1)
    assert res.x[0, 0, 0] == pytest.approx(-3 / 8, rel=1e-12)
    assert res.diagnostics["ess"][0, 0] == pytest.approx(32 / 11, rel=1e-12)


def test_apf_second_stage_weights_are_carried_into_the_next_first_stage():
    """Step 2: lambda_2 ∝ w_1 p(y_2 | mu_2) = [1/2, 1/4, 1/4, 0] (with w_1 = [1/4, 3/8, 3/8, 0]
    carried; uniform weights would give [3/5, 1/5, 1/5, 0]), so the cloud propagated at step 2 is
    [-3/2, -3/2, 1/2, -1/2]; the step's estimate is 1/2 with ESS 2. Checked against
    ``logw`` not updated after step 1 (uniform carry): the ESS and the estimate fail."""
    model, res = _run()
    (f2,) = model.inputs("f", 2)
    np.testing.assert_allclose(_cloud(f2), [-1.5, 0.5, -0.5, 2.5], rtol=0, atol=1e-15)
    assert res.diagnostics["first_stage_ess"][0, 1] == pytest.approx(8 / 3, rel=1e-12)
    (g2,) = model.inputs("transition", 2)
    np.testing.assert_allclose(_cloud(g2), [-1.5, -1.5, 0.5, -0.5], rtol=0, atol=1e-15)
    np.testing.assert_allclose(res.x[0, :, 0], [-3 / 8, 1 / 2], rtol=1e-12)
    np.testing.assert_allclose(res.diagnostics["ess"][0], [32 / 11, 2.0], rtol=1e-12)
    np.testing.assert_allclose(res.diagnostics["first_stage_ess"][0], [8 / 3, 8 / 3], rtol=1e-12)
    assert not res.diagnostics["collapsed"].any() and res.diagnostics["n_collapsed"] == 0


def test_apf_evidence_increments():
    """p̂(y_k | y_1:k-1) = [sum_i w_{k-1}^i p(y_k | mu^i)] [1/N sum_j second_j]:
    1/9 at step 1 and 1/4 at step 2, log evidence log(1/36). Checked against the increment
    without the 1/N of the second factor (log(4/9) + log(1)) and against log_a alone."""
    _, res = _run()
    assert res.diagnostics["log_evidence"][0] == pytest.approx(np.log(1 / 36), rel=1e-12)
    _, res1 = _run(T=1)
    assert res1.diagnostics["log_evidence"][0] == pytest.approx(np.log(1 / 9), rel=1e-12)


def test_apf_second_stage_collapse_is_flagged_per_step():
    """Step 2 with y_2 = 20: the look-ahead and the propagated particles are all outside the
    noise's support (|20 - x^2| >= 3/2), both stages collapse, the step is flagged, a
    WeightCollapseWarning is issued and the evidence is 0; step 1 is untouched. Checked against
    the flag not written (``collapsed[:, k - 1]`` left False): fails."""
    model = SquareSpy()
    rng = ScriptedNormals(np.reshape(X0, (1, 4, 1)), np.reshape(NOISE1, (1, 4, 1)),
                          np.reshape(NOISE2, (1, 4, 1)))
    with pytest.warns(WeightCollapseWarning, match=r"^APF: weight collapse in 1 of 2 run-steps"):
        res = AuxiliaryParticleFilter(model, 4).filter(np.reshape([1.0, 20.0], (1, 2, 1)), rng)
    assert res.diagnostics["collapsed"].dtype == bool
    np.testing.assert_array_equal(res.diagnostics["collapsed"], [[False, True]])
    assert res.diagnostics["n_collapsed"] == 1
    assert res.diagnostics["log_evidence"][0] == -np.inf
    assert res.x[0, 0, 0] == pytest.approx(-3 / 8, rel=1e-12)


def test_apf_collapse_of_the_second_stage_alone_is_flagged():
    """The look-ahead keeps the hand case's particles (first stage as above, resampled
    [-3/2, 0, 0, 3/2]) but the transition noise 5 throws every one of them out of the noise's
    support (x^2 >= 12.25, y_1 = 1): only the second stage collapses, the step is flagged, its
    weights are uniform (estimate (3.5 + 5 + 5 + 6.5)/4 = 5) and the evidence is 0. Checked
    against ``collapsed = coll1 & coll2``: fails. (The first stage alone cannot collapse without
    an error: see the report of issue 35 -- every look-ahead likelihood 0 makes the second stage
    +inf where a propagated particle has a positive likelihood.)"""
    model = SquareSpy()
    rng = ScriptedNormals(np.reshape(X0, (1, 4, 1)), np.full((1, 4, 1), 5.0))
    with pytest.warns(WeightCollapseWarning, match=r"^APF: "):
        res = AuxiliaryParticleFilter(model, 4).filter(np.reshape([1.0], (1, 1, 1)), rng)
    np.testing.assert_array_equal(res.diagnostics["collapsed"], [[True]])
    assert res.diagnostics["log_evidence"][0] == -np.inf
    assert res.x[0, 0, 0] == pytest.approx(5.0, rel=1e-12)
    assert res.diagnostics["first_stage_ess"][0, 0] == pytest.approx(8 / 3, rel=1e-12)


class SteepSpy(SquareSpy):
    """The same dynamics with a Gaussian-like likelihood 1000 nats steep: log p = -1000 (y - x^2)^2,
    so that the normalisation's exp underflows for every particle but the best."""

    def log_likelihood(self, y, x):
        return -1000.0 * (y[:, None, 0] - x[..., 0] ** 2) ** 2


def test_apf_runs_under_floating_point_errors_raised():
    """The filter keeps its own floating-point error state: under ``np.errstate(all="raise")``
    the hand case (log of zero weights: divide), a collapse (-inf - -inf: invalid) and a steep
    likelihood (exp underflow: under) give the same numbers as before, without a
    FloatingPointError. Checked against the filter's ``np.errstate`` without ``divide``,
    ``invalid`` or ``under``: each raises."""
    with np.errstate(all="raise"):
        _, res = _run()
        np.testing.assert_allclose(res.x[0, :, 0], [-3 / 8, 1 / 2], rtol=1e-12)
        rng = ScriptedNormals(np.reshape(X0, (1, 4, 1)), np.reshape(NOISE1, (1, 4, 1)),
                              np.reshape(NOISE2, (1, 4, 1)))
        with pytest.warns(WeightCollapseWarning):
            res = AuxiliaryParticleFilter(SquareSpy(), 4).filter(np.reshape([1.0, 20.0], (1, 2, 1)), rng)
        assert res.diagnostics["log_evidence"][0] == -np.inf
        rng = ScriptedNormals(np.reshape(X0, (1, 4, 1)), np.zeros((1, 4, 1)))
        res = AuxiliaryParticleFilter(SteepSpy(), 4).filter(np.reshape([0.0], (1, 1, 1)), rng)
        # look-ahead log p(0 | mu) = -1000 mu^4 = [-5062.5, 0, -5062.5, -16000]: exp underflows
        # to 0 for all but x = 0, whose four copies are propagated without noise: second stage
        # 0 - 0, estimate 0, ESS 4
        assert res.x[0, 0, 0] == 0.0 and res.diagnostics["ess"][0, 0] == pytest.approx(4.0)
        assert res.diagnostics["first_stage_ess"][0, 0] == pytest.approx(1.0)


def test_apf_initial_distribution_override():
    """m0, P0 given to the filter replace the model's: the prior cloud is m0 + z chol(P0)^T,
    here 1 + 2 z. Checked against the override dropped (``super().__init__(model, None, P0)``):
    fails."""
    f = AuxiliaryParticleFilter(SquareSpy(), 4, m0=[1.0], P0=[[4.0]])
    np.testing.assert_array_equal(f.m0, [1.0])
    np.testing.assert_array_equal(f.P0, [[4.0]])
    model = SquareSpy()
    rng = ScriptedNormals(np.reshape(X0, (1, 4, 1)), np.zeros((1, 4, 1)))
    AuxiliaryParticleFilter(model, 4, m0=[1.0], P0=[[4.0]]).filter(np.reshape([1.0], (1, 1, 1)), rng)
    np.testing.assert_allclose(_cloud(model.inputs("f", 1)[0]), 1.0 + 2.0 * np.array(X0), rtol=1e-15)


def test_apf_runs_are_filtered_independently():
    """Two runs with different measurements: run 1 (y = [1, 3/2], the hand case) gives the hand
    numbers whatever run 0 does (y_1 = 0: p(0 | mu) = [0, 2/3, 0, 0], every particle but one
    dropped, first-stage ESS 1). Checked against the first-stage ESS summed over all runs
    (einsum "rn,rn->" ) by hand: fails."""
    model = SquareSpy()
    x0 = np.reshape(X0 * 2, (2, 4, 1))
    rng = ScriptedNormals(x0, np.reshape(NOISE1 * 2, (2, 4, 1)), np.reshape(NOISE2 * 2, (2, 4, 1)))
    y = np.array([[[0.0], [1.5]], [[1.0], [1.5]]])
    res = AuxiliaryParticleFilter(model, 4).filter(y, rng)
    assert res.diagnostics["first_stage_ess"][0, 0] == pytest.approx(1.0)
    np.testing.assert_allclose(res.x[1, :, 0], [-3 / 8, 1 / 2], rtol=1e-12)
    np.testing.assert_allclose(res.diagnostics["first_stage_ess"][1], [8 / 3, 8 / 3], rtol=1e-12)
    assert res.diagnostics["log_evidence"][1] == pytest.approx(np.log(1 / 36), rel=1e-12)
    # run 0, step 1: only particle 1 (x = 0) survives the look-ahead; its four copies are
    # propagated to [0, 1/2, -1/2, 1], p(0 | x) = [2/3, 5/9, 5/9, 2/9], divided by p(0 | 0) = 2/3:
    # second stage [1, 5/6, 5/6, 1/3] / 3, estimate (5/36 - 5/36 + 1/9) = 1/9, ESS 324/90 = 18/5
    assert res.x[0, 0, 0] == pytest.approx(1 / 9, rel=1e-12)
    assert res.diagnostics["ess"][0, 0] == pytest.approx(18 / 5, rel=1e-12)


def test_apf_repr_and_name():
    f = AuxiliaryParticleFilter(SquareSpy(), 7, resampling="residual")
    assert repr(f) == "AuxiliaryParticleFilter(N=7, resampling='residual')"
    assert f.name == "APF" and f.n_particles == 7 and f.resampling == "residual"
    assert AuxiliaryParticleFilter(SquareSpy(), 3).resampling == "systematic"
    with pytest.raises(ValueError, match=r"^n_particles must be >= 1"):
        AuxiliaryParticleFilter(SquareSpy(), 0)


def test_apf_first_stage_collapse_falls_back_to_a_bootstrap_step():
    """No look-ahead point explains y_1 = 6.5: p(y_1 | mu^i) = 0 for mu^2 = [9/4, 0, 9/4, 4]
    (|6.5 - mu^2| >= 3/2), so the first stage collapses. The run then takes a bootstrap step:
    ancestors from w_0 (uniform: each particle once), x_1 = [-3/2, 0, 3/2, 5/2],
    p(y_1 | x_1) = [0, 0, 0, (1 - 1/6) / (3/2) = 5/9], so w_1 = [0, 0, 0, 1], estimate 5/2, ESS 1,
    evidence (1/4)(5/9) = 5/36, and the step is flagged collapsed. Checked against the code before
    this fix, where the second stage p(y|x) / p(y|mu) = (5/9) / 0 = +inf raised ValueError."""
    model = SquareSpy()
    rng = ScriptedNormals(np.reshape(X0, (1, 4, 1)), np.reshape([0.0, 0.0, 0.0, 0.5], (1, 4, 1)))
    with pytest.warns(WeightCollapseWarning, match="^APF:"):
        res = AuxiliaryParticleFilter(model, 4).filter(np.reshape([6.5], (1, 1, 1)), rng)
    np.testing.assert_allclose(_cloud(model.inputs("transition", 1)[0]), X0)   # every particle once
    assert res.x[0, 0, 0] == pytest.approx(2.5, rel=1e-12)
    assert res.diagnostics["ess"][0, 0] == pytest.approx(1.0, rel=1e-12)
    assert res.diagnostics["first_stage_ess"][0, 0] == pytest.approx(4.0, rel=1e-12)
    assert res.diagnostics["log_evidence"][0] == pytest.approx(np.log(5 / 36), rel=1e-12)
    assert res.diagnostics["collapsed"][0, 0] and res.diagnostics["collapsed"].dtype == bool
