"""The GPFF's eq (43) flow map in closed form (pfrepro.flow.affine_flow_map, AffineField).

With a plain measurement residual the eq (43) field is affine in the state, so the
integrator's whole map over the lambda grid is computed in closed form instead of stepping
d + 1 probe points through 20-80 stages. That changes rounding only: these tests hold the
closed form to the stepped reference (kept as ``GaussianParticleFlowFilter._update_probes``
and :func:`pfrepro.flow.integrate_flow`) to 1e-10 relative to the cloud's scale (the two
differ by ~1e-13 in practice), for every integrator and schedule, on the UNGM (d = m = 1)
and on linear models of 2 and 4 dimensions. The bearings-only model (angle wrap) keeps the
probe path bit for bit, and the count of the algorithm as printed does not move.
"""
import numpy as np
import pytest

from pfrepro import flow
from pfrepro.cost import count_model_calls
from pfrepro.filters import GaussianParticleFlowFilter
from pfrepro.filters.gpff import _posterior_moments, particle_moments
from pfrepro.filters.sigma_points import ScaledSigmaPoints
from pfrepro.models import UNGM, BearingsOnly, LinearGaussianModel
from pfrepro.montecarlo import filter_streams, truth_streams

INTEGRATORS = ["euler", "midpoint", "rk4"]
#: closed form against stepping, relative to the cloud's scale (observed: ~1e-13)
RTOL = 1e-10


def linear_2d():
    """2-D state, one scalar measurement mixing both components (m = 1, d = 2)."""
    return LinearGaussianModel([[1.0, 0.1], [0.0, 1.0]], [[1.0, 0.5]], [[0.2, 0.05], [0.05, 0.1]], [[0.3]],
                               [0.0, 0.0], P0=np.array([[2.0, 0.8], [0.8, 1.0]]))


def linear_4d():
    """4-D turning constant-velocity model, a rotated 2-D position sensor (m = 2, d = 4)."""
    dt, om, th = 0.7, 0.15, 0.4
    F = np.array([[1.0, 0, np.sin(om * dt) / om, -(1 - np.cos(om * dt)) / om],
                  [0, 1, (1 - np.cos(om * dt)) / om, np.sin(om * dt) / om],
                  [0, 0, np.cos(om * dt), -np.sin(om * dt)], [0, 0, np.sin(om * dt), np.cos(om * dt)]])
    Q = 0.05 * np.array([[dt ** 3 / 3, 0, dt ** 2 / 2, 0], [0, dt ** 3 / 3, 0, dt ** 2 / 2],
                         [dt ** 2 / 2, 0, dt, 0], [0, dt ** 2 / 2, 0, dt]])
    H = np.array([[np.cos(th), np.sin(th), 0, 0], [-np.sin(th), np.cos(th), 0, 0]])
    return LinearGaussianModel(F, H, Q, [[0.5, 0.1], [0.1, 0.4]], [0.0, 0.0, 1.0, 0.5],
                               P0=np.diag([1.0, 1.0, 0.3, 0.3]))


MODELS = {"UNGM": UNGM.zhang2016, "linear 2-D": linear_2d, "linear 4-D": linear_4d}


def _cloud(model, runs, N, seed):
    rng = np.random.default_rng(seed)
    x = model.m0 + rng.standard_normal((runs, N, model.dim_x)) @ np.linalg.cholesky(3.0 * model.P0).T
    y = model.h(x[:, 0]) + rng.standard_normal((runs, model.dim_y))
    return x, y


@pytest.mark.parametrize("schedule", ["uniform", "exponential"])
@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("name", list(MODELS))
def test_closed_form_update_matches_the_probe_integration(name, integrator, schedule):
    model = MODELS[name]()
    g = GaussianParticleFlowFilter(model, 40, integrator=integrator, schedule=schedule, n_steps=20)
    assert g._plain_residual
    x, y = _cloud(model, 5, 40, 3)
    fast, slow = g.update(x, y), g._update_probes(x, y)
    scale = np.max(np.abs(slow - slow.mean(axis=1, keepdims=True)))
    np.testing.assert_allclose(fast, slow, rtol=0, atol=RTOL * scale)
    assert not np.array_equal(fast, slow)            # a different arithmetic (else nothing was tested)


@pytest.mark.parametrize("n_steps", [1, 2, 7, 20])
@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("d", [1, 2, 4])
def test_affine_flow_map_is_the_integrators_map(d, integrator, n_steps):
    """Random affine fields u A(lam) + b(lam) tabulated at the stage lambdas: the closed form
    equals stepping points with integrate_flow (odd step counts exercise the pairing tree)."""
    rng = np.random.default_rng(d * 100 + n_steps)
    grid = flow.lambda_schedule(n_steps, "exponential", 1.3)
    lams, index = flow.stage_lambdas(grid, integrator)
    B = rng.standard_normal((3, d, d))
    A = -np.einsum("l,rij,rkj->lrik", 1.0 + lams, B, B) + 0.3 * rng.standard_normal((lams.size, 3, d, d))
    b = rng.standard_normal((lams.size, 3, d))
    at = {lam: i for i, lam in enumerate(lams.tolist())}
    u0 = rng.standard_normal((3, 6, d))
    stepped = flow.integrate_flow(u0, lambda z, lam: z @ A[at[lam]] + b[at[lam]][:, None, :], grid, integrator)
    M, v = flow.affine_flow_map(A, b, grid, integrator)
    assert M.shape == (3, d, d) and v.shape == (3, d)
    np.testing.assert_allclose(u0 @ M + v[:, None, :], stepped, rtol=1e-12, atol=1e-12 * np.abs(stepped).max())
    # the AffineField is that field, and integrate_flow integrates it in closed form
    origin = rng.standard_normal((3, d))
    fld = flow.AffineField(A, b, origin, grid, integrator)
    z0 = origin[:, None, :] + u0
    np.testing.assert_allclose(fld(z0, lams[-1]), u0 @ A[-1] + b[-1][:, None, :], rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(flow.integrate_flow(z0, fld, grid, integrator), origin[:, None, :] + stepped,
                               rtol=1e-12, atol=1e-12 * np.abs(z0).max() * 10)


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_stage_lambdas_are_where_integrate_flow_evaluates(integrator):
    grid = flow.lambda_schedule(9, "exponential", 1.2)
    seen = []
    flow.integrate_flow(np.zeros((1, 1, 1)), lambda z, lam: (seen.append(lam), 0.0 * z)[1], grid, integrator)
    lams, index = flow.stage_lambdas(grid, integrator)
    stages = {"euler": [0], "midpoint": [0, 1], "rk4": [0, 1, 1, 2]}[integrator]
    expected = [lams[index[j, s]] for j in range(len(grid) - 1) for s in stages]
    assert seen == expected                           # the same floats, in the same order
    assert len(set(lams.tolist())) == lams.size


def test_affine_flow_map_and_field_reject_bad_input():
    grid = flow.lambda_schedule(4)
    lams, _ = flow.stage_lambdas(grid, "euler")
    A, b = -np.ones((lams.size, 2, 1, 1)), np.zeros((lams.size, 2, 1))
    with pytest.raises(ValueError, match="A must be"):
        flow.affine_flow_map(A[1:], b[1:], grid, "euler")
    with pytest.raises(ValueError, match="b must be"):
        flow.affine_flow_map(A, b[..., None], grid, "euler")
    with pytest.raises(ValueError, match="integrator"):
        flow.affine_flow_map(A, b, grid, "heun")
    with pytest.raises(ValueError, match="stages"):
        flow.affine_flow_map(A, b, grid, "euler", stages=flow.stage_lambdas(flow.lambda_schedule(5), "euler"))
    fld = flow.AffineField(A, b, np.zeros((2, 1)), grid, "euler")
    with pytest.raises(ValueError, match="tabulated"):
        flow.integrate_flow(np.zeros((2, 3, 1)), fld, flow.lambda_schedule(5), "euler")
    with pytest.raises(ValueError, match="tabulated"):
        flow.integrate_flow(np.zeros((2, 3, 1)), fld, grid, "rk4")


def test_the_closed_form_does_not_step(monkeypatch):
    """With a plain residual the update never evaluates the field point by point."""
    def refuse(self, z, lam):
        raise AssertionError("the closed form stepped the field")

    monkeypatch.setattr(flow.AffineField, "__call__", refuse)
    model = UNGM.zhang2016()
    x, y = _cloud(model, 3, 30, 1)
    for integrator in INTEGRATORS:
        assert np.all(np.isfinite(GaussianParticleFlowFilter(model, 30, integrator=integrator).update(x, y)))


def test_bearings_only_rk4_keeps_the_probe_path_bit_for_bit():
    """The angle wrap makes the field affine only piecewise: with RK stages the bearings-only
    model keeps integrating the probe points (the reference itself, bit for bit)."""
    model = BearingsOnly.zhang2016()
    g = GaussianParticleFlowFilter(model, 30, integrator="rk4")
    assert not g._plain_residual
    x, y = _cloud(model, 3, 30, 2)
    assert np.array_equal(g.update(x, y), g._update_probes(x, y))


def test_bearings_only_euler_checks_the_wrap():
    """Euler on the bearings-only model: precomputed steps of the field with plain subtraction,
    the stepped reference up to rounding where no angle wraps between the probes, and the
    reference itself, bit for bit, in a run where one does (a bearing measured opposite to the
    predicted one); the other runs keep the fast path."""
    model = BearingsOnly.zhang2016()
    g = GaussianParticleFlowFilter(model, 30)
    x, y = _cloud(model, 4, 30, 2)
    fast, slow = g.update(x, y), g._update_probes(x, y)
    scale = np.max(np.abs(slow - slow.mean(axis=1, keepdims=True)))
    np.testing.assert_allclose(fast, slow, rtol=0, atol=RTOL * scale)
    assert not np.array_equal(fast, slow)
    yw = y.copy()
    yh = model.h(x[1].mean(axis=0))
    yw[1] = np.pi - np.mod(np.pi - (yh + 0.999 * np.pi), 2 * np.pi)   # wrapped to (-pi, pi]
    fast, slow = g.update(x, yw), g._update_probes(x, yw)
    assert np.array_equal(fast[1], slow[1])
    np.testing.assert_allclose(fast, slow, rtol=0, atol=RTOL * scale)
    assert not np.array_equal(fast[0], slow[0])


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_counts_of_the_closed_form_are_those_of_the_printed_flow(integrator):
    """pfrepro.cost counts the flow by wrapping integrate_flow: the closed form still counts
    every lambda stage (the algorithm as printed) and d + 1 states per stage (the affine map is
    fixed by d + 1 points, the probes), as the stepped probes did."""
    model, T, N = UNGM.zhang2016(), 6, 25
    y = model.simulate(T, 1, truth_streams(4, 1)).y
    c = count_model_calls(GaussianParticleFlowFilter(model, N, integrator=integrator), y)
    stages = flow.INTEGRATORS[integrator]
    assert c["flow_calls"] == 20 * stages * T
    assert c["flow"] == (model.dim_x + 1) * 20 * stages * T
    assert c["flow_printed"] == 20 * stages * T * N
    assert c["model_evaluations"] == T * (N + 2 * model.dim_x + 1)


@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("name", ["UNGM", "linear 4-D"])
def test_gpff_run_is_the_same_in_any_batch(name, integrator):
    """A run's estimates do not depend on the batch it is filtered in (the closed form's
    products are stacked per run or scalar, its sums over steps run along a contiguous axis
    whatever the batch: a sum over the steps axis of (steps, runs) was pairwise for one run
    and sequential for several, and failed this test)."""
    model, big = MODELS[name](), 8
    y = model.simulate(10, big, truth_streams(11, big)).y
    g = GaussianParticleFlowFilter(model, 32, integrator=integrator, return_cov=True)
    full = g.filter(y, filter_streams(5, "GPFF", big))
    for start, size in ((2, 3), (0, 1), (6, 1)):
        part = g.filter(y[start:start + size], filter_streams(5, "GPFF", size, start=start))
        assert np.array_equal(full.x[start:start + size], part.x)
        assert np.array_equal(full.P[start:start + size], part.P)


@pytest.mark.parametrize("N", [2, 7, 100])
@pytest.mark.parametrize("d", [1, 2, 3, 4, 6])
def test_particle_moments_are_eq52(d, N):
    """d = 1: the einsum of before, bit for bit; d >= 2: one BLAS product per run, the same
    sums in another order (1e-13 relative); the variances of the divergence test are the
    einsum's diagonal, bit for bit."""
    x = np.random.default_rng(d * 1000 + N).normal(size=(5, N, d)) * 3 + 1
    m, P = particle_moments(x)
    dev = x - x.mean(axis=1)[:, None, :]
    ref = np.einsum("rni,rnj->rij", dev, dev) / (N - 1)
    ref = 0.5 * (ref + np.swapaxes(ref, -1, -2))
    assert np.array_equal(m, x.mean(axis=1))
    assert np.array_equal(P, np.swapaxes(P, -1, -2))
    if d == 1:
        assert np.array_equal(P, ref)
    else:
        np.testing.assert_allclose(P, ref, rtol=1e-13, atol=1e-13 * np.abs(ref).max())
    m2, none, var = _posterior_moments(x, full_cov=False)
    assert none is None and np.array_equal(m2, m)
    assert np.array_equal(var, np.diagonal(ref, axis1=-2, axis2=-1))
    assert np.array_equal(_posterior_moments(x)[2], np.diagonal(P, axis1=-2, axis2=-1))


@pytest.mark.parametrize("seed", range(5))
def test_two_by_two_solve_is_lapacks(seed):
    """The 2 x 2 systems (lambda Pyy + R) X = B of the flow's coefficients by Cramer's rule:
    LAPACK's solution to 1e-12 relative, singular matrices non-finite in their own run only."""
    rng = np.random.default_rng(seed)
    C = rng.standard_normal((20, 7, 2, 2))
    S = C @ np.swapaxes(C, -1, -2) + 0.01 * np.eye(2)
    B = rng.standard_normal((7, 2, 5))
    np.testing.assert_allclose(flow._solve_sym(S, B), np.linalg.solve(S, B), rtol=1e-12, atol=1e-12)
    S[3, 2] = [[1.0, 2.0], [2.0, 4.0]]
    with np.errstate(divide="ignore", invalid="ignore"):
        X = flow._solve_sym(S, B)
    assert not np.all(np.isfinite(X[3, 2]))
    mask = np.ones((20, 7), bool)
    mask[3, 2] = False
    assert np.all(np.isfinite(X[mask]))


def test_divergence_verdict_is_the_test_on_every_particle():
    """The test reads the mean and variances instead of every particle: the same verdict for
    NaN and infinite particles, a runaway variance, a runaway mean, and a healthy run."""
    g = GaussianParticleFlowFilter(UNGM.zhang2016(), 20)
    rng = np.random.default_rng(0)
    x_prior = rng.standard_normal((6, 20, 1))
    m_prior, P_prior = particle_moments(x_prior)
    x = x_prior * 0.5
    x[1, 3] = np.nan
    x[2, 4] = np.inf
    x[3, :2, 0] = [-np.inf, np.inf]
    x[4] *= 1e3                                      # variance grown 250000 x
    x[5] += 1e5                                      # mean moved 1e5 prior sd
    with np.errstate(invalid="ignore"):                # inf - inf in the sums, as in the filter
        bad, (m, P) = g._diverged(x, m_prior, P_prior, full_cov=False)
        mf, Pf = particle_moments(x)
    ok = np.all(np.isfinite(x.reshape(6, -1)), axis=1)
    prior = np.diagonal(P_prior, axis1=-2, axis2=-1)
    old = ~ok | np.any(np.diagonal(Pf, axis1=-2, axis2=-1) > 100.0 * prior, axis=1) | np.any(
        (mf - m_prior) ** 2 > 1e6 * prior, axis=1)
    np.testing.assert_array_equal(bad, old)
    np.testing.assert_array_equal(bad, [False, True, True, True, True, True])
    assert P is None and np.array_equal(m, mf, equal_nan=True)


def test_scalar_sigma_points_are_the_cholesky_points():
    """d = 1: the points from the square root equal ScaledSigmaPoints' (Cholesky) points, for a
    positive, a zero, a negative and a NaN variance alike."""
    model = UNGM.zhang2016()
    g = GaussianParticleFlowFilter(model, 10)
    m = np.array([[0.5], [1.0], [-2.0], [3.0], [1e-3]])
    P = np.array([2.3, 0.0, -1.0, np.nan, 7e-9]).reshape(5, 1, 1)
    with np.errstate(invalid="ignore"):
        _, _, y_hat, Pyy, Pxy = g.prior_statistics(None, moments=(m, P))
        sig = ScaledSigmaPoints(1, 1.0, 2.0, 0.0).sigma_points(m, P, on_error="nan")
    from pfrepro.filters.sigma_points import unscented_transform
    y_ref, Pyy_ref, dy = unscented_transform(model.h(sig), g.points.Wm, g.points.Wc, residual=model.residual_y)
    assert np.array_equal(y_hat, y_ref, equal_nan=True)
    assert np.array_equal(Pyy, 0.5 * (Pyy_ref + np.swapaxes(Pyy_ref, -1, -2)), equal_nan=True)
    assert np.array_equal(Pxy, np.einsum("i,rij,rik->rjk", g.points.Wc, sig - m[:, None, :], dy), equal_nan=True)
