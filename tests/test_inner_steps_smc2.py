"""Inner steps of SMC² (:mod:`pfrepro.filters.smc2`), pinned by hand (issue 35).

Every random number SMC² draws comes from a scripted source (``ScriptedStreams``: each draw
is the next array of a script, its method and shape checked), and the model is a stub with
deterministic dynamics (Q = 0: no draw) and a NONLINEAR measurement,

    x_k = θ x_{k-1} + k,     y_k = x_k² + v,  v ~ N(0, 1),

so each step -- the state PFs' weights, evidence increments and systematic resampling; the
θ-weights, estimates and evidence; the θ-resampling, the random-walk PMMH proposal scaled by
the cloud's spread (and its floor), the bounds of the uniform prior, the acceptance ratio,
the state carried by an accepted and a rejected move; the weights carried after a
rejuvenation -- is checked against numbers worked out by hand below, with the θ-posterior
piled up NEAR THE PRIOR'S BOUNDS (proposals that leave the support must be rejected
whatever their likelihood).

Each test was checked once against the wrong formula named in its docstring (applied by hand
to ``src/``, the test failed, reverted).
"""
from __future__ import annotations

import numpy as np
import pytest

from pfrepro.filters.smc2 import SMC2, _systematic_counts_nd
from pfrepro.models.parameterized import ParameterizedModel
from scripted_streams import ScriptedStreams

LOG_2PI_2 = 0.5 * np.log(2 * np.pi)


# ------------------------------------------------------------------------------ stubs
class SquareObs(ParameterizedModel):
    """x_k = θ x_{k-1} + k (Q = 0), y_k = x_k² + v, v ~ N(0, 1); prior N(0, 1); records the
    (k, θ shape) of every transition."""

    def __init__(self, bounds=(0.0, 1.0)):
        mid = 0.5 * (bounds[0] + bounds[1])
        super().__init__(1, 1, 1, 0.0, 1.0, [0.0], [0.0], 1.0, [mid], bounds)
        self.calls, self.thetas = [], []

    def f(self, x, k, theta):
        self.calls.append((k, np.shape(theta)))
        self.thetas.append(np.array(theta))
        return theta * x + k

    def h(self, x):
        return x ** 2


def ll(y, x):
    """The stub's log p(y | x), written out: -(y - x²)²/2 - log(2π)/2."""
    return -0.5 * (y - np.asarray(x) ** 2) ** 2 - LOG_2PI_2


def pf1(theta, x0, ys):
    """log p̂(y_1:k | θ) of a one-particle PF (N_x = 1: the likelihood itself) started at x0,
    and its final state: x_j = θ x_{j-1} + j."""
    x, tot = x0, 0.0
    for j, y in enumerate(ys, start=1):
        x = theta * x + j
        tot += ll(y, x)
    return tot, x


# ------------------------------------------------------------------------------ 1. counts
def test_systematic_counts_nd_by_hand():
    """counts_i = ceil(N C_i - u) - ceil(N C_{i-1} - u) per cloud on a (2, 2, 4) stack:
    (.1 .2 .3 .4), u = .5: N C - u = (-.1, .7, 1.9, 3.5) -> (0, 1, 2, 4) -> (0, 1, 1, 2);
    (.4 .3 .2 .1), u = .05: (1.55, 2.75, 3.55, 3.95) -> (2, 3, 4, 4) -> (2, 1, 1, 0);
    the same with u = .95: (.65, 1.85, 2.65, 3.05) -> (1, 1, 1, 1);
    unnormalised (2, 2, 2, 2), u = .5: rescaled to N C = (1, 2, 3, 4) -> (1, 1, 1, 1).
    Checked against ``floor`` for ``ceil`` and ``c *= N`` (no rescaling)."""
    w = np.array([[[0.1, 0.2, 0.3, 0.4], [0.4, 0.3, 0.2, 0.1]],
                  [[0.4, 0.3, 0.2, 0.1], [2.0, 2.0, 2.0, 2.0]]])
    u = np.array([[[0.5], [0.05]], [[0.95], [0.5]]])
    got = _systematic_counts_nd(w, u)
    np.testing.assert_array_equal(got, [[[0, 1, 1, 2], [2, 1, 1, 0]], [[1, 1, 1, 1], [1, 1, 1, 1]]])
    assert got.dtype == np.intp


# ------------------------------------------------------------------------------ 2. one PF step
TH2 = np.array([[0.2, 0.9]])                                # one run, M = 2 θ-particles
X2 = np.array([[[1.0, 2.0, -1.0], [0.5, 0.1, 0.0]]])[..., None]   # N_x = 3 state particles each
# step k = 2: x' = θ x + 2 -> (2.2, 2.4, 1.8) and (2.45, 2.09, 2.0); y_2 = 5
XP2 = np.array([[2.2, 2.4, 1.8], [2.45, 2.09, 2.0]])


def test_pf_step_weights_evidence_and_resampling_by_hand():
    """One bootstrap-PF step of every θ-particle's cloud at k = 2: x' = θ^m x + 2 (θ broadcast
    over the cloud, the step index passed on), log p̂(y_2 | θ^m) = log((1/N) sum_n p(y_2 | x'_n)),
    and systematic resampling of each cloud with its own uniform: cloud 0 (u = .6) has
    N C = (1.520, 2.673, 3), counts (1, 2, 0); cloud 1 (u = .95) N C = (.894, 2.104, 3),
    ceil(N C - u) = (0, 2, 3), counts (0, 2, 1).
    Checked against log p̂ without the -log N, against resampling both clouds with one cloud's
    weights, and against the transition at step k - 1."""
    m = SquareObs()
    f = SMC2(m, 2, 3)
    rng = ScriptedStreams(1, [("random", [[[0.6], [0.95]]])])
    x, inc = f._pf_step(X2.copy(), TH2, np.array([[5.0]]), 2, rng)
    assert m.calls == [(2, (1, 2, 1, 1))]
    lik = np.exp(ll(5.0, XP2) + LOG_2PI_2)
    np.testing.assert_allclose(inc, [np.log(lik.mean(axis=1)) - LOG_2PI_2], rtol=1e-12)
    w = lik / lik.sum(axis=1, keepdims=True)
    c0 = 3 * np.cumsum(w[0])
    np.testing.assert_allclose(c0, [1.51971583, 2.67289584, 3.0], rtol=1e-8)
    np.testing.assert_allclose(3 * np.cumsum(w[1]), [0.89386181, 2.10389794, 3.0], rtol=1e-8)
    np.testing.assert_array_equal(x[0, 0, :, 0], [2.2, 2.4, 2.4])
    np.testing.assert_array_equal(x[0, 1, :, 0], [2.09, 2.09, 2.0])


def test_run_pf_starts_fresh_and_sums_the_increments():
    """A fresh PF per θ over y_1:2: clouds drawn from the prior (the scripted N(0, 1) draws,
    not the current clouds), steps k = 1 and 2 with y_1 and y_2, log p̂(y_1:2 | θ) = the sum
    of the two increments. N_x = 1: p̂ is the likelihood itself and x follows x_j = θ x_{j-1} + j.
    Checked against steps numbered from 0 and against keeping only the last increment."""
    m = SquareObs()
    f = SMC2(m, 2, 1)
    theta = np.array([[0.3, 0.8]])
    x0 = np.array([[[[0.5]], [[-1.0]]]])
    rng = ScriptedStreams(1, [("standard_normal", x0), ("random", np.full((1, 2, 1), 0.5)),
                              ("random", np.full((1, 2, 1), 0.5))])
    ys = [2.0, 6.0]
    x, tot = f._run_pf(theta, np.array([[[ys[0]], [ys[1]]]]), rng)
    assert [k for k, _ in m.calls] == [1, 2]
    # θ = 0.3: x_1 = 0.15 + 1 = 1.15, x_2 = 0.345 + 2 = 2.345; θ = 0.8: x_1 = 0.2, x_2 = 2.16
    np.testing.assert_allclose(x[0, :, 0, 0], [2.345, 2.16], rtol=1e-12)
    np.testing.assert_allclose(tot[0], [ll(2.0, 1.15) + ll(6.0, 2.345), ll(2.0, 0.2) + ll(6.0, 2.16)], rtol=1e-12)
    assert rng.script == []


# ------------------------------------------------------------------------------ 3. PMMH move near the upper bound
# M = 4 θ-particles piled up below the upper bound 1 of the prior U(0, 1), N_x = 1, y_1 = 4
TH_IN = np.array([[0.90, 0.95, 0.97, 0.99]])
W_IN = np.array([[0.1, 0.2, 0.3, 0.4]])          # u = .5: N C - u = (-.1, .7, 1.9, 3.5), counts (0, 1, 1, 2)
LL_IN = np.array([[-5.0, -3.0, 0.5, -2.0]])
X_IN = np.array([[10.0, 20.0, 30.0, 40.0]])[..., None, None]
# after resampling: θ = (.95, .97, .99, .99), loglik = (-3, .5, -2, -2), x = (20, 30, 40, 40)
TH_R = np.array([0.95, 0.97, 0.99, 0.99])
SD_R = np.sqrt(((TH_R - 0.975) ** 2).mean())     # equal weights after resampling: sqrt(2.75e-4) = 0.016583
Z_RW = np.array([-1.0, 1.0, 1.0, -2.0])          # proposals (.93342, .98658, 1.00658 (outside), .95683)
X0_NEW = np.ones(4)                               # the fresh PFs' initial states


def _upper_case():
    prop = TH_R + SD_R * Z_RW
    ll_new = np.array([pf1(min(p, 1.0), 1.0, [4.0])[0] for p in prop])
    return prop, ll_new


def test_hand_numbers_of_the_upper_bound_move():
    prop, ll_new = _upper_case()
    assert SD_R == pytest.approx(0.0165831, rel=1e-5)
    np.testing.assert_allclose(prop, [0.9334169, 0.9865831, 1.0065831, 0.9568338], rtol=1e-6)
    assert prop[2] > 1.0 and np.all(prop[[0, 1, 3]] < 1.0)
    # acceptance ratios p̂(y | θ') / p̂(y | θ) (uniform prior: 1 inside, 0 outside)
    ratio = np.exp(ll_new - np.array([-3.0, 0.5, -2.0, -2.0]))
    np.testing.assert_allclose(ratio, [7.7428, 0.24162, 2.9478, 2.9051], rtol=1e-4)


# u: p0 accepted (ratio 7.7 > 1), p1 rejected (u = .25 > ratio .2416, accepted with the
# inverse ratio), p2 outside the prior's support with u = 1e-12: rejected although its
# clipped-to-the-bound PF has ratio 2.95 > 1, p3 accepted (ratio 2.91, u = .999)
U_ACC = np.array([0.5, 0.25, 1e-12, 0.999])


def _rejuvenate_upper(**kw):
    m = SquareObs((0.0, 1.0))
    f = SMC2(m, 4, 1, **kw)
    script = [("random", [[0.5]]), ("standard_normal", [Z_RW]), ("standard_normal", X0_NEW.reshape(1, 4, 1, 1)),
              ("random", np.full((1, 4, 1), 0.5)), ("random", [U_ACC])]
    rng = ScriptedStreams(1, script)
    out = f._rejuvenate(X_IN.copy(), TH_IN.copy(), LL_IN.copy(), W_IN.copy(), np.array([[[4.0]]]), rng)
    assert rng.script == []
    # the fresh PFs run the model inside the prior's support only (the outside proposal at the bound)
    top = max(t.max() for t in m.thetas)
    assert top == 1.0 if not kw else top < 1.0
    return out


def test_pmmh_move_near_the_upper_bound_by_hand():
    """Resample θ by its weights (systematic, u = .5: counts (0, 1, 1, 2)), propose
    θ' = θ + c sd ε with sd the spread of the RESAMPLED cloud (population sd, equal weights),
    run a fresh PF for θ' (at the bound when θ' is outside), accept with log u < log p̂(y | θ')
    - log p̂(y | θ) and only inside the prior's support (0, 1). Accepted particles carry θ',
    the new log p̂ and the fresh PF's cloud; rejected ones keep the resampled θ, log p̂ and
    cloud; the acceptance rate is 2/4.
    The fresh PF of the outside proposal runs at the bound (the model never sees θ outside
    the support). Checked against: no support check (p2 accepted at θ' = 1.0066), no clip at
    the upper bound, the inverse ratio, the
    sample sd (ddof = 1), the sd of the cloud before resampling, and a rejected particle
    carrying the fresh cloud."""
    prop, ll_new = _upper_case()
    x, theta, loglik, acc = _rejuvenate_upper()
    np.testing.assert_allclose(theta[0], [prop[0], 0.97, 0.99, prop[3]], rtol=1e-12)
    np.testing.assert_allclose(loglik[0], [ll_new[0], 0.5, -2.0, ll_new[3]], rtol=1e-12)
    np.testing.assert_allclose(x[0, :, 0, 0], [prop[0] + 1, 30.0, 40.0, prop[3] + 1], rtol=1e-12)
    np.testing.assert_allclose(acc, [0.5])
    assert np.all((theta > 0) & (theta < 1))


def test_pmmh_random_walk_scale():
    """rw_scale c = 0.5 halves the step: θ' = θ + 0.5 sd ε (the same draws). Checked against
    ignoring ``rw_scale``."""
    x, theta, loglik, acc = _rejuvenate_upper(rw_scale=0.5)
    prop = TH_R + 0.5 * SD_R * Z_RW
    # every proposal inside now; ratios by hand decide which are accepted
    ll_new = np.array([pf1(p, 1.0, [4.0])[0] for p in prop])
    keep = np.log(U_ACC) < ll_new - np.array([-3.0, 0.5, -2.0, -2.0])
    np.testing.assert_allclose(theta[0], np.where(keep, prop, TH_R), rtol=1e-12)
    assert keep.tolist() == [True, False, True, True]
    np.testing.assert_allclose(acc, [0.75])


# ------------------------------------------------------------------------------ 4. collapsed cloud at the lower bound
def test_collapsed_cloud_at_the_lower_bound_moves_by_the_floor_two_moves():
    """Prior U(1, 5); all M = 3 θ-particles at 1 + 1e-6 (a posterior piled on the lower bound):
    their spread is 0, so the walk uses the floor sd = 1e-6 (hi - lo) = 4e-6. Move 1:
    ε = (-1, 1, .5) -> θ' = (1 - 3e-6 (outside: rejected), 1 + 5e-6, 1 + 3e-6 (ratio tiny: rejected));
    move 2 starts from the state move 1 left: θ = (1 + 1e-6, 1 + 5e-6, 1 + 1e-6), spread
    1.9e-6 < 4e-6 (floor again); ε = (.5, -.5, 1) -> all inside, p0 and p1 accepted, p2 not.
    Acceptance = mean over the moves of the accepted fraction = (1/3 + 2/3) / 2.
    The outside proposal's PF runs at the lower bound.
    Checked against no clip at the lower bound, the floor 1e-6 (not scaled by hi - lo), (hi + lo), the acceptance summed
    over the moves instead of averaged, and move 2 proposing from the state before move 1."""
    m = SquareObs((1.0, 5.0))
    f = SMC2(m, 3, 1, n_moves=2)
    t0 = 1.0 + 1e-6
    ll_in = np.array([[-3.0, -3.0, 2.0]])
    x_in = np.array([[10.0, 20.0, 30.0]])[..., None, None]
    y = np.array([[[4.0]]])
    z1, z2 = np.array([-1.0, 1.0, 0.5]), np.array([0.5, -0.5, 1.0])
    u1, u2 = np.array([0.5, 0.5, 0.5]), np.array([0.5, 0.5, 0.5])
    ones = np.ones((1, 3, 1, 1))
    script = [("random", [[0.5]]),
              ("standard_normal", [z1]), ("standard_normal", ones), ("random", np.full((1, 3, 1), 0.5)),
              ("random", [u1]),
              ("standard_normal", [z2]), ("standard_normal", ones), ("random", np.full((1, 3, 1), 0.5)),
              ("random", [u2])]
    rng = ScriptedStreams(1, script)
    x, theta, loglik, acc = f._rejuvenate(x_in.copy(), np.full((1, 3), t0), ll_in.copy(), np.full((1, 3), 1 / 3),
                                          y, rng)
    assert rng.script == []
    assert min(t.min() for t in m.thetas) == 1.0          # the outside proposal's PF runs at the bound
    floor = 1e-6 * 4.0
    p1 = t0 + floor * z1
    assert p1[0] < 1.0 < p1[1]
    l1 = pf1(p1[1], 1.0, [4.0])[0]
    assert np.log(0.5) < l1 + 3.0 and np.log(0.5) > pf1(p1[2], 1.0, [4.0])[0] - 2.0
    th1 = np.array([t0, p1[1], t0])
    ll1 = np.array([-3.0, l1, 2.0])
    sd1 = np.sqrt(((th1 - th1.mean()) ** 2).mean())
    assert sd1 < floor
    p2 = th1 + floor * z2
    l2 = np.array([pf1(p, 1.0, [4.0])[0] for p in p2])
    keep2 = np.log(u2) < l2 - ll1
    assert keep2.tolist() == [True, True, False]
    np.testing.assert_allclose(theta[0], [p2[0], p2[1], t0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(loglik[0], [l2[0], l2[1], 2.0], rtol=1e-12)
    np.testing.assert_allclose(x[0, :, 0, 0], [p2[0] + 1, p2[1] + 1, 30.0], rtol=1e-12)
    np.testing.assert_allclose(acc, [(1 / 3 + 2 / 3) / 2])


# ------------------------------------------------------------------------------ 5. the filter
# prior U(0.5, 1), runs = 2, M = 2, N_x = 1, ess_threshold 0.9 (rejuvenate when ESS < 1.8)
BOUNDS = (0.5, 1.0)
U_PRIOR = np.array([[0.2, 0.9], [0.4, 0.6]])     # θ = .5 + .5 u = (.6, .95), (.7, .8)
Y = np.array([[4.0, 13.0], [2.8, 10.0]])


def _filter_case():
    """Step-by-step hand computation of the scripted two-step run (see the test's docstring)."""
    th = 0.5 + 0.5 * U_PRIOR
    x1 = th * 1.0 + 1                                       # x_0 = 1 for every θ-particle
    inc1 = ll(Y[:, :1], x1)
    w1 = np.exp(inc1) / np.exp(inc1).sum(axis=1, keepdims=True)
    return th, x1, inc1, w1


def test_filter_by_hand_with_rejuvenations_in_each_run():
    """Two runs, T = 2, M = 2, N_x = 1, prior U(.5, 1) (θ = .5 + .5 u).
    Step 1: θ-weights w1 ∝ p(y_1 | θ) (uniform prior weights), ESS = 1 / sum w²: run 0 (1.64)
    rejuvenates -- from ITS OWN stream (a subset holding run 0) --, run 1 (2.00) does not.
    Run 0's move: θ-counts (1, 1) (u = .5), θ' = θ + sd ε, ε = (1, .5): θ'_1 = 1.0375 lies
    outside (.5, 1) and is rejected, θ'_0 = .775 accepted.
    Step 2: run 0 enters with uniform θ-weights, run 1 with w1; w2 ∝ carried · p̂(y_2 | ...)
    ; log evidence = log sum_m w0_m p̂_1 + log sum_m carried_m p̂_2; estimates of θ, its variance
    and x are w-weighted means; run 1 (ESS 1.33) now rejuvenates: θ-counts (2, 0), a collapsed
    cloud that moves by the floor .5e-6 (hi - lo), ε = (-1, 1); its PMMH compares a fresh
    two-step p̂(y_1:2 | θ') with the ACCUMULATED log p̂(y_1:2 | θ): ratios 1.0000015 and
    0.9999985 against u = (.5, .9999999), one accepted (with log p̂(y_2 | θ) alone the ratios
    are .397: none); pmmh_steps = n_moves · k.
    Checked against: the incremental weights not multiplying the carried ones (w2 ∝ p̂_2),
    loglik not accumulated (``loglik = inc``), the θ prior on (0, 1) (``lo + u``), ESS from sum w,
    the acceptance diagnostic written at the wrong step, pmmh counted as n_moves, the whole
    rng handed to a partial rejuvenation, and the first move scaled by the spread of the cloud
    before resampling."""
    m = SquareObs(BOUNDS)
    f = SMC2(m, 2, 1, ess_threshold=0.9)
    th, x1, inc1, w1 = _filter_case()
    ess1 = 1 / (w1 ** 2).sum(axis=1)
    assert ess1[0] < 1.8 <= ess1[1]
    # run 0's move at k = 1: resampled θ = th[0] (counts (1, 1)), sd = .175
    sd0 = np.sqrt(((th[0] - th[0].mean()) ** 2).mean())
    prop0 = th[0] + sd0 * np.array([1.0, 0.5])
    np.testing.assert_allclose(prop0, [0.775, 1.0375])
    l_new0 = ll(Y[0, 0], prop0[0] * 1.0 + 1)
    u0 = np.array([0.5, 1e-12])
    assert np.log(u0[0]) < l_new0 - inc1[0, 0]
    th_a = np.array([[prop0[0], th[0, 1]], th[1]])           # θ after step 1
    x_a = np.array([[prop0[0] + 1, x1[0, 1]], x1[1]])        # the states after step 1
    ll_a = np.array([[l_new0, inc1[0, 1]], inc1[1]])
    # step 2
    x2 = th_a * x_a + 2
    inc2 = ll(Y[:, 1:], x2)
    carried = np.array([[0.5, 0.5], w1[1]])
    v = carried * np.exp(inc2)
    w2 = v / v.sum(axis=1, keepdims=True)
    ess2 = 1 / (w2 ** 2).sum(axis=1)
    assert ess2[0] >= 1.8 > ess2[1]
    # run 1's move at k = 2: θ-counts from w2[1] with u = .5
    c = 2 * np.cumsum(w2[1])
    counts = np.diff(np.ceil(c - 0.5), prepend=0).astype(int)
    th_r = np.repeat(th_a[1], counts)
    ll_r = np.repeat(ll_a[1] + inc2[1], counts)
    sd1 = max(np.sqrt(((th_r - th_r.mean()) ** 2).mean()), 1e-6 * 0.5)
    prop1 = th_r + sd1 * np.array([-1.0, 1.0])
    l_new1 = np.array([pf1(p, 1.0, Y[1])[0] for p in prop1])
    u1 = np.array([0.5, 0.9999999])
    keep1 = (prop1 > 0.5) & (prop1 < 1.0) & (np.log(u1) < l_new1 - ll_r)
    script = [("random", U_PRIOR), ("standard_normal", np.ones((2, 2, 1, 1))),
              ("random", np.full((2, 2, 1), 0.5)),                              # step 1 PF resampling
              ("random", [[0.5]]), ("standard_normal", [[1.0, 0.5]]),          # run 0: θ-counts, ε
              ("standard_normal", np.ones((1, 2, 1, 1))), ("random", np.full((1, 2, 1), 0.5)),
              ("random", [u0]),
              ("random", np.full((2, 2, 1), 0.5)),                              # step 2 PF resampling
              ("random", [[0.5]]), ("standard_normal", [[-1.0, 1.0]]),         # run 1: θ-counts, ε
              ("standard_normal", np.ones((1, 2, 1, 1))), ("random", np.full((1, 2, 1), 0.5)),
              ("random", np.full((1, 2, 1), 0.5)), ("random", [u1])]
    rng = ScriptedStreams(2, script)
    res = f.filter(Y[..., None], rng)
    assert rng.script == []
    assert [e for e in rng.log if e[0] == "subset"] == [("subset", [0]), ("subset", [1])]
    d = res.diagnostics
    np.testing.assert_allclose(d["theta_ess"], np.stack([ess1, ess2], axis=1), rtol=1e-12)
    np.testing.assert_array_equal(d["rejuvenated"], [[True, False], [False, True]])
    np.testing.assert_allclose(d["theta"][:, 0], (w1 * th).sum(axis=1), rtol=1e-12)
    np.testing.assert_allclose(d["theta"][:, 1], (w2 * th_a).sum(axis=1), rtol=1e-12)
    np.testing.assert_allclose(d["theta_var"][:, 0], (w1 * (th - (w1 * th).sum(1, keepdims=True)) ** 2).sum(1),
                               rtol=1e-12)
    np.testing.assert_allclose(d["theta_var"][:, 1],
                               (w2 * (th_a - (w2 * th_a).sum(1, keepdims=True)) ** 2).sum(1), rtol=1e-12)
    np.testing.assert_allclose(res.x[:, 0, 0], (w1 * x1).sum(axis=1), rtol=1e-12)
    np.testing.assert_allclose(res.x[:, 1, 0], (w2 * x2).sum(axis=1), rtol=1e-12)
    np.testing.assert_allclose(d["log_evidence"],
                               np.log(np.exp(inc1).mean(axis=1)) + np.log(v.sum(axis=1)), rtol=1e-12)
    acc1 = keep1.mean()
    assert 0 < acc1 < 1, keep1
    np.testing.assert_allclose(d["acceptance"], [[0.5, np.nan], [np.nan, acc1]])
    np.testing.assert_array_equal(d["pmmh_steps"], [1, 2])
    assert d["rejuvenated"].dtype == bool and d["pmmh_steps"].dtype == np.int64


def test_filter_state_estimate_averages_each_cloud():
    """N_x = 2, no rejuvenation (ess_threshold 0): the state estimate at step 1 is
    sum_m w_m (1/N_x) sum_n x_n^m over the resampled clouds. θ = (.25, .75) (prior U(0, 1)),
    x_0 = (1, 3) and (0, 2) -> x_1 = (1.25, 1.75) and (1, 2.5); y_1 = 3. The PF resampling
    (u = .5) keeps both particles of cloud 0 (weights .263/.737: N C - u = (.03, 1.5), counts
    (1, 1)) and doubles particle 0 of cloud 1 (.964/.036: (1.43, 1.5), counts (2, 0)), so the
    cloud means are 1.5 and 1.0. Checked against multiplying by N_x instead of dividing."""
    f = SMC2(SquareObs(), 2, 2, ess_threshold=0.0)
    script = [("random", [[0.25, 0.75]]), ("standard_normal", np.array([[[1.0, 3.0], [0.0, 2.0]]])[..., None]),
              ("random", np.full((1, 2, 1), 0.5))]
    res = f.filter(np.full((1, 1, 1), 3.0), ScriptedStreams(1, script))
    x1 = np.array([[1.25, 1.75], [1.0, 2.5]])
    lik = np.exp(ll(3.0, x1))
    np.testing.assert_allclose(lik[:, 0] / lik.sum(axis=1), [0.26284184, 0.96377994], rtol=1e-7)
    w = lik.mean(axis=1) / lik.mean(axis=1).sum()
    np.testing.assert_allclose(res.x[0, 0, 0], w @ [1.5, 1.0], rtol=1e-12)
    np.testing.assert_allclose(res.diagnostics["theta"][0, 0], w @ [0.25, 0.75], rtol=1e-12)
    assert not res.diagnostics["rejuvenated"].any() and np.isnan(res.diagnostics["acceptance"]).all()


def test_settings_errors_and_repr():
    """Constructor checks and the repr. Checked against ``n_theta < 1`` for ``< 2``."""
    m = SquareObs()
    msg = r"^n_theta must be >= 2 \(the random walk is scaled by the θ-cloud's spread\)$"
    with pytest.raises(ValueError, match=msg):
        SMC2(m, 1, 5)
    for bad in ({"n_x": 0}, {"ess_threshold": 1.5}, {"n_moves": 0}, {"resampling": "bogus"}):
        with pytest.raises(ValueError, match=list(bad)[0]):
            SMC2(m, **{"n_theta": 2, "n_x": 5, **bad})
    f = SMC2(m, 2, 5, ess_threshold=0.25, rw_scale=0.5, n_moves=3)
    assert repr(f) == "SMC2(n_theta=2, n_x=5, ess_threshold=0.25)"
    assert (f.n_theta, f.n_x, f.ess_threshold, f.rw_scale, f.n_moves, f.resampling) == (2, 5, 0.25, 0.5, 3,
                                                                                        "systematic")
    assert f.name == "SMC²" and f.needs_rng
    with pytest.raises(TypeError, match="rng"):
        f.filter(np.ones((1, 1, 1)), None)


# ------------------------------------------------------------------------------ 6. more cases
class SquareObs2D(ParameterizedModel):
    """dim_x = 2: x_k = θ x_{k-1} + k (Q = 0), y_k = x_{k,0}² + x_{k,1} + v, v ~ N(0, 1)."""

    def __init__(self):
        super().__init__(2, 1, 1, np.zeros((2, 2)), 1.0, [0.0, 0.0], [0.0, 0.0], np.eye(2), [0.5], (0.0, 1.0))

    def f(self, x, k, theta):
        return theta * x + k

    def h(self, x):
        return x[..., :1] ** 2 + x[..., 1:]


def test_pf_step_resamples_whole_state_vectors():
    """dim_x = 2, one run, M = 1, N_x = 2, k = 1, θ = .5: x' = (.5 x + 1) = (1, 1.5) and (2, 0);
    h = 2.5 and 4; y = 4: w ∝ (e^-1.125, 1), N C = (.490, 2); u = .6: counts (0, 2): both
    rows become (2, 0). Checked against ``np.repeat`` without ``axis=0`` (a flattened repeat
    of the coordinates)."""
    f = SMC2(SquareObs2D(), 2, 2)
    x = np.array([[[[0.0, 1.0], [2.0, -2.0]]]])
    xn, inc = f._pf_step(x, np.array([[0.5]]), np.array([[4.0]]), 1, ScriptedStreams(1, [("random", [[[0.6]]])]))
    lik = np.exp(-0.5 * np.array([1.5, 0.0]) ** 2)
    np.testing.assert_allclose(2 * lik[0] / lik.sum(), 0.49017, rtol=1e-4)
    np.testing.assert_array_equal(xn[0, 0], [[2.0, 0.0], [2.0, 0.0]])
    np.testing.assert_allclose(inc, [[np.log(lik.mean()) - LOG_2PI_2]], rtol=1e-12)


def test_rejuvenate_two_runs_at_once_uses_each_runs_own_spread():
    """Two runs in one call (every run rejuvenating draws from the whole rng): run 0 is the
    upper-bound case above, run 1 the same cloud shifted down by .5 with twice the spread
    (θ = (.35, .39, .43, .43) after resampling, sd = 2 SD_R). Each run's proposal uses ITS OWN
    cloud's mean and spread, and its acceptance rate is its own. Checked against the mean, the
    sd and the acceptance rate pooled over the runs (``axis=None``)."""
    m = SquareObs((0.0, 1.0))
    f = SMC2(m, 4, 1)
    th_in = np.array([TH_IN[0], [0.30, 0.35, 0.39, 0.43]])
    ll_in = np.array([LL_IN[0], LL_IN[0]])
    x_in = np.concatenate([X_IN, X_IN])
    w_in = np.array([W_IN[0], W_IN[0]])
    u_acc_1 = np.array([1e-12, 1e-12, 0.999999, 1e-12])
    script = [("random", [[0.5], [0.5]]), ("standard_normal", [Z_RW, Z_RW]),
              ("standard_normal", np.ones((2, 4, 1, 1))), ("random", np.full((2, 4, 1), 0.5)),
              ("random", [U_ACC, u_acc_1])]
    x, theta, loglik, acc = f._rejuvenate(x_in, th_in, ll_in, w_in, np.array([[[4.0]], [[4.0]]]),
                                          ScriptedStreams(2, script))
    prop0, _ = _upper_case()
    th_r1 = np.array([0.35, 0.39, 0.43, 0.43])
    sd1 = np.sqrt(((th_r1 - th_r1.mean()) ** 2).mean())
    np.testing.assert_allclose(sd1, 2 * SD_R, rtol=1e-12)
    prop1 = th_r1 + sd1 * Z_RW
    ll_new1 = np.array([pf1(p, 1.0, [4.0])[0] for p in prop1])
    keep1 = np.log(u_acc_1) < ll_new1 - ll_in[0, [1, 2, 3, 3]]
    assert keep1.tolist() == [True, True, False, True]
    np.testing.assert_allclose(theta[0], [prop0[0], 0.97, 0.99, prop0[3]], rtol=1e-12)
    np.testing.assert_allclose(theta[1], np.where(keep1, prop1, th_r1), rtol=1e-12)
    np.testing.assert_allclose(acc, [0.5, 0.75])


def test_rejuvenation_threshold_is_strict_and_runs_under_raise():
    """M = 2, N_x = 1, ess_threshold .5: θ-particle 1's likelihood underflows to 0 (x_1 = 9,
    residual 77), so the θ-weights are (1, 0) and ESS = 1 = .5 M exactly: no rejuvenation
    (only ESS < threshold · M moves). The run happens under ``np.errstate(all="raise")``: the
    filter's own ``errstate`` must silence the underflow and log(0) it meets. Checked against
    ``<=`` and against the errstate without ``under``/``divide``."""
    f = SMC2(SquareObs((0.0, 1.0)), 2, 1, ess_threshold=0.5)
    script = [("random", [[0.5, 0.8]]), ("standard_normal", [[[[1.0]], [[10.0]]]]),
              ("random", np.full((1, 2, 1), 0.5))]
    with np.errstate(all="raise"):
        res = f.filter(np.full((1, 1, 1), 2.25), ScriptedStreams(1, script))
    # x_1 = .5 + 1 = 1.5 (h = 2.25 = y), .8 * 10 + 1 = 9 (h = 81)
    assert res.diagnostics["theta_ess"][0, 0] == 1.0
    assert not res.diagnostics["rejuvenated"].any()
    np.testing.assert_allclose(res.diagnostics["theta"][0, 0], 0.5, rtol=1e-12)
    np.testing.assert_allclose(res.diagnostics["log_evidence"], [np.log(0.5) - LOG_2PI_2], rtol=1e-12)


def test_documented_defaults_and_exact_messages():
    """The defaults (M = 200, N_x = 100, ess_threshold .5, c = 1, one move, systematic) and the
    argument named at the start of each error message. Checked against a default changed by
    one and a misnamed argument."""
    f = SMC2(SquareObs())
    assert (f.n_theta, f.n_x, f.ess_threshold, f.rw_scale, f.n_moves, f.resampling) == (200, 100, 0.5, 1.0, 1,
                                                                                        "systematic")
    m = SquareObs()
    for kw, msg in (({"n_theta": 0}, "n_theta must be >= 1"), ({"n_x": 0}, "n_x must be >= 1"),
                    ({"ess_threshold": 2.0}, "ess_threshold must lie in"), ({"rw_scale": -1.0}, "rw_scale must be"),
                    ({"n_moves": 0}, "n_moves must be >= 1")):
        with pytest.raises(ValueError, match="^" + msg):
            SMC2(m, **{"n_theta": 4, "n_x": 5, **kw})
