"""Tests of the GPFF flow math (pfrepro.flow) and filter (Zhang, Zhou & Feng 2016)."""
import numpy as np
import pytest

from pfrepro import flow, metrics
from pfrepro.experiments.gpff_zhang2016 import random_linear_problem
from pfrepro.filters import (FilterDivergenceError, FilterDivergenceWarning, GaussianParticleFlowFilter, KalmanFilter,
                             ScaledSigmaPoints, kalman_update, unscented_transform)
from pfrepro.filters.gpff import particle_moments
from pfrepro.models import CWPA, UNGM, BearingsOnly, LinearGaussianModel
from pfrepro.montecarlo import filter_rng, truth_rng

SIZES = [(1, 1), (3, 1), (4, 2), (6, 3)]


def _kf(mean, P, H, R, y):
    x, Pk, _ = kalman_update(mean[None], P[None], (y - H @ mean)[None], H, R)
    return x[0], Pk[0]


@pytest.mark.parametrize("d,m", SIZES)
def test_homotopy_at_one_is_kalman_posterior(d, m):
    mean, P, H, R, y = random_linear_problem(d, m, np.random.default_rng(d * 10 + m))
    xk, Pk = _kf(mean, P, H, R, y)
    x1, P1 = flow.homotopy_moments(mean, P, H, R, y, 1.0)
    np.testing.assert_allclose(x1, xk, atol=1e-12)
    np.testing.assert_allclose(P1, Pk, atol=1e-12)


@pytest.mark.parametrize("d,m", SIZES)
def test_affine_flow_reproduces_kf_update(d, m):
    """Particles moved by the affine flow (eqs 24, 27): RK4 with fine steps and the exact map
    give the Kalman update of the cloud's sample moments (mean and covariance)."""
    rng = np.random.default_rng(100 + d)
    mean, P, H, R, y = random_linear_problem(d, m, rng)
    X = mean + rng.standard_normal((1, 400, d)) @ np.linalg.cholesky(P).T
    ms, Ps = particle_moments(X)
    xt, Pt = _kf(ms[0], Ps[0], H, R, y)
    Z = flow.integrate_flow(X, lambda z, lam: flow.affine_flow_field(z, lam, ms, Ps, H, R, y[None]),
                            flow.lambda_schedule(200), "rk4")
    mz, Pz = particle_moments(Z)
    np.testing.assert_allclose(mz[0], xt, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(Pz[0], Pt, rtol=1e-6, atol=1e-7)
    x1, Phi = flow.exact_affine_map(ms, Ps, H, R, y[None])
    Ze = x1[:, None] + (X - ms[:, None]) @ np.swapaxes(Phi, -1, -2)
    me, Pe = particle_moments(Ze)
    np.testing.assert_allclose(me[0], xt, atol=1e-10)
    np.testing.assert_allclose(Pe[0], Pt, atol=1e-10)


def test_flow_moment_ode_equals_kalman_bucy_rhs():
    """The cloud moments' velocity (A m + b, A P + P A^T) equals eqs (39)-(40) along the homotopy."""
    mean, P, H, R, y = random_linear_problem(4, 2, np.random.default_rng(7))
    for lam in (0.0, 0.3, 1.0):
        xl, Pl = flow.homotopy_moments(mean, P, H, R, y, lam)
        a1, B1 = flow.flow_moment_rhs(xl, Pl, lam, mean, P, H, R, y)
        a2, B2 = flow.kalman_bucy_rhs(xl, Pl, H, R, y)
        np.testing.assert_allclose(a1, a2, atol=1e-12)
        np.testing.assert_allclose(B1, B2, atol=1e-12)


@pytest.mark.parametrize("d,m", SIZES)
def test_nonlinear_field_equals_linear_field_for_linear_h(d, m):
    rng = np.random.default_rng(200 + d)
    mean, P, H, R, y = random_linear_problem(d, m, rng)
    sp = ScaledSigmaPoints(d, 1.0, 2.0, 0.0)
    sig = sp.sigma_points(mean[None], P[None])
    yh, Pyy, dy = unscented_transform(sig @ H.T, sp.Wm, sp.Wc)
    Pxy = np.einsum("i,rij,rik->rjk", sp.Wc, sig - mean, dy)
    X = mean + rng.standard_normal((1, 30, d))
    for lam in (0.0, 0.4, 1.0):
        f_lin = flow.affine_flow_field(X, lam, mean[None], P[None], H, R, y[None])
        f_nl = flow.gaussian_flow_field(X, lam, X @ H.T, y[None], yh, Pxy, Pyy, R)
        np.testing.assert_allclose(f_nl, f_lin, rtol=1e-11, atol=1e-11)
        B, u = flow.nonlinear_coefficients(lam, y, yh[0], Pxy[0], Pyy[0], R, "corrected")
        np.testing.assert_allclose(X[0] @ H.T @ B.T + u, f_lin[0], rtol=1e-10, atol=1e-10)
        # one state per run (..., d) instead of particles (..., N, d): the same field
        one = flow.affine_flow_field(X[:, 3], lam, mean[None], P[None], H, R, y[None])
        np.testing.assert_allclose(one, f_lin[:, 3], rtol=1e-13, atol=1e-13)


def test_printed_eq46_is_dimensionally_inconsistent():
    mean, P, H, R, y = random_linear_problem(4, 2, np.random.default_rng(3))
    Pxy, Pyy = P @ H.T, H @ P @ H.T
    with pytest.raises(ValueError):
        flow.nonlinear_coefficients(0.5, y, H @ mean, Pxy, Pyy, R, "printed")


@pytest.mark.parametrize("kind", ["uniform", "exponential"])
@pytest.mark.parametrize("n", [1, 7, 20, 29])
def test_lambda_schedules_sum_to_one(kind, n):
    g = flow.lambda_schedule(n, kind, 1.2)
    assert g[0] == 0.0 and g[-1] == 1.0 and g.size == n + 1
    assert np.all(np.diff(g) > 0)
    assert abs(np.diff(g).sum() - 1.0) < 1e-14
    if kind == "uniform":
        np.testing.assert_allclose(np.diff(g), 1.0 / n)
    elif n > 1:
        np.testing.assert_allclose(np.diff(g)[1:] / np.diff(g)[:-1], 1.2)


def test_integrator_orders():
    """Observed orders of Euler, midpoint, RK4 on the affine flow are close to 1, 2, 4."""
    rng = np.random.default_rng(11)
    mean, P, H, R, y = random_linear_problem(3, 2, rng)
    X = mean + rng.standard_normal((1, 50, 3)) @ np.linalg.cholesky(P).T
    ms, Ps = particle_moments(X)
    x1, Phi = flow.exact_affine_map(ms, Ps, H, R, y[None])
    target = x1[:, None] + (X - ms[:, None]) @ np.swapaxes(Phi, -1, -2)
    for meth, order in flow.INTEGRATORS.items():
        errs = []
        for n in (40, 80):
            Z = flow.integrate_flow(X, lambda z, lam: flow.affine_flow_field(z, lam, ms, Ps, H, R, y[None]),
                                    flow.lambda_schedule(n), meth)
            errs.append(np.max(np.abs(Z - target)))
        assert abs(np.log2(errs[0] / errs[1]) - order) < 0.3, (meth, errs)


def test_gpff_close_to_kf_on_linear_model():
    model = CWPA.zhang2016("gaussian")
    sim = model.simulate(40, 30, truth_rng(1))
    kf = metrics.mse(sim.x[:, 1:], KalmanFilter(model).filter(sim.y).x).mean()
    for integ in ("euler", "exact"):
        g = GaussianParticleFlowFilter(model, 200, integrator=integ).filter(sim.y, filter_rng(1, "GPFF"))
        assert g.x.shape == (30, 40, 6)
        gm = metrics.mse(sim.x[:, 1:], g.x).mean()
        assert abs(gm - kf) / kf < 0.15, (integ, gm, kf)


def test_gpff_runs_on_nonlinear_models_and_is_reproducible():
    model = BearingsOnly.zhang2016()
    sim = model.simulate(20, 5, truth_rng(2))
    for field in ("eq41", "eq43"):
        f = GaussianParticleFlowFilter(model, 50, field=field)
        a = f.filter(sim.y, np.random.default_rng(5))
        b = f.filter(sim.y, np.random.default_rng(5))
        np.testing.assert_array_equal(a.x, b.x)
        assert np.all(np.isfinite(a.x))


def test_eq43_affine_shortcut_matches_stepping_every_particle():
    """The eq43 field is affine: moving d+1 probes and applying the map = stepping each particle."""
    model = UNGM.zhang2016()
    f = GaussianParticleFlowFilter(model, 64, field="eq43", integrator="rk4")
    rng = np.random.default_rng(0)
    x = rng.normal(3.0, 2.0, (4, 64, 1))
    y = rng.normal(1.0, 1.0, (4, 1))
    fast = f.update(x, y)
    m, P, y_hat, Pyy, Pxy = f.prior_statistics(x)
    J = np.swapaxes(np.linalg.solve(P, Pxy), -1, -2)

    def field(z, lam):
        hz = y_hat[:, None, :] + (z - m[:, None, :]) @ np.swapaxes(J, -1, -2)
        return flow.gaussian_flow_field(z, lam, hz, y, y_hat, Pxy, Pyy, model.R)

    slow = flow.integrate_flow(x, field, f.grid, "rk4")
    np.testing.assert_allclose(fast, slow, rtol=1e-10, atol=1e-10)


def test_eq41_divergence_is_recorded_when_dropping():
    model = UNGM.zhang2016()
    sim = model.simulate(30, 4, truth_rng(3))
    res = GaussianParticleFlowFilter(model, 50, field="eq41", on_divergence="drop").filter(
        sim.y, np.random.default_rng(1))
    d = res.diagnostics["diverged_at"]
    assert d.shape == (4,)
    for r in range(4):
        if d[r] > 0:
            assert np.all(np.isnan(res.x[r, d[r] - 1:]))
            assert np.all(np.isfinite(res.x[r, :d[r] - 1]))
    assert res.diagnostics["n_diverged"] > 0
    with pytest.raises(FilterDivergenceError):
        GaussianParticleFlowFilter(model, 50, field="eq41", on_divergence="raise").filter(
            sim.y, np.random.default_rng(1))
    # the default keeps the runs and warns once, with the count
    with pytest.warns(FilterDivergenceWarning, match=f"{res.diagnostics['n_diverged']} of 4 runs diverged"):
        warned = GaussianParticleFlowFilter(model, 50, field="eq41").filter(sim.y, np.random.default_rng(1))
    np.testing.assert_array_equal(warned.x, res.x)


def test_input_validation():
    model = CWPA.zhang2016()
    mean, P, H, R, y = random_linear_problem(3, 2, np.random.default_rng(0))
    with pytest.raises(ValueError):
        GaussianParticleFlowFilter(model, 1)
    with pytest.raises(ValueError):
        GaussianParticleFlowFilter(model, 0)
    with pytest.raises(ValueError):
        GaussianParticleFlowFilter(model, 10, integrator="leapfrog")
    with pytest.raises(ValueError):
        GaussianParticleFlowFilter(model, 10, field="eq99")
    with pytest.raises(TypeError):
        GaussianParticleFlowFilter(UNGM.zhang2016(), 10, integrator="exact")
    with pytest.raises(TypeError):
        GaussianParticleFlowFilter(model, 10).filter(np.zeros((1, 5, 2)), rng=None)
    with pytest.raises(ValueError):
        GaussianParticleFlowFilter(model, 10).filter(np.full((1, 5, 2), np.nan), np.random.default_rng(0))
    with pytest.raises(ValueError):
        GaussianParticleFlowFilter(model, 10).filter(np.zeros((1, 5, 3)), np.random.default_rng(0))
    with pytest.raises(ValueError):
        flow.lambda_schedule(0)
    with pytest.raises(ValueError):
        flow.lambda_schedule(10, "log")
    with pytest.raises(ValueError):
        flow.lambda_schedule(10, "exponential", ratio=-1)
    with pytest.raises(ValueError):
        flow.homotopy_moments(mean, -P, H, R, y, 0.5)           # not positive definite
    with pytest.raises(ValueError):
        flow.homotopy_moments(mean, P + np.triu(np.ones((3, 3)), 1), H, R, y, 0.5)  # not symmetric
    with pytest.raises(ValueError):
        flow.homotopy_moments(mean, P, H.T, R, y, 0.5)          # wrong H shape
    with pytest.raises(ValueError):
        flow.homotopy_moments(mean, P, H, R, y, 1.5)            # lambda outside [0, 1]
    with pytest.raises(ValueError):
        flow.affine_flow_coefficients(mean * np.nan, P, H, R, y, 0.5)
    with pytest.raises(ValueError):
        flow.integrate_flow(np.zeros((1, 3)), lambda z, lam: z, [0.0, 0.5, 0.4])
    with pytest.raises(ValueError):
        flow.integrate_flow(np.zeros((1, 3)), lambda z, lam: z, [0.0, 1.0], "euler2")
    with pytest.raises(ValueError):
        particle_moments(np.zeros((3, 1, 2)))


def test_linear_model_exact_integrator_handles_generic_linear_model():
    model = LinearGaussianModel(F=[[1.0, 0.1], [0.0, 1.0]], H=[[1.0, 0.0]], Q=0.01 * np.eye(2), R=[[0.1]],
                                x0=[0.0, 1.0])
    sim = model.simulate(25, 10, truth_rng(4))
    g = GaussianParticleFlowFilter(model, 500, integrator="exact").filter(sim.y, filter_rng(4, "g"))
    k = KalmanFilter(model).filter(sim.y)
    assert np.max(np.abs(g.x - k.x)) < 0.2


def test_field_from_cached_coefficients_is_the_field():
    """GPFF's per-lambda coefficient cache (flow_field_coefficients + field_from_coefficients)
    computes exactly what gaussian_flow_field computes, scalar and vector measurements."""
    rng = np.random.default_rng(5)
    for d, m in ((1, 1), (4, 2), (3, 3)):
        A = rng.standard_normal((2, m, m)); Pyy = A @ np.swapaxes(A, -1, -2) + np.eye(m)
        Pxy = rng.standard_normal((2, d, m)); R = np.eye(m) * 0.3
        y, yh, hx = rng.standard_normal((2, m)), rng.standard_normal((2, m)), rng.standard_normal((2, 7, m))
        for lam in (0.0, 0.35, 1.0):
            ref = flow.gaussian_flow_field(None, lam, hx, y, yh, Pxy, Pyy, R)
            G, c = flow.flow_field_coefficients(lam, y, yh, Pxy, Pyy, R)
            assert np.array_equal(flow.field_from_coefficients(hx, y, G, c), ref)
            # and the defining formula, 1/2 Pxy C [r(y, h) + R C r(y, y_hat)], C = (lam Pyy + R)^-1
            C = np.linalg.inv(lam * Pyy + R)
            want = 0.5 * np.einsum("rdm,rmk,rnk->rnd", Pxy, C,
                                   (y[:, None] - hx) + np.einsum("mk,rkj,rj->rm", R, C, y - yh)[:, None])
            np.testing.assert_allclose(ref, want, rtol=1e-10, atol=1e-12)


# --------------------------------------------------------------- free choices, readings, claims statistics
from pfrepro.experiments import gpff_zhang2016 as E  # noqa: E402


def test_choices_rows_and_reading_labels():
    from pfrepro.choices import FIXED, as_choice_map
    cmap = as_choice_map(E.CHOICES)
    # every choice the reading filters vary is a non-fixed row of the table
    for which in ("ung", "bot", "cwpa_gaussian"):
        for label, (_, tags) in E.reading_filters(which).items():
            assert " | " in label
            for c in tags:
                assert c in cmap and cmap[c].status != FIXED
    assert E.reading_label("PF(500)", "pf_resampling", "systematic", "systematic") == "PF(500)"
    assert E.reading_label("PF(500)", "pf_resampling", "multinomial", "systematic") == "PF(500) | pf_resampling=multinomial"
    with pytest.raises(ValueError):
        E.reading_filters("nope")


def test_convergence_time_by_hand():
    err = np.array([[5, 3, 1, 0.5, 3, 0.5, 0.2],     # last above the band at step 5 -> converged at 6
                    [0.1] * 7,                       # always inside -> 1
                    [5] * 7,                         # never -> T + 1
                    [0.1, 0.1, np.nan, 0.1, 0.1, 0.1, 0.1]])
    tau = E.convergence_time(err, 1.0)
    assert tau[:3].tolist() == [6, 1, 8] and np.isnan(tau[3])


def test_equivalence_is_two_one_sided():
    from pfrepro.stats import equivalence
    assert equivalence(0.03, 0.007, 0.1) is True          # significant but inside the margin
    assert equivalence(0.09, 0.01, 0.1) is None           # interval crosses the margin
    assert equivalence(0.2, 0.01, 0.1) is False           # wholly outside
    assert equivalence(-0.2, 0.01, 0.1) is False
    assert equivalence(0.0, 0.06, 0.1) is None            # too noisy to show equivalence


def test_heavy_tail_and_robust_statistics():
    from pfrepro import stats
    rng = np.random.default_rng(0)
    light = rng.normal(10, 1, 100)
    heavy = light.copy()
    heavy[0] = 1e4
    # the shared estimators with this chapter's heavy-tail share, bootstrap size and seed
    assert not stats.heavy_tailed(light, E.HEAVY_SHARE) and stats.heavy_tailed(heavy, E.HEAVY_SHARE)
    md, se = stats.median_paired(heavy, np.zeros(100), E.BOOT, E.BOOT_SEED)
    assert abs(md - np.median(heavy)) < 1e-12 and 0 < se < 1           # the outlier does not move it
    assert stats.median_paired(heavy, np.zeros(100), E.BOOT, E.BOOT_SEED) == (md, se)   # fixed bootstrap seed
    d, se = stats.std_difference(2 * light, light, E.BOOT, E.BOOT_SEED)
    assert abs(d - np.std(light, ddof=1)) < 1e-12 and se > 0


def test_eq43_printed_differs_from_eq22_except_at_zero():
    t = E.eq43_check()
    assert t.loc[0.0].iloc[0] < 1e-12
    assert (t.iloc[1:, 0] > 0.05).all()
    assert t.attrs["landing"]["(22)"] < 1e-9 and t.attrs["landing"]["printed (43)"] > 0.05


def test_eqs16_to_18_hold():
    assert E.eqs16_18_check().to_numpy().max() < 1e-10


def test_cost_counts_as_printed_by_hand():
    """GPFF(N) with eq 43 moves d + 1 probe points, but as printed every particle moves at every
    lambda stage; the PF copies N particles per resampling event."""
    from pfrepro.cost import count_model_calls
    from pfrepro.filters import BootstrapParticleFilter
    model = BearingsOnly.zhang2016()
    T, N = 5, 50
    y = model.simulate(T, 1, truth_rng(3)).y
    for integ, stages in (("euler", 1), ("rk4", 4)):
        c = count_model_calls(GaussianParticleFlowFilter(model, N, n_steps=20, field="eq43", integrator=integ), y)
        assert c["flow_calls"] == 20 * stages * T
        assert c["flow_printed"] == 20 * stages * T * N
        assert c["model_evaluations"] == T * (N + 2 * 4 + 1)               # transitions + sigma points
        assert c["printed_operations"] == c["model_evaluations"] + c["flow_printed"]
    c = count_model_calls(BootstrapParticleFilter(model, N), y)
    assert c["resampled"] == N * T and c["model_evaluations"] == 2 * N * T
    c2 = count_model_calls(BootstrapParticleFilter(model, N, ess_threshold=0.5), y)
    assert c2["resampled"] % N == 0 and c2["resampled"] <= N * T


@pytest.mark.parametrize("integrator", ["euler", "rk4", "exact"])
def test_update_with_the_callers_moments_is_bit_identical(integrator):
    # the filter hands update() the prior moments it computed for the divergence test
    m = UNGM.zhang2016() if integrator != "exact" else LinearGaussianModel(
        F=[[1.0, 0.1], [0.0, 1.0]], H=[[1.0, 0.0]], Q=0.01 * np.eye(2), R=[[0.1]], x0=[0.0, 1.0])
    g = GaussianParticleFlowFilter(m, 50, integrator=integrator, field="eq43")
    x = np.random.default_rng(1).normal(size=(3, 50, m.dim_x))
    y = np.random.default_rng(2).normal(size=(3, m.dim_y))
    assert np.array_equal(g.update(x, y), g.update(x, y, moments=particle_moments(x)))
