"""Inner steps of the regularised particle filter (issue 35), pinned by hand-computed cases.

A 2-D state (so that the kernel's covariance factor L has an off-diagonal entry and L and L^T
differ), N = 4 particles, a NONLINEAR measurement y = |x|^2 + e with triangular noise e of
half-width s = 3/2, p(y | x) = max(0, 1 - |y - |x|^2| / s) / s. The test scripts the generator's
normal draws (prior cloud, transition noise, kernel noise eps); the weights are multiples of
1/4, so systematic resampling's offspring counts do not depend on its uniform draw; a spy
model records the cloud it is handed, so the cloud after resampling and jitter is read directly.

Hand computation, step 1 (y_1 = 3), cloud X = [(0, 2), (1/2, -2), (3/2, 3/2), (1/2, 2)]:
    |x|^2 = [4, 17/4, 9/2, 17/4], p(3 | x) = [2/9, 1/9, 0, 1/9], w = [1/2, 1/4, 0, 1/4]
    estimate (pre-resampling) m = (1/4, 1), ESS 1 / (1/4 + 1/16 + 1/16) = 8/3, evidence 1/9
    weighted covariance S = sum w (x - m)(x - m)^T = [[1/16, -1/4], [-1/4, 3]]
        (deviations (-1/4, 1), (1/4, -3), ., (1/4, 1))
    L = chol(S) = [[1/4, 0], [-1, sqrt(2)]]
    counts [2, 1, 0, 1]: resampled [(0, 2), (0, 2), (1/2, -2), (1/2, 2)]
    h = h_opt(N=4, n=2) = (4/4)^(1/6) 4^(-1/6) = 2^(-1/3)
    eps = [(1, 0), (0, 1), (-1, 0), (0, -1)]: L eps_j = (1/4, -1), (0, sqrt 2), (-1/4, 1), (0, -sqrt 2)
(the factor is of S + 1e-12 tr(S)/n I, the ridge of `_weighted_cholesky`: a relative change of
~1e-11, hence the tolerance 1e-9 on the jittered cloud; the ridge itself is pinned on a singular
cloud.)

Each test was checked once against the wrong formula named in its docstring (the formula
applied by hand in src/pfrepro/filters/regularized.py, the test seen to fail, the source
reverted).
"""
from __future__ import annotations

import numpy as np
import pytest

from pfrepro.filters.particle import WeightCollapseWarning
from pfrepro.filters.regularized import RegularizedParticleFilter, _weighted_cholesky, optimal_bandwidth

S_HALF = 1.5
H_OPT_4_2 = 2.0 ** (-1.0 / 3.0)          # h_opt(4, 2) = 4^(-1/6)
R2 = np.sqrt(2.0)

X = np.array([[0.0, 2.0], [0.5, -2.0], [1.5, 1.5], [0.5, 2.0]])
W = np.array([0.5, 0.25, 0.0, 0.25])
L_HAND = np.array([[0.25, 0.0], [-1.0, R2]])
RESAMPLED = np.array([[0.0, 2.0], [0.0, 2.0], [0.5, -2.0], [0.5, 2.0]])
EPS = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
L_EPS = np.array([[0.25, -1.0], [0.0, R2], [-0.25, 1.0], [0.0, -R2]])   # rows L eps_j


class ScriptedNormals(np.random.Generator):
    """A generator whose ``standard_normal`` returns the scripted arrays in order (shape
    checked), zeros once the script is used up; its uniform draws (used by resampling) are a
    real PCG64's unless ``uniforms`` scripts them too."""

    def __init__(self, *normals, uniforms=()):
        super().__init__(np.random.PCG64(0))
        self.normals = [np.asarray(z, float) for z in normals]
        self.uniforms = [np.asarray(u, float) for u in uniforms]

    def random(self, size=None, dtype=np.float64, out=None):
        if not self.uniforms:
            return super().random(size, dtype, out)
        u = self.uniforms.pop(0)
        assert u.shape == tuple(size), (u.shape, size)
        return u.copy()

    def standard_normal(self, size=None, dtype=np.float64, out=None):
        if not self.normals:
            return np.zeros(size)
        z = self.normals.pop(0)
        assert z.shape == tuple(size), (z.shape, size)
        return z.copy()


class RangeSpy:
    """x_k = x_{k-1} + v_k (v_k from the generator), y = |x|^2 + triangular noise; records the
    cloud handed to the transition at each step."""

    dim_x = 2
    dim_y = 1

    def __init__(self):
        self.m0, self.P0 = np.zeros(2), np.eye(2)
        self.handed = {}

    def sample_transition(self, x, k, rng):
        self.handed[k] = x.copy()
        return x + rng.standard_normal(x.shape)

    def log_likelihood(self, y, x):
        r = np.abs(y[:, None, 0] - np.sum(x ** 2, axis=-1))
        with np.errstate(divide="ignore"):
            return np.log(np.maximum(0.0, 1.0 - r / S_HALF) / S_HALF)


def _filter(clouds, ys, eps, ess_threshold=None, bandwidth_scale=1.0):
    """Filter T = 2 steps; ``clouds`` (runs, 4, 2) is the prior draw (the transition noise is
    zero), ``eps`` the kernel noise of the resampled runs."""
    clouds = np.asarray(clouds, float)
    runs = clouds.shape[0]
    model = RangeSpy()
    zero = np.zeros_like(clouds)
    rng = ScriptedNormals(clouds, zero, eps, zero)
    f = RegularizedParticleFilter(model, 4, ess_threshold=ess_threshold, bandwidth_scale=bandwidth_scale)
    res = f.filter(np.asarray(ys, float).reshape(runs, 2, 1), rng)
    return model, res


def test_optimal_bandwidth_hand_values():
    """h_opt = [4/(n+2)]^(1/(n+4)) N^(-1/(n+4)): (4, 1) -> (4/3 / 4)^(1/5) = 3^(-1/5);
    (4, 2) -> 4^(-1/6) = 2^(-1/3); (64, 2) -> 64^(-1/6) = 1/2; (1, 1) -> (4/3)^(1/5).
    Checked against N^(-1/(n+2)) (fails at (4, 1)) and A = [4/(n+1)]^(1/(n+4)) (fails at (64, 2))."""
    assert optimal_bandwidth(4, 1) == pytest.approx(3.0 ** -0.2, rel=1e-14)
    assert optimal_bandwidth(4, 2) == pytest.approx(H_OPT_4_2, rel=1e-14)
    assert optimal_bandwidth(64, 2) == pytest.approx(0.5, rel=1e-14)
    assert optimal_bandwidth(1, 1) == pytest.approx((4 / 3) ** 0.2, rel=1e-14)
    with pytest.raises(ValueError, match=r"^dim must be >= 1"):
        optimal_bandwidth(4, 0)
    with pytest.raises(ValueError, match=r"^n_particles must be >= 1"):
        optimal_bandwidth(0, 1)


def test_weighted_cholesky_is_the_factor_of_the_weighted_covariance():
    """L L^T = sum_i w_i (x_i - m)(x_i - m)^T with m = sum_i w_i x_i: L = [[1/4, 0], [-1, sqrt 2]].
    Checked against the unweighted covariance of the cloud (the zero-weight particle counted)
    and against the deviations from the unweighted mean: both fail."""
    L = _weighted_cholesky(W[None], X[None])
    np.testing.assert_allclose(L[0], L_HAND, rtol=1e-10, atol=1e-15)


def test_weighted_cholesky_ridge_of_a_collinear_cloud():
    """Particles on the line x_2 = x_1, S = [[4, 4], [4, 4]] (singular): the ridge 1e-12 * tr(S)/n
    = 4e-12 makes the factor exist, L = [[2, 0], [2, sqrt(8e-12)]] to first order
    (L22^2 = 4 + 4e-12 - 16 / (4 + 4e-12) = 8e-12). A cloud of identical particles (S = 0) gets
    the floor 1e-300 as its scale and no visible jitter (L ~ 1e-156). Checked against the ridge
    1e-12 * n / tr(S) (L22 = sqrt(2 * 0.25e-12)) and against the floor 1 for the scale: fail."""
    x = np.array([[[-2.0, -2.0], [2.0, 2.0], [-2.0, -2.0], [2.0, 2.0]]])
    L = _weighted_cholesky(np.full((1, 4), 0.25), x)
    assert L[0, 0, 0] == pytest.approx(2.0, rel=1e-10) and L[0, 1, 0] == pytest.approx(2.0, rel=1e-10)
    assert L[0, 0, 1] == 0.0
    assert L[0, 1, 1] == pytest.approx(np.sqrt(8e-12), rel=1e-3)
    same = np.full((1, 4, 2), 3.0)
    L0 = _weighted_cholesky(np.full((1, 4), 0.25), same)
    assert np.all(np.abs(L0) < 1e-100)


def test_rpf_weights_estimate_and_evidence_before_resampling():
    """Step 1: w = [1/2, 1/4, 0, 1/4], the estimate is the pre-resampling weighted mean (1/4, 1),
    ESS 8/3, log evidence increment log(1/9), resampled. Checked against the estimate taken
    after the jitter (the mean of the jittered, resampled cloud): fails."""
    _, res = _filter(X[None], [3.0, 3.0], EPS[None])
    np.testing.assert_allclose(res.x[0, 0], [0.25, 1.0], rtol=1e-12)
    assert res.diagnostics["ess"][0, 0] == pytest.approx(8 / 3, rel=1e-12)
    assert res.diagnostics["resampled"][0, 0]
    # step 2's likelihood at the jittered cloud is not hand-computed; step 1's increment is
    _, res1 = _filter(X[None], [3.0, 3.0], EPS[None], bandwidth_scale=0.0)
    # bandwidth 0: the cloud entering step 2 is RESAMPLED, |x|^2 = [4, 4, 17/4, 17/4],
    # p(3 | x) = [2/9, 2/9, 1/9, 1/9] with uniform weights -> increment 1/6
    np.testing.assert_allclose(res1.diagnostics["log_evidence"], [np.log(1 / 9) + np.log(1 / 6)], rtol=1e-12)
    # and weights 1/N carried (resampled): w_2 = [1/3, 1/3, 1/6, 1/6], estimate (1/6, 4/3)
    np.testing.assert_allclose(res1.x[0, 1], [1 / 6, 4 / 3], rtol=1e-12)
    # the same with ESS threshold 0.8 (3.2 particles): step 1 (ESS 8/3) resamples, step 2
    # (ESS 1 / (2/9 + 2/36) = 18/5) does not; the flags are written at their own step
    _, res2 = _filter(X[None], [3.0, 3.0], EPS[None], ess_threshold=0.8, bandwidth_scale=0.0)
    assert res2.diagnostics["resampled"].dtype == bool
    np.testing.assert_array_equal(res2.diagnostics["resampled"], [[True, False]])
    np.testing.assert_allclose(res2.diagnostics["ess"], [[8 / 3, 18 / 5]], rtol=1e-12)


def test_rpf_jitter_is_h_L_eps_after_resampling():
    """The cloud handed to step 2 is x^{a_j} + h L eps_j with L the factor of the weighted
    covariance of the cloud BEFORE resampling and h = h_opt(4, 2) = 2^(-1/3). Checked against
    ``eps @ L`` (L^T eps_j: (1/4, 0), (-1, sqrt 2), ...), the factor of the resampled (uniform)
    cloud, and the jitter added before resampling: all fail."""
    model, res = _filter(X[None], [3.0, 3.0], EPS[None])
    np.testing.assert_allclose(model.handed[1][0], X, rtol=0, atol=1e-15)
    np.testing.assert_allclose(model.handed[2][0], RESAMPLED + H_OPT_4_2 * L_EPS, rtol=1e-9, atol=1e-15)
    assert res.diagnostics["resampled"].all()


def test_rpf_kernel_covariance_is_the_weighted_cloud_before_resampling():
    """The kernel's covariance is the weighted covariance of the cloud BEFORE resampling, not
    the covariance of the resampled cloud (they coincide when the offspring counts are exactly
    N w, as in the case above, so here the systematic draw is scripted, U = 1/4).
    Cloud on the axis, x = [(0, 0), (1, 0), (2, 0), (3, 0)], y_1 = 3/4: |x|^2 = [0, 1, 4, 9],
    r = [3/4, 1/4, 13/4, 33/4], p = [1/3, 5/9, 0, 0], w = [3/8, 5/8, 0, 0];
    N C = [3/2, 4, 4, 4], counts ceil(N C - 1/4) differences = [2, 2, 0, 0]: resampled first
    coordinates [0, 0, 1, 1] (variance 1/4); weighted mean 5/8, weighted variance
    3/8 * 25/64 + 5/8 * 9/64 = 15/64, L_11 = sqrt(15)/8. Kernel noise first coordinates
    [1, -1, 2, 0]: the cloud handed to step 2 has first coordinates
    [0, 0, 1, 1] + 2^(-1/3) sqrt(15)/8 [1, -1, 2, 0]. Checked against the factor of the
    resampled, equally weighted cloud (1/2 for sqrt(15)/8): fails."""
    x = np.array([[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]]])
    eps = np.array([[[1.0, 0.0], [-1.0, 0.0], [2.0, 0.0], [0.0, 0.0]]])
    model = RangeSpy()
    rng = ScriptedNormals(x, np.zeros_like(x), eps, np.zeros_like(x), uniforms=[[[0.25]]])
    RegularizedParticleFilter(model, 4).filter(np.reshape([0.75, 0.75], (1, 2, 1)), rng)
    want = np.array([0.0, 0.0, 1.0, 1.0]) + H_OPT_4_2 * np.sqrt(15.0) / 8 * np.array([1.0, -1.0, 2.0, 0.0])
    np.testing.assert_allclose(model.handed[2][0, :, 0], want, rtol=1e-9, atol=1e-15)
    assert np.all(np.abs(model.handed[2][0, :, 1]) < 1e-12)


@pytest.mark.parametrize("scale", [0.0, 3.0])
def test_rpf_bandwidth_scale_multiplies_the_optimal_bandwidth(scale):
    """bandwidth = scale * h_opt: scale 0 is the bootstrap PF's resampled cloud, scale 3 triples
    the jitter. Checked against the jitter without the bandwidth (h = 1): fails."""
    model, _ = _filter(X[None], [3.0, 3.0], EPS[None], bandwidth_scale=scale)
    np.testing.assert_allclose(model.handed[2][0], RESAMPLED + scale * H_OPT_4_2 * L_EPS, rtol=1e-9, atol=1e-15)


# run 1 of the ESS-threshold case: |x|^2 = [4, 4, 17/4, 17/4], p(3 | x) = [2/9, 2/9, 1/9, 1/9],
# w = [1/3, 1/3, 1/6, 1/6], ESS 1 / (2/9 + 2/36) = 18/5 = 3.6 >= 0.7 * 4: kept. Step 2 with
# y_2 = 4: p(4 | x) = [2/3, 2/3, 5/9, 5/9]; carried weights times it: [2/9, 2/9, 5/54, 5/54],
# sum 17/27; estimate (33/108, 33/108) / (17/27) = (33/68, 33/68); increment 17/27.
# (Uniform weights carried instead: estimate 9/44.)
X_KEEP = np.array([[0.0, 2.0], [2.0, 0.0], [0.5, -2.0], [-2.0, 0.5]])


def test_rpf_ess_threshold_jitters_only_the_resampled_run_and_keeps_the_other_weights():
    """ESS threshold 0.7: run 0 (ESS 8/3 < 2.8) resamples and is jittered with kernel noise of
    shape (1, N, n); run 1 (ESS 3.6) keeps its cloud unjittered and carries its weights into step
    2: estimate (33/68, 33/68), log evidence log(1/6) + log(17/27). Checked against the kept
    run's weights reset to 1/N (estimate 9/44) and against the jitter applied to every run: both
    fail."""
    model, res = _filter(np.stack([X, X_KEEP]), [[3.0, 3.0], [3.0, 4.0]], EPS[None], ess_threshold=0.7)
    np.testing.assert_array_equal(res.diagnostics["resampled"][:, 0], [True, False])
    np.testing.assert_allclose(res.diagnostics["ess"][:, 0], [8 / 3, 18 / 5], rtol=1e-12)
    np.testing.assert_allclose(model.handed[2][0], RESAMPLED + H_OPT_4_2 * L_EPS, rtol=1e-9, atol=1e-15)
    np.testing.assert_array_equal(model.handed[2][1], X_KEEP)
    np.testing.assert_allclose(res.x[1, 1], [33 / 68, 33 / 68], rtol=1e-12)
    assert res.diagnostics["log_evidence"][1] == pytest.approx(np.log(1 / 6) + np.log(17 / 27), rel=1e-12)


X_EQUAL = np.array([[0.0, 2.0], [2.0, 0.0], [0.0, -2.0], [-2.0, 0.0]])     # |x|^2 = 4 for all: w = 1/4


def test_rpf_ess_threshold_boundary_is_strict():
    """Resample where ESS < threshold * N, not <=: equal weights give ESS = 4 = 1.0 * N exactly,
    so at threshold 1 that run is kept (and its cloud is not jittered). Checked against ``<=``:
    fails."""
    model, res = _filter(np.stack([X, X_EQUAL]), [[3.0, 3.0], [3.0, 3.0]], EPS[None], ess_threshold=1.0)
    np.testing.assert_array_equal(res.diagnostics["ess"][:, 0], [8 / 3, 4.0])
    np.testing.assert_array_equal(res.diagnostics["resampled"][:, 0], [True, False])
    np.testing.assert_array_equal(model.handed[2][1], X_EQUAL)


def test_rpf_repr_and_attributes():
    f = RegularizedParticleFilter(RangeSpy(), 4, resampling="stratified", ess_threshold=0.5, bandwidth_scale=2.0)
    assert repr(f) == ("RegularizedParticleFilter(N=4, resampling='stratified', ess_threshold=0.5, "
                       "bandwidth_scale=2.0)")
    assert f.bandwidth == pytest.approx(2.0 * H_OPT_4_2, rel=1e-14)
    assert f.name == "RPF"
    g = RegularizedParticleFilter(RangeSpy(), 4)
    assert g.resampling == "systematic" and g.ess_threshold is None and g.bandwidth_scale == 1.0
    with pytest.raises(ValueError, match=r"^ess_threshold must lie in \[0, 1\]"):
        RegularizedParticleFilter(RangeSpy(), 4, ess_threshold=1.5)
    with pytest.raises(ValueError, match=r"^bandwidth_scale must be >= 0"):
        RegularizedParticleFilter(RangeSpy(), 4, bandwidth_scale=-1.0)
    with pytest.raises(ValueError, match=r"^n_particles must be >= 1"):
        RegularizedParticleFilter(RangeSpy(), 0)
    h = RegularizedParticleFilter(RangeSpy(), 4, m0=[1.0, 2.0], P0=np.diag([4.0, 9.0]))
    np.testing.assert_array_equal(h.m0, [1.0, 2.0])
    np.testing.assert_array_equal(h.P0, np.diag([4.0, 9.0]))


def test_rpf_collapse_is_flagged_at_its_step():
    """Step 2 with y_2 = 50: every particle is outside the noise's support, the step collapses:
    flagged at step 2 (not step 1), warned as "RPF: ...", evidence 0. Checked against the flag
    written at column k - 2: fails."""
    with pytest.warns(WeightCollapseWarning, match=r"^RPF: weight collapse in 1 of 2 run-steps"):
        _, res = _filter(X[None], [3.0, 50.0], EPS[None])
    assert res.diagnostics["collapsed"].dtype == bool
    np.testing.assert_array_equal(res.diagnostics["collapsed"], [[False, True]])
    assert res.diagnostics["n_collapsed"] == 1 and res.diagnostics["log_evidence"][0] == -np.inf


class SteepRangeSpy(RangeSpy):
    """log p = -1e5 (y - |x|^2)^2: the normalisation's exp underflows for all but the best."""

    def log_likelihood(self, y, x):
        return -1e5 * (y[:, None, 0] - np.sum(x ** 2, axis=-1)) ** 2


def test_rpf_runs_under_floating_point_errors_raised():
    """Under ``np.errstate(all="raise")`` the hand case (log of a zero weight: divide) and a steep
    likelihood (exp underflow: under) run as before. Checked against the filter's
    ``np.errstate`` without ``divide`` or ``under``: each raises FloatingPointError."""
    with np.errstate(all="raise"):
        model, _ = _filter(X[None], [3.0, 3.0], EPS[None])
        np.testing.assert_allclose(model.handed[2][0], RESAMPLED + H_OPT_4_2 * L_EPS, rtol=1e-9, atol=1e-15)
        zero = np.zeros((1, 4, 2))
        rng = ScriptedNormals(X[None], zero, zero, zero)
        res = RegularizedParticleFilter(SteepRangeSpy(), 4).filter(np.reshape([4.0, 4.0], (1, 2, 1)), rng)
        # |x|^2 = [4, 17/4, 9/2, 17/4], y = 4: log p = -1e5 [0, 1/16, 1/4, 1/16] = [0, -6250, -25000,
        # -6250]: exp underflows to 0 but for (0, 2), which takes all the weight (ESS 1); the
        # resampled cloud has no spread, so no jitter: all four particles enter step 2 at (0, 2)
        assert res.diagnostics["ess"][0, 0] == 1.0
        np.testing.assert_array_equal(res.x[0, 0], [0.0, 2.0])
        np.testing.assert_array_equal(res.x[0, 1], [0.0, 2.0])
