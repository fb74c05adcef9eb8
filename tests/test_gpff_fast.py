"""The GPFF's cheaper time step, pinned bit for bit against the forms it replaces.

At N = 100 most of a GPFF time step is work that does not grow with N: numpy calls on small
per-run arrays. The faster forms compute the same numbers with fewer or cheaper calls:

* the scalar loop (``_filter_scalar``: d = m = 1, plain residual, the UNGM) against the general
  loop of ``filter`` (``_scalar = False``), every integrator and schedule, batches of 1, 3 and 8,
  with and without covariances, and through every divergence branch;
* the update starting from the prior moments' deviations against the update computing them;
* one Cramer/division solve for both right-hand sides of ``flow.flow_field_coefficients``
  against the two solves it replaces (the old form is kept below);
* the checked Euler steps of the bearings-only model (I + h A by its diagonal, the wrap test
  once over the batch) against the old stepping and wrap test (kept below), with and without
  a wrapped angle.

Every comparison is ``np.array_equal`` (NaN where both are NaN).
"""
import warnings

import numpy as np
import pytest

from pfrepro import flow
from pfrepro.filters import FilterDivergenceError, FilterDivergenceWarning, GaussianParticleFlowFilter
from pfrepro.filters import gpff
from pfrepro.models import UNGM, BearingsOnly, LinearGaussianModel
from pfrepro.montecarlo import filter_streams, truth_streams

INTEGRATORS = ["euler", "midpoint", "rk4"]


def _same(a, b):
    return a.shape == b.shape and np.array_equal(a, b, equal_nan=True)


def _run(g, y, seed, scalar):
    """``g.filter`` with the scalar loop on or off; the result and the warnings raised."""
    g._scalar = scalar and g._scalar
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        res = g.filter(y, filter_streams(seed, "fast", y.shape[0]))
    return res, [str(x.message) for x in w if issubclass(x.category, FilterDivergenceWarning)]


def _assert_same_result(a, b):
    assert _same(a.x, b.x)
    assert (a.P is None) == (b.P is None)
    if a.P is not None:
        assert _same(a.P, b.P)
    assert _same(a.diagnostics["diverged_at"], b.diagnostics["diverged_at"])
    assert a.diagnostics["n_diverged"] == b.diagnostics["n_diverged"]


# ----------------------------------------------------------------------------- the scalar loop
@pytest.mark.parametrize("schedule", ["uniform", "exponential"])
@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("runs", [1, 3, 8])
def test_scalar_loop_is_the_general_loop(runs, integrator, schedule):
    model = UNGM.zhang2016()
    for seed in (1, 2):
        y = model.simulate(25, runs, truth_streams(seed, runs)).y
        for return_cov in (False, True):
            g = GaussianParticleFlowFilter(model, 40, integrator=integrator, schedule=schedule,
                                           return_cov=return_cov)
            assert g._scalar
            fast, wf = _run(g, y, seed, True)
            ref, wr = _run(GaussianParticleFlowFilter(model, 40, integrator=integrator, schedule=schedule,
                                                      return_cov=return_cov), y, seed, False)
            _assert_same_result(fast, ref)
            assert wf == wr == []


def test_scalar_loop_is_taken_and_steps_no_probe(monkeypatch):
    """The UNGM's filter runs the scalar loop (the general update is never called); with
    integrate_flow wrapped (as pfrepro.cost does to count the flow) it runs the general loop."""
    model = UNGM.zhang2016()
    y = model.simulate(5, 2, truth_streams(0, 2)).y
    g = GaussianParticleFlowFilter(model, 20)

    def fail(*a, **k):
        raise AssertionError("the general update was called")

    monkeypatch.setattr(GaussianParticleFlowFilter, "_update", fail)
    g.filter(y, filter_streams(0, "fast", 2))
    wrapped = flow.integrate_flow
    monkeypatch.setattr(flow, "integrate_flow", lambda *a, **k: wrapped(*a, **k))
    with pytest.raises(AssertionError, match="general update"):
        g.filter(y, filter_streams(0, "fast", 2))


@pytest.mark.parametrize("return_cov", [False, True])
@pytest.mark.parametrize("case", ["outlier", "small shift", "huge prior", "overflow"])
def test_scalar_loop_diverges_as_the_general_loop(case, return_cov):
    """Every divergence branch: an outlier measurement (the shift test), a tight ``max_shift``
    (some runs fail at some steps), a prior whose variance is beyond the fast verdict's bound
    (the exact branch), a measurement near the largest float (the flow overflows: non-finite
    particles)."""
    model, kw = UNGM.zhang2016(), {}
    runs = 6
    y = model.simulate(20, runs, truth_streams(7, runs)).y
    if case == "outlier":
        y[2, 5] = 1e200
        y[4, 11] = -1e250
    elif case == "small shift":
        kw["max_shift"] = 0.7
    elif case == "huge prior":
        model = UNGM(m0=0.0, P0=1e303)
        y = model.simulate(20, runs, truth_streams(7, runs)).y
    else:
        y[1, 3] = 1.7e308
    for policy in ("warn", "drop"):
        a, wa = _run(GaussianParticleFlowFilter(model, 30, on_divergence=policy, return_cov=return_cov, **kw),
                     y, 3, True)
        b, wb = _run(GaussianParticleFlowFilter(model, 30, on_divergence=policy, return_cov=return_cov, **kw),
                     y, 3, False)
        _assert_same_result(a, b)
        assert wa == wb
        assert a.diagnostics["n_diverged"] > 0
    with pytest.raises(FilterDivergenceError) as ea:
        _run(GaussianParticleFlowFilter(model, 30, on_divergence="raise", **kw), y, 3, True)
    with pytest.raises(FilterDivergenceError) as eb:
        _run(GaussianParticleFlowFilter(model, 30, on_divergence="raise", **kw), y, 3, False)
    assert str(ea.value) == str(eb.value)


def test_scalar_loop_on_a_scalar_model_with_other_sigma_points():
    """UT parameters where (n + lambda) != 1 keep the symmetrised square root."""
    model = UNGM.zhang2016()
    y = model.simulate(15, 3, truth_streams(4, 3)).y
    for alpha, kappa in ((1e-3, 0.0), (1.0, 2.0)):
        g = GaussianParticleFlowFilter(model, 30, alpha=alpha, kappa=kappa, on_divergence="drop")
        a, _ = _run(g, y, 5, True)
        b, _ = _run(GaussianParticleFlowFilter(model, 30, alpha=alpha, kappa=kappa, on_divergence="drop"),
                    y, 5, False)
        _assert_same_result(a, b)


# ----------------------------------------------------------------------------- the general update
def linear_4d():
    F = np.eye(4) + np.diag([0.1, 0.1], 2)
    H = np.array([[1.0, 0.2, 0, 0], [-0.3, 1.0, 0, 0]])
    return LinearGaussianModel(F, H, 0.05 * np.eye(4), [[0.5, 0.1], [0.1, 0.4]], [0.0, 0.0, 1.0, 0.5],
                               P0=np.diag([1.0, 1.0, 0.3, 0.3]))


@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("make", [UNGM.zhang2016, BearingsOnly.zhang2016, linear_4d])
def test_update_from_the_moments_deviations(make, integrator):
    model = make()
    g = GaussianParticleFlowFilter(model, 50, integrator=integrator)
    rng = np.random.default_rng(3)
    x = model.m0 + rng.standard_normal((4, 50, model.dim_x)) @ np.linalg.cholesky(3.0 * model.P0).T
    y = model.h(x[:, 0]) + 0.1 * rng.standard_normal((4, model.dim_y))
    m, P, dev = gpff._moments_dev(x)
    mp, Pp = gpff.particle_moments(x)
    assert _same(m, mp) and _same(P, Pp) and _same(dev, x - m[:, None, :])
    ref = g._update(x, y, (m, P), g._mode)
    assert _same(g._update(x, y, (m, P), g._mode, dev.copy()), ref)
    assert _same(g.update(x, y), ref)


def _old_flow_field_coefficients(lam, y, y_hat, Pxy, Pyy, R, residual=None):
    """flow.flow_field_coefficients before the solves were merged (two solves)."""
    r = (lambda a, b: a - b) if residual is None else residual
    S = lam * Pyy + R
    G = flow._T(flow._solve_sym(S, flow._T(Pxy)))
    z = flow._solve_sym(S, r(y, y_hat)[..., None])[..., 0]
    c = R[..., 0, :] * z if R.shape[-1] == 1 else flow._mv(R, z)
    return G, c


@pytest.mark.parametrize("m", [1, 2, 3])
@pytest.mark.parametrize("seed", range(4))
def test_one_solve_for_both_right_hand_sides(m, seed):
    rng = np.random.default_rng(seed)
    runs, d = 7, 4
    A = rng.standard_normal((runs, m, m))
    Pyy = A @ np.swapaxes(A, -1, -2) + 0.1 * np.eye(m)
    Pxy = rng.standard_normal((runs, d, m))
    R = np.eye(m) * 0.3 + 0.05
    y, y_hat = rng.standard_normal((runs, m)), rng.standard_normal((runs, m))
    lam = np.linspace(0.0, 1.0, 9)[:, None, None, None]
    if m == 2:     # a singular S in one run and lambda: non-finite numbers there only, as before
        Pyy[2] = -R / 0.5
    for residual in (None, lambda a, b: np.sin(a - b)):
        for lm in (lam, 0.35):
            with np.errstate(all="ignore"):
                G, c = flow.flow_field_coefficients(lm, y, y_hat, Pxy, Pyy, R, residual)
                G0, c0 = _old_flow_field_coefficients(lm, y, y_hat, Pxy, Pyy, R, residual)
            assert _same(G, G0) and _same(c, c0)


# ----------------------------------------------------------------------------- checked Euler (bearings)
class _OldCheckedEuler(gpff._WrapCheckedEuler):
    """_WrapCheckedEuler.integrate as it was: M = eye + h A, and the wrap test element by element."""

    def integrate(self, z, grid, method):
        lams, index, hs, cols, _ = flow._plan(self.grid, "euler")
        d = self.A.shape[-1]
        h = hs[:, None, None, None]
        M = np.eye(d) + h * self.A[cols[0]]
        v = h[..., 0] * self.b[cols[0]]
        o = self.origin[:, None, :]
        u = np.asarray(z, float) - o
        runs, K = u.shape[:2]
        U = np.empty((runs, len(hs), K, d))
        for j in range(len(hs)):
            U[:, j] = u
            u = u @ M[j]
            u += v[j][:, None, :]
        hz = self._base[:, None] + (U.reshape(runs, -1, d) @ self._JT).reshape(runs, len(hs), K, -1)
        yN = _OldCheckedEuler.y[:, None, None, :]
        e = yN - hz
        dev = np.abs(_OldCheckedEuler.residual(yN, hz) - e)
        self.failed = ~np.all(dev <= 1e-9 * (1.0 + np.abs(e)), axis=(1, 2, 3))
        return o + u


def test_checked_euler_is_the_old_stepping_and_wrap_test(monkeypatch):
    model = BearingsOnly.zhang2016()
    g = GaussianParticleFlowFilter(model, 30)
    rng = np.random.default_rng(2)
    x = model.m0 + rng.standard_normal((5, 30, 4)) @ np.linalg.cholesky(3.0 * model.P0).T
    y = model.h(x[:, 0]) + 0.05 * rng.standard_normal((5, 2))
    yw = y.copy()
    yw[1] = model.residual_y(model.h(x[1].mean(axis=0)) + 0.999 * np.pi, 0.0)   # a bearing opposite
    failed = {}
    real_init = gpff._WrapCheckedEuler.__init__

    def spy(self, *a, **k):
        real_init(self, *a, **k)
        failed.setdefault("fields", []).append(self)

    for yy, n_failed in ((y, 0), (yw, 1)):
        failed.clear()
        monkeypatch.setattr(gpff._WrapCheckedEuler, "__init__", spy)
        new = g.update(x, yy)
        new_failed = failed["fields"][0].failed
        monkeypatch.undo()
        _OldCheckedEuler.y, _OldCheckedEuler.residual = yy, model.residual_y
        monkeypatch.setattr(gpff, "_WrapCheckedEuler", _OldCheckedEuler)
        old = g.update(x, yy)
        monkeypatch.undo()
        assert _same(new, old)
        assert int(new_failed.sum()) == n_failed
    # the wrapped run took the exact path: the probe reference bit for bit
    assert _same(g.update(x, yw)[1], g._update_probes(x, yw)[1])


def test_bearings_only_filter_batches():
    """A run's numbers do not depend on its batch (the checked path's shortcut is per batch)."""
    model = BearingsOnly.zhang2016()
    y = model.simulate(12, 8, truth_streams(9, 8)).y
    g = GaussianParticleFlowFilter(model, 30, return_cov=True)
    full = g.filter(y, filter_streams(9, "fast", 8))
    for sel in ([0, 1, 2], [5], [7, 3]):
        part = g.filter(y[sel], filter_streams(9, "fast", 8).subset(np.array(sel)))
        assert _same(part.x, full.x[sel]) and _same(part.P, full.P[sel])


# ----------------------------------------------------------------------------- normals in blocks
def _states(streams):
    return [g.bit_generator.state for g in streams]


def _filter_with_streams(g, y, seed, blocks):
    """``g.filter`` with per-run streams, the normals drawn in blocks or step by step; the result,
    the warnings, the streams' states afterwards (or the error raised)."""
    streams = filter_streams(seed, "blocks", y.shape[0])
    orig = GaussianParticleFlowFilter._normal_blocks
    g._normal_blocks = (lambda rng, T: orig(g, rng, T)) if blocks else (lambda rng, T: None)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FilterDivergenceWarning)
            out = g.filter(y, streams)
    except FilterDivergenceError as e:
        out = str(e)
    del g._normal_blocks
    return out, _states(streams)


@pytest.mark.parametrize("budget", [None, 1000])
@pytest.mark.parametrize("case", ["UNGM", "UNGM rk4 diverging", "UNGM raise", "BOT", "linear 4-D"])
def test_normals_in_blocks_are_the_per_step_draws(case, budget, monkeypatch):
    """The same estimates and the same generator states afterwards, whether each run's normals
    are drawn a step at a time or in blocks (one block, or many with a small budget), also when
    runs diverge (they stop drawing) and when the filter raises."""
    if budget is not None:
        monkeypatch.setattr(gpff._NormalBlocks, "BUDGET", budget)
    kw, T = {}, 15
    if case.startswith("UNGM"):
        model = UNGM.zhang2016()
        if case != "UNGM":
            kw = {"max_shift": 0.7, "integrator": "rk4" if "rk4" in case else "euler",
                  "on_divergence": "raise" if "raise" in case else "warn"}
    else:
        model = BearingsOnly.zhang2016() if case == "BOT" else linear_4d()
    for runs in (1, 3, 8):
        y = model.simulate(T, runs, truth_streams(11, runs)).y
        g = GaussianParticleFlowFilter(model, 25, return_cov=True, **kw)
        assert g._normal_blocks(filter_streams(0, "x", runs), T) is not None
        a, sa = _filter_with_streams(g, y, 5, True)
        b, sb = _filter_with_streams(g, y, 5, False)
        if isinstance(a, str):
            assert a == b
        else:
            _assert_same_result(a, b)
        assert sa == sb
    if "diverging" in case:
        assert a.diagnostics["n_diverged"] > 0


def test_normals_in_blocks_only_for_per_run_streams_and_gaussian_transitions():
    model = UNGM.zhang2016()
    g = GaussianParticleFlowFilter(model, 20)
    assert g._normal_blocks(np.random.default_rng(0), 10) is None        # one shared generator
    assert g._normal_blocks(filter_streams(0, "x", 2), 10) is not None

    class OwnTransition(UNGM):
        def sample_transition(self, x, k, rng):
            return super().sample_transition(x, k, rng)

    assert GaussianParticleFlowFilter(OwnTransition(), 20)._normal_blocks(filter_streams(0, "x", 2), 10) is None
    blocks = g._normal_blocks(filter_streams(0, "x", 2), 1)
    with pytest.raises(ValueError, match="unexpected draw"):
        blocks.take(np.arange(2)).standard_normal((2, 20, 2))


@pytest.mark.parametrize("model", ["scalar", "2-D"])
def test_the_divergence_warning_points_at_the_caller(model):
    """Both loops (the scalar one runs one call deeper) warn at the line that called ``filter``."""
    if model == "scalar":
        m = UNGM()
    else:
        m = LinearGaussianModel(F=0.9 * np.eye(2), H=np.eye(2), Q=np.eye(2), R=0.01 * np.eye(2),
                                x0=np.zeros(2), m0=np.zeros(2), P0=np.eye(2))
    sim = m.simulate(10, 4, truth_streams(1, 4))
    f = GaussianParticleFlowFilter(m, 50, max_shift=1e-3)
    assert f._scalar == (model == "scalar")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        f.filter(sim.y, filter_streams(2, "gpff", 4))
    hits = [w for w in caught if issubclass(w.category, FilterDivergenceWarning)]
    assert hits and all(w.filename == __file__ for w in hits)


def test_a_run_that_stops_early_drew_few_normals_ahead():
    """Blocks grow 8, 16, 32, ... steps: a run that stops drawing at step 3 of 50 (a diverged run)
    drew one 8-step block, not the horizon (which made the eq-41 filter 40 % slower), and settle()
    still leaves its generator where step-by-step draws would have."""
    from pfrepro.rng import RunStreams

    streams = RunStreams.from_entropy(7, 2)
    blocks = gpff._NormalBlocks(streams, 5, 50)
    for _ in range(3):
        blocks.take(np.arange(2)).standard_normal((2, 5))
    for _ in range(47):
        blocks.take(np.array([1])).standard_normal((1, 5))
    assert blocks._drawn[0] == 8 * 5 and blocks._drawn[1] == 50 * 5
    blocks.settle()
    ref = RunStreams.from_entropy(7, 2)
    ref[0].standard_normal(3 * 5)
    assert ref[0].bit_generator.state == streams[0].bit_generator.state
