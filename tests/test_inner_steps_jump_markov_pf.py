"""Inner steps of the jump-Markov PF (:mod:`pfrepro.filters.jump_markov_pf`), pinned by hand (issue 35).

Every random number the filter draws comes from a scripted source (``ScriptedStreams``: each
draw is the next array of a script, its method and shape checked), and the mode models are
stubs whose nonlinear dynamics record what they receive; the measurement is nonlinear,
y = x_0^2 + x_1 + v, v ~ N(0, 1). So each step -- the initial and the jumped modes, each
mode's transition with its own square root of Q, the weights, the estimate, the mode
probabilities, the ESS, the weights carried after (partial) resampling and the modes that
travel with the resampled particles -- is checked against numbers worked out by hand below.

Each test was checked once against the wrong formula named in its docstring (applied by hand
to ``src/``, the test failed, reverted).
"""
from __future__ import annotations

import numpy as np
import pytest

from pfrepro.filters.jump_markov_pf import JumpMarkovParticleFilter
from pfrepro.filters.particle import WeightCollapseWarning
from pfrepro.models import JumpMarkovSystem
from pfrepro.models.base import StateSpaceModel
from scripted_streams import ScriptedStreams

LOG_2PI = np.log(2 * np.pi)


# ------------------------------------------------------------------------------ stubs
class Mode(StateSpaceModel):
    """dim_x = 2, y = x_0^2 + x_1 + v, v ~ N(0, 1); transition ``fn`` (recording every call as
    (k, x)); process noise N(0, Q)."""

    def __init__(self, fn, Q):
        super().__init__(2, 1, Q, [[1.0]], [0.0, 0.0], [0.0, 0.0], np.eye(2))
        self.fn, self.calls = fn, []

    def f(self, x, k):
        self.calls.append((k, np.array(x)))
        return self.fn(np.asarray(x), k)

    def h(self, x):
        return x[..., :1] ** 2 + x[..., 1:]


# mode 0: (x0 + k, x1 / 2), Q0 = [[4, 2], [2, 2]] = L0 L0^T with L0 = [[2, 0], [1, 1]]
# mode 1: (2 x0, x1 - k),   Q1 = diag(1, 1/4),       L1 = diag(1, 1/2)
L0 = np.array([[2.0, 0.0], [1.0, 1.0]])
L1 = np.diag([1.0, 0.5])
PI = [[0.85, 0.15], [0.3, 0.7]]
P_INIT = [0.6, 0.4]


def f0(x, k):
    return np.stack([x[..., 0] + k, 0.5 * x[..., 1]], axis=-1)


def f1(x, k):
    return np.stack([2.0 * x[..., 0], x[..., 1] - k], axis=-1)


def system():
    return JumpMarkovSystem([Mode(f0, L0 @ L0.T), Mode(f1, L1 @ L1.T)], PI, initial_probs=P_INIT)


def loglik(y, x):
    """The stub's log p(y | x) written out: -(y - x0^2 - x1)^2 / 2 - log(2 pi) / 2."""
    return -0.5 * (y - x[..., 0] ** 2 - x[..., 1]) ** 2 - 0.5 * LOG_2PI


# one run, N = 4, step 1 -------------------------------------------------------------------
U_INIT = [0.1, 0.59, 0.6, 0.95]       # cum(initial) = (0.6, 1): modes 0, 0, 1 (0.6 is not < 0.6), 1
MODES_0 = [0, 0, 1, 1]
X_0 = [[0.0, 0.0], [1.0, -1.0], [0.5, 0.5], [-1.0, 2.0]]   # the prior draws (m0 = 0, P0 = I)
U_JUMP = [0.5, 0.9, 0.2, 0.5]         # rows cum(Pi[0]) = (0.85, 1), cum(Pi[1]) = (0.3, 1)
MODES_1 = [0, 1, 0, 1]                # 0 -> 0 (0.5 < .85), 0 -> 1 (0.9), 1 -> 0 (0.2 < .3), 1 -> 1 (0.5)
Z_1 = [[0.5, 0.0], [1.0, 1.0], [0.0, 1.0], [1.0, -1.0]]
# x_1 by hand: f_mode(x_0, 1) + L_mode z
#   p0 (mode 0): (0 + 1, 0)      + L0 (0.5, 0) = (1, 0) + (1, 0.5)      = (2, 0.5)
#   p1 (mode 1): (2, -1 - 1)     + L1 (1, 1)   = (2, -2) + (1, 0.5)     = (3, -1.5)
#   p2 (mode 0): (1.5, 0.25)     + L0 (0, 1)   = (1.5, 0.25) + (0, 1)   = (1.5, 1.25)
#   p3 (mode 1): (-2, 2 - 1)     + L1 (1, -1)  = (-2, 1) + (1, -0.5)    = (-1, 0.5)
X_1 = np.array([[2.0, 0.5], [3.0, -1.5], [1.5, 1.25], [-1.0, 0.5]])
# h(x_1) = (4.5, 7.5, 3.5, 1.5); with y_1 = 4.5 the residuals are (0, -3, 1, 3), so
# w ∝ (1, e^-4.5, e^-0.5, e^-4.5)
Y1 = 4.5
LIK_1 = np.array([1.0, np.exp(-4.5), np.exp(-0.5), np.exp(-4.5)])


def _script_step1(runs=1):
    rep = lambda a: np.broadcast_to(np.asarray(a, float), (runs,) + np.shape(a)).copy()  # noqa: E731
    return [("standard_normal", rep(X_0)), ("random", rep(U_INIT)),
            ("random", rep(U_JUMP)), ("standard_normal", rep(Z_1))]


def test_hand_numbers_of_step_1():
    for i, j in enumerate(MODES_1):
        f, L = (f0, L0) if j == 0 else (f1, L1)
        np.testing.assert_allclose(f(np.array(X_0[i]), 1) + L @ Z_1[i], X_1[i])
    np.testing.assert_allclose(np.exp(loglik(Y1, X_1) + 0.5 * LOG_2PI), LIK_1)


# ------------------------------------------------------------------------------ tests
def test_draw_modes_is_the_first_index_whose_cumulative_exceeds_u():
    """Inverse CDF: the first j with u < cum[j]; u equal to cum[j] goes to j + 1; a cumulative
    row that ends below 1 by rounding sends u above it to the last mode, not past it.
    Checked against ``u > cum`` (the boundary case moves down) and without the ``np.minimum``."""
    cum = np.array([[0.25, 0.5, 1.0], [0.3, 0.6, 0.9999999]])
    u = np.array([[0.0, 0.25, 0.2499, 0.5, 0.99],
                  [0.3, 0.29, 0.6, 0.99999995, 0.0]])
    got = JumpMarkovParticleFilter._draw_modes(cum[:, None, :], u)
    np.testing.assert_array_equal(got, [[0, 1, 0, 2, 2], [1, 0, 2, 2, 0]])
    # one shared cumulative row for every particle (the initial draw)
    np.testing.assert_array_equal(JumpMarkovParticleFilter._draw_modes(np.array([0.6, 1.0]), np.array(U_INIT)),
                                  MODES_0)


def test_mode_jump_and_per_mode_transition_by_hand():
    """Step 1 on one run, N = 4: the initial modes from the cumulative initial probabilities,
    the jump from the cumulative ROW of each particle's mode (Pi[from, :]), then each mode's
    f(x, k = 1) on its own particles (the recorded calls). Checked against the column-wise
    cumulative (``cumsum(Pi, axis=0)``), against Pi^T and against f(x, k - 1). (The noise term
    L_mode z is pinned through the estimates of the tests below.)"""
    sysm = system()
    rng = ScriptedStreams(1, _script_step1() + [("random", [[0.5]])])
    JumpMarkovParticleFilter(sysm, 4).filter(np.full((1, 1, 1), Y1), rng)
    (k0, x_in0), = sysm.models[0].calls
    (k1, x_in1), = sysm.models[1].calls
    assert (k0, k1) == (1, 1)
    np.testing.assert_array_equal(x_in0, np.array(X_0)[[0, 2]])    # modes at step 1: (0, 1, 0, 1)
    np.testing.assert_array_equal(x_in1, np.array(X_0)[[1, 3]])
    assert rng.script == []


def test_weights_estimate_mode_probabilities_ess_and_evidence_by_hand():
    """Step 1: w ∝ p(y_1 | x_1^i) = (1, e^-4.5, e^-0.5, e^-4.5) / S; the estimate sum_i w_i x_1^i;
    the mode probabilities are the weight sums over the particles in each mode AFTER the jump
    (modes 0, 1, 0, 1); ESS = 1 / sum w^2; log evidence = log(S / 4) - log(2 pi) / 2.
    Checked against the unweighted mode shares (1/2, 1/2) and against ESS = 1 / sum w."""
    res = JumpMarkovParticleFilter(system(), 4).filter(np.full((1, 1, 1), Y1),
                                                       ScriptedStreams(1, _script_step1() + [("random", [[0.5]])]))
    S = 1 + np.exp(-0.5) + 2 * np.exp(-4.5)
    w = LIK_1 / S
    np.testing.assert_allclose(res.x[0, 0], w @ X_1, rtol=1e-12)
    np.testing.assert_allclose(res.diagnostics["mode_probs"][0, 0],
                               [(1 + np.exp(-0.5)) / S, 2 * np.exp(-4.5) / S], rtol=1e-12)
    np.testing.assert_allclose(res.diagnostics["ess"][0, 0], S ** 2 / (1 + np.exp(-1.0) + 2 * np.exp(-9.0)),
                               rtol=1e-12)
    np.testing.assert_allclose(res.diagnostics["log_evidence"], [np.log(S / 4) - 0.5 * LOG_2PI], rtol=1e-12)
    assert res.diagnostics["resampled"].tolist() == [[True]]
    assert res.diagnostics["n_collapsed"] == 0 and not res.diagnostics["collapsed"].any()


# step 2 after resampling at step 1 ----------------------------------------------------------
# run 0 (y_1 = 4.5): w = (1, e^-4.5, e^-0.5, e^-4.5)/S = (.6140, .0068, .3724, .0068), ESS 1.94 < 2;
#   systematic counts with u = 0.5: N C = (2.456, 2.483, 3.973, 4), ceil(N C - u) = (2, 2, 4, 4),
#   counts (2, 0, 2, 0): particles (p0, p0, p2, p2), modes (0, 0, 0, 0)
# run 1 (y_1 = 4.0): residuals (-.5, -3.5, .5, 2.5), w ∝ (e^-.125, e^-6.125, e^-.125, e^-3.125),
#   ESS = 2.19 >= 2: no resampling at ess_threshold 0.5 (always resampled at None)
Y1_RUN1 = 4.0
LIK_1_RUN1 = np.exp(-0.5 * np.array([0.25, 12.25, 0.25, 6.25]))
U_JUMP_2 = [0.9, 0.5, 0.5, 0.2]       # from modes (0, 0, 0, 0): (1, 0, 0, 0); from (0, 1, 0, 1): (1, 1, 0, 0)
Z_2 = [[0.0, 0.0], [1.0, 0.0], [0.0, -1.0], [0.5, 0.5]]
Y2 = 6.0


def _step2_by_hand(x1, modes1):
    """x_2 = f_mode(x_1, 2) + L_mode z_2 with the step-2 modes drawn from ``modes1``."""
    cum = np.cumsum(PI, axis=1)
    modes2 = [int(np.sum(u >= cum[m])) for u, m in zip(U_JUMP_2, modes1)]
    x2 = np.array([(f0(x, 2) + L0 @ z) if j == 0 else (f1(x, 2) + L1 @ z) for x, j, z in zip(x1, modes2, Z_2)])
    return x2, modes2


def test_resampled_particles_carry_their_modes_into_the_next_jump():
    """Resampling every step: run 0's particles after step 1 are (p0, p0, p2, p2), and their
    modes travel with them -- all in mode 0 -- so the step-2 uniforms (0.9, 0.5, 0.5, 0.2) send
    particle 0 to mode 1 and the rest to mode 0; x_2 = f_mode(x_1, 2) + L_mode z_2 gives the
    step-2 estimate. Checked against resampling x but not the modes (modes (0, 1, 0, 1) would
    send particles 0 and 1 to mode 1) and against L^T z (einsum ``"ji,pj->pi"``)."""
    sysm = system()
    script = _script_step1() + [("random", [[0.5]]),
                                ("random", [U_JUMP_2]), ("standard_normal", [Z_2]), ("random", [[0.5]])]
    res = JumpMarkovParticleFilter(sysm, 4).filter(np.array([[[Y1], [Y2]]]), ScriptedStreams(1, script))
    x1 = X_1[[0, 0, 2, 2]]
    x2, modes2 = _step2_by_hand(x1, [0, 0, 0, 0])
    assert modes2 == [1, 0, 0, 0]
    assert [k for k, _ in sysm.models[0].calls] == [1, 2] and [k for k, _ in sysm.models[1].calls] == [1, 2]
    np.testing.assert_array_equal(sysm.models[1].calls[1][1], x1[[0]])
    np.testing.assert_array_equal(sysm.models[0].calls[1][1], x1[[1, 2, 3]])
    lik2 = np.exp(loglik(Y2, x2) + 0.5 * LOG_2PI)
    w2 = lik2 / lik2.sum()                                      # uniform weights carried
    np.testing.assert_allclose(res.x[0, 1], w2 @ x2, rtol=1e-12)
    np.testing.assert_allclose(res.diagnostics["mode_probs"][0, 1], [w2[1:].sum(), w2[0]], rtol=1e-12)
    S = LIK_1.sum()
    np.testing.assert_allclose(res.diagnostics["log_evidence"],
                               [np.log(S / 4) + np.log(lik2.mean()) - LOG_2PI], rtol=1e-12)


def test_partial_resampling_carries_uniform_and_kept_weights():
    """ESS threshold 0.5, two runs: only run 0 (ESS 1.94 < 2) resamples at step 1, from its own
    stream (``take_runs``: a subset holding run 0); run 1 (ESS 2.19) enters step 2 with its own
    step-1 weights and its particles and modes unchanged. Step-2 estimates, mode probabilities
    and evidence by hand from the carried weights. Checked against carrying uniform weights for
    every run (``logw = -log N`` whether resampled or not)."""
    sysm = system()
    script = _script_step1(2) + [("random", [[0.5]]),
                                 ("random", [U_JUMP_2, U_JUMP_2]), ("standard_normal", [Z_2, Z_2]),
                                 ("random", [[0.5], [0.5]])]          # step 2: both ESS < 2 (by hand below)
    rng = ScriptedStreams(2, script)
    res = JumpMarkovParticleFilter(sysm, 4, ess_threshold=0.5).filter(np.array([[[Y1], [Y2]], [[Y1_RUN1], [Y2]]]),
                                                                      rng)
    assert ("subset", [0]) in rng.log and rng.script == []
    d = res.diagnostics
    assert d["resampled"].tolist() == [[True, True], [False, True]]
    w1_run1 = LIK_1_RUN1 / LIK_1_RUN1.sum()
    np.testing.assert_allclose(d["ess"][:, 0], [LIK_1.sum() ** 2 / (LIK_1 ** 2).sum(), 1 / (w1_run1 ** 2).sum()],
                               rtol=1e-12)
    assert d["ess"][0, 0] < 2 <= d["ess"][1, 0]
    for run, x1, modes1, carried in ((0, X_1[[0, 0, 2, 2]], [0, 0, 0, 0], np.full(4, 0.25)),
                                     (1, X_1, MODES_1, w1_run1)):
        x2, modes2 = _step2_by_hand(x1, modes1)
        lik2 = np.exp(loglik(Y2, x2) + 0.5 * LOG_2PI)
        v = carried * lik2
        w2 = v / v.sum()
        np.testing.assert_allclose(res.x[run, 1], w2 @ x2, rtol=1e-12)
        np.testing.assert_allclose(d["mode_probs"][run, 1], [w2[np.array(modes2) == j].sum() for j in (0, 1)],
                                   rtol=1e-12)
        np.testing.assert_allclose(d["ess"][run, 1], 1 / (w2 ** 2).sum(), rtol=1e-12)
        assert 1 / (w2 ** 2).sum() < 2
        lik1 = LIK_1 if run == 0 else LIK_1_RUN1
        np.testing.assert_allclose(d["log_evidence"][run], np.log(lik1.mean()) + np.log(v.sum()) - LOG_2PI,
                                   rtol=1e-12)
    # run 1's step-2 modes: from (0, 1, 0, 1) the uniforms (0.9, 0.5, 0.5, 0.2) give (1, 1, 0, 0)
    assert _step2_by_hand(X_1, MODES_1)[1] == [1, 1, 0, 0]


def test_resampling_threshold_is_strict():
    """N = 2, ess_threshold 0.5: the second particle's likelihood underflows to 0 (residual
    50), so w = (1, 0) and ESS = 1 = 0.5 * N exactly: not resampled (resample only when
    ESS < threshold * N), and the zero weight is carried. Run under ``np.errstate(all="raise")``.
    Checked against ``<=`` and against the filter's errstate without ``under``/``divide``."""
    z = [[0.0, 0.0], [0.0, 0.0]]
    script = [("standard_normal", [[[0.0, 0.0], [0.0, 100.0]]]), ("random", [[0.1, 0.1]]),
              ("random", [[0.1, 0.1]]), ("standard_normal", [z])]
    # both stay in mode 0: x_1 = (1, 0) and (1, 50) (f0 halves x1), h = 1 and 51, y = 1
    with np.errstate(all="raise"):      # the filter's own errstate silences the underflow and log(0)
        res = JumpMarkovParticleFilter(system(), 2, ess_threshold=0.5).filter(np.ones((1, 1, 1)),
                                                                              ScriptedStreams(1, script))
    assert res.diagnostics["ess"][0, 0] == 1.0
    assert res.diagnostics["resampled"].dtype == bool and res.diagnostics["collapsed"].dtype == bool
    assert res.diagnostics["resampled"].tolist() == [[False]]
    np.testing.assert_array_equal(res.x[0, 0], [1.0, 0.0])


def test_collapse_is_recorded_and_warned_under_the_filters_name():
    """Every likelihood zero at step 2 of 2 (h returns inf, so log p(y | x) = -inf; a NaN
    log-likelihood is a model error since the model contract checks it): the run collapses
    there -- uniform weights, log increment -inf, ``collapsed[0, 1]`` -- and the warning names
    JMPF. Checked against recording the collapse at the wrong step (k instead of k - 1)."""
    sysm = system()
    sysm.models[0].h = lambda x: np.where(x[..., :1] > 100, np.inf, x[..., :1] ** 2 + x[..., 1:])
    script = [("standard_normal", [np.zeros((2, 2))]), ("random", [[0.1, 0.1]]),
              ("random", [[0.1, 0.1]]), ("standard_normal", [np.zeros((2, 2))]), ("random", [[0.5]]),
              ("random", [[0.1, 0.1]]), ("standard_normal", [[[200.0, 0.0], [200.0, 0.0]]]), ("random", [[0.5]])]
    with pytest.warns(WeightCollapseWarning, match="JMPF"):
        res = JumpMarkovParticleFilter(sysm, 2).filter(np.ones((1, 2, 1)), ScriptedStreams(1, script))
    assert res.diagnostics["collapsed"].tolist() == [[False, True]]
    assert res.diagnostics["n_collapsed"] == 1
    assert res.diagnostics["log_evidence"][0] == -np.inf


def test_settings_errors_and_repr():
    """The constructor's checks and messages, the rng check, and the repr (exact strings).
    Checked against ``hasattr(models) and hasattr(Pi)`` (an object with models but no Pi)."""
    sysm = system()

    class OnlyModels:
        models = sysm.models

    with pytest.raises(TypeError, match="^JumpMarkovParticleFilter needs a JumpMarkovSystem, got OnlyModels$"):
        JumpMarkovParticleFilter(OnlyModels(), 4)
    with pytest.raises(ValueError, match="^ess_threshold must lie in"):
        JumpMarkovParticleFilter(sysm, 4, ess_threshold=1.5)
    with pytest.raises(ValueError, match="^n_particles must be >= 1"):
        JumpMarkovParticleFilter(sysm, 0)
    with pytest.raises(ValueError, match="resampling"):
        JumpMarkovParticleFilter(sysm, 4, resampling="bogus")
    f = JumpMarkovParticleFilter(sysm, 4, resampling="residual", ess_threshold=0.25)
    assert repr(f) == "JumpMarkovParticleFilter(N=4, r=2, resampling='residual', ess_threshold=0.25)"
    assert f.name == "JMPF" and f.needs_rng
    with pytest.raises(TypeError, match="rng"):
        f.filter(np.ones((1, 1, 1)), None)
    np.testing.assert_array_equal(f._roots, [L0, L1])
    np.testing.assert_allclose(f._cum_Pi, [[0.85, 1.0], [0.3, 1.0]])
    np.testing.assert_allclose(f._cum_init, [0.6, 1.0])


def test_the_named_resampling_scheme_is_used():
    """resampling="multinomial" draws its N uniforms per resampling run (``random((runs, N))``),
    systematic one (``random((runs, 1))``): the script's shape check sees which scheme ran.
    Checked against ignoring the setting (always systematic)."""
    u_multi = [[0.1, 0.2, 0.7, 0.9]]
    script = _script_step1() + [("random", u_multi)]
    rng = ScriptedStreams(1, script)
    JumpMarkovParticleFilter(system(), 4, resampling="multinomial").filter(np.full((1, 1, 1), Y1), rng)
    assert rng.script == [] and rng.log[-1] == ("random", (1, 4))


def test_prior_override_reaches_the_initial_draw():
    """m0 = (1, 2), P0 = diag(4, 9): x_0 = m0 + chol(P0) z = (1 + 2 z_0, 2 + 3 z_1), seen by the
    mode models at step 1 (the modes are those of the step-1 script). Checked against the
    override dropped (the system's N(0, I))."""
    sysm = system()
    script = _script_step1() + [("random", [[0.5]])]
    JumpMarkovParticleFilter(sysm, 4, m0=[1.0, 2.0], P0=np.diag([4.0, 9.0])).filter(np.full((1, 1, 1), Y1),
                                                                                    ScriptedStreams(1, script))
    x0 = np.array([1.0, 2.0]) + np.array(X_0) * [2.0, 3.0]
    np.testing.assert_allclose(sysm.models[0].calls[0][1], x0[[0, 2]], rtol=1e-12)
    np.testing.assert_allclose(sysm.models[1].calls[0][1], x0[[1, 3]], rtol=1e-12)
