"""Grid (point-mass) filter: matches the Kalman filter on scalar linear-Gaussian models.

Its only approximation on a linear model is the linear split of the moved mass between
two nodes, which adds variance t(1-t) dx^2 per step: the error is O(dx^2) (measured:
halving dx divides the errors by 4.0), and exactly zero (to round-off) when F = 1 moves
mass node to node. Sampled Gaussian kernels convolve essentially exactly.
"""
from __future__ import annotations

import numpy as np
import pytest

from pfrepro.filters import BootstrapParticleFilter, GridFilter, KalmanFilter
from pfrepro.filters.grid import GridMassWarning
from pfrepro.models import UNGM, LinearGaussianModel


def lg(F, Q, R, P0=1.0, x0=0.0):
    return LinearGaussianModel([[F]], [[1.0]], [[Q]], [[R]], [x0], P0=[[P0]])


def grid_errors(model, n_grid, bounds=(-30.0, 30.0), T=20, runs=5, seed=0):
    sim = model.simulate(T, runs=runs, rng=np.random.default_rng(seed))
    kf = KalmanFilter(model).filter(sim.y)
    g = GridFilter(model, bounds=bounds, n_grid=n_grid).filter(sim.y)
    mean_err = np.max(np.abs(g.x - kf.x)[..., 0] / np.sqrt(kf.P[..., 0, 0]))  # in posterior sds
    var_err = np.max(np.abs(g.P - kf.P) / kf.P)  # relative
    return mean_err, var_err, g


@pytest.mark.parametrize("F, Q, R", [(0.9, 1.0, 0.5), (0.5, 4.0, 2.0), (-0.7, 0.5, 0.05)])
def test_fine_grid_matches_kf(F, Q, R):
    # dx = 0.0125; measured for (0.9, 1, 0.5): mean 2.7e-5 sd, variance 5.9e-6 relative
    mean_err, var_err, g = grid_errors(lg(F, Q, R), n_grid=4801)
    assert mean_err < 1e-4 and var_err < 2e-5, (mean_err, var_err)
    assert np.all(np.abs(g.diagnostics["lost_mass"]) < 1e-12)
    assert np.all(g.diagnostics["final_edge_mass"] < 1e-12)


def test_error_is_second_order_in_dx():
    model = lg(0.9, 1.0, 0.5)
    errs = np.array([grid_errors(model, n)[:2] for n in (601, 1201, 2401)])  # dx 0.1, 0.05, 0.025
    ratios = errs[:-1] / errs[1:]
    assert np.all((ratios > 3.5) & (ratios < 4.5)), ratios  # measured 4.00


def test_unit_transition_is_exact():
    """F = 1 moves every node onto a node: no interpolation, so the grid filter is the KF to round-off."""
    mean_err, var_err, _ = grid_errors(lg(1.0, 1.0, 0.1), n_grid=601)
    assert mean_err < 1e-10 and var_err < 1e-10


def test_lost_mass_is_reported_when_bounds_too_narrow():
    model = lg(1.0, 1.0, 1.0, x0=0.0)
    y = np.linspace(0, 12, 12)[None, :, None]  # drifts toward the upper edge at 5
    with pytest.warns(GridMassWarning, match="widen bounds"):
        g = GridFilter(model, bounds=(-5.0, 5.0), n_grid=401).filter(y)
    assert 1e-3 < g.diagnostics["lost_mass"][0] <= 1
    assert g.diagnostics["final_edge_mass"][0] > 1e-3


def test_grid_agrees_with_large_pf_on_ungm():
    """Nonlinear, bimodal posteriors: a 20000-particle PF agrees with the grid within its MC error."""
    model = UNGM.zhang2016()
    sim = model.simulate(10, runs=4, rng=np.random.default_rng(1))
    g = GridFilter(model, bounds=(-40.0, 40.0), n_grid=4001).filter(sim.y)
    pf = BootstrapParticleFilter(model, 20000).filter(sim.y, rng=np.random.default_rng(2))
    z = (pf.x - g.x)[..., 0] / np.sqrt(g.P[..., 0, 0])
    # measured RMS ~0.01 posterior sds; a wrong time index or likelihood gives O(1)
    assert np.sqrt(np.mean(z**2)) < 0.05
    assert np.all(np.abs(g.diagnostics["lost_mass"]) < 1e-9)


def test_single_run_input_shapes():
    model = lg(0.9, 1.0, 0.5)
    g = GridFilter(model, bounds=(-20, 20), n_grid=801).filter(np.array([0.1, -0.3, 0.7]))
    assert g.x.shape == (1, 3, 1) and g.P.shape == (1, 3, 1, 1)


def test_log_domain_posterior_reads_a_nan_likelihood_as_zero():
    """A NaN log-likelihood at one node is likelihood 0 there (not +inf, which would make the
    row 'collapsed' and throw the measurement away)."""
    from pfrepro.filters import GridFilter

    pred = np.array([[0.25, 0.25, 0.5]])
    post, coll = GridFilter._log_domain_posterior(pred, np.array([[0.0, np.nan, -1.0]]), k=1)
    e = np.exp(-1.0)
    np.testing.assert_allclose(post[0], [0.25 / (0.25 + 0.5 * e), 0.0, 0.5 * e / (0.25 + 0.5 * e)], rtol=1e-15)
    assert not coll[0]


def test_move_matrix_hand_cases_at_the_grid_edges():
    """Grid 0, 1, ..., 4 (dx = 1). The mass at g_i goes to f(g_i), split linearly between the
    two nodes around it; a point mapped beyond the grid is lost, one mapped exactly onto the
    first or last node stays whole."""
    from pfrepro.filters import GridFilter
    from pfrepro.models import StateSpaceModel

    class Shift(StateSpaceModel):
        def __init__(self, s):
            self.s = s
            super().__init__(dim_x=1, dim_y=1, Q=16.0, measurement_noise=1.0, x0=[2.0], m0=[2.0], P0=[[1.0]])

        def f(self, x, k):
            return x + self.s

        def h(self, x):
            return x

    def M(s):
        return GridFilter(Shift(s), bounds=(0.0, 4.0), n_grid=5)._move_matrix(1).toarray()

    half = np.zeros((5, 5))
    for i in range(4):
        half[i, i] = half[i + 1, i] = 0.5            # node 4 -> 4.5: off the grid, lost
    np.testing.assert_array_equal(M(0.5), half)
    one = np.zeros((5, 5))
    for i in range(4):
        one[i + 1, i] = 1.0                           # node 3 -> 4 exactly: kept on the last node
    np.testing.assert_array_equal(M(1.0), one)
    down = np.zeros((5, 5))
    for i in range(1, 5):
        down[i - 1, i] = 1.0                          # node 1 -> 0 exactly: kept; node 0 -> -1: lost
    np.testing.assert_array_equal(M(-1.0), down)


def test_grid_filter_is_the_kalman_filter_on_a_linear_model_with_a_prior_off_zero():
    """x_k = 0.9 x_{k-1} + w, y = x + v, prior N(5, 2): the grid filter's mean and variance are
    the Kalman filter's (to grid accuracy) -- the prior is centred on m0 = 5, not -5 --, its
    diagnostics: lost mass accumulates (>= the last step's), edge mass per run, no log-domain step."""
    from pfrepro.filters import GridFilter, KalmanFilter
    from pfrepro.models import LinearGaussianModel

    m = LinearGaussianModel([[0.9]], [[1.0]], [[1.0]], [[0.5]], x0=[5.0], m0=[5.0], P0=[[2.0]])
    sim = m.simulate(6, 2, np.random.default_rng(0))
    g = GridFilter(m, bounds=(-20.0, 30.0), n_grid=2001).filter(sim.y)
    kf = KalmanFilter(m).filter(sim.y)
    np.testing.assert_allclose(g.x, kf.x, atol=1e-4)
    np.testing.assert_allclose(g.P, kf.P, atol=1e-4)
    d = g.diagnostics
    assert d["final_edge_mass"].shape == (2,) and np.all(d["final_edge_mass"] < 1e-12)
    assert d["lost_mass"].shape == (2,) and np.all((d["lost_mass"] >= 0) & (d["lost_mass"] < 1e-9))
    assert d["log_domain_steps"].dtype == bool and not d["log_domain_steps"].any()
    # an outlier that needs the log domain in run 1 at step 3 is recorded there
    y = sim.y.copy()
    y[1, 2, 0] = 1e4
    # (the outlier drags run 1's posterior onto the upper edge: mass leaves the grid after it)
    # (9e-5 of a step's mass: below the default tolerance, above a stricter one)
    o = GridFilter(m, bounds=(-20.0, 30.0), n_grid=2001).filter(y).diagnostics
    with pytest.warns(GridMassWarning, match=r"in 1 of 2 runs \[1\]"):
        strict = GridFilter(m, bounds=(-20.0, 30.0), n_grid=2001, lost_mass_tol=1e-6).filter(y).diagnostics
    np.testing.assert_array_equal(strict["lost_mass"], o["lost_mass"])
    assert o["log_domain_steps"][1, 2] and o["log_domain_steps"].sum() == 1


def test_transition_kernel_is_the_sampled_process_noise_density():
    """Q = 4 (q = 2), grid (-10, 10) with 401 nodes (dx = 0.05): the kernel is N(0, q^2) sampled
    at the offsets -8q .. 8q (half = ceil(8 q / dx) = 320 nodes each side), normalised to mass
    1; its discrete variance is q^2 (the sampled Gaussian's sum reproduces the integral to far
    below round-off at dx = q / 40); neighbouring nodes differ by exp(-dx^2 / (2 q^2))."""
    g = GridFilter(lg(0.9, 4.0, 1.0), bounds=(-10.0, 10.0), n_grid=401)
    assert g.dx == pytest.approx(0.05, rel=1e-12)
    np.testing.assert_array_equal(g.grid, np.linspace(-10.0, 10.0, 401))
    half = 320
    assert g._half == half and g.kernel.shape == (2 * half + 1,)
    offs = np.arange(-half, half + 1) * 0.05
    ref = np.exp(-0.5 * offs**2 / 4.0)
    np.testing.assert_allclose(g.kernel, ref / ref.sum(), rtol=1e-12, atol=0)
    assert g.kernel.sum() == pytest.approx(1.0, abs=1e-14)
    assert np.sum(g.kernel * offs**2) == pytest.approx(4.0, rel=1e-10)
    assert g.kernel[half + 1] / g.kernel[half] == pytest.approx(np.exp(-0.5 * 0.05**2 / 4.0), rel=1e-13)


def test_convolution_is_the_linear_same_size_convolution():
    """_convolve is numpy's direct linear convolution with the kernel, cropped to the grid
    ('same'): no circular wrap-around (the FFT length covers grid + 2 half-widths) and no
    shift, also for mass next to either edge."""
    g = GridFilter(lg(0.9, 1.0, 1.0), bounds=(-5.0, 5.0), n_grid=201)
    rng = np.random.default_rng(3)
    moved = np.zeros((3, 201))
    moved[0] = rng.random(201)
    moved[1, 0], moved[1, -1] = 0.7, 0.3                # mass on the two edge nodes
    moved[2, 100] = 1.0                                 # a unit mass in the middle: the kernel
    got = g._convolve(moved)
    h = g._half
    for r in range(3):
        full = np.convolve(moved[r], g.kernel)          # length 201 + 2 h; node i sits at i + h
        np.testing.assert_allclose(got[r], full[h:h + 201], rtol=0, atol=1e-15)
    np.testing.assert_allclose(got[2, 100:], g.kernel[h:h + 101], rtol=0, atol=1e-15)
    assert g._nfft >= 201 + 2 * g._half


def test_grid_spacing_and_size_limits():
    """dx <= q / 4 is accepted (q = 1: 41 nodes on (-5, 5) give dx = 0.25 exactly), a coarser
    grid is refused; n_grid = 3 is the smallest grid; bounds must be finite with lo < hi."""
    m = lg(0.9, 1.0, 1.0)
    assert GridFilter(m, bounds=(-5.0, 5.0), n_grid=41).dx == 0.25
    with pytest.raises(ValueError, match="^grid spacing 0.256 is too coarse for process noise std 1; raise n_grid$"):
        GridFilter(m, bounds=(-5.0, 5.0), n_grid=40)
    assert GridFilter(m, bounds=(-0.1, 0.1), n_grid=3).grid.tolist() == [-0.1, 0.0, 0.1]
    with pytest.raises(ValueError, match="^n_grid must be >= 3$"):
        GridFilter(m, bounds=(-0.1, 0.1), n_grid=2)
    for bad in [(1.0, 1.0), (2.0, 1.0), (-np.inf, 1.0), (0.0, np.nan)]:
        with pytest.raises(ValueError, match=r"^bounds must satisfy lo < hi, got \("):
            GridFilter(m, bounds=bad, n_grid=41)
    for bad in [None, (1.0,), ("a", 1.0)]:
        with pytest.raises(ValueError, match=r"^bounds must be a pair \(lo, hi\) of numbers, got "):
            GridFilter(m, bounds=bad, n_grid=41)


def test_constructor_arguments_reach_the_filter():
    """The filter's own N(m0, P0) replaces the model's (the grid filter is then the Kalman
    filter started from it); the defaults are the documented grid (-60, 60) with 6001 nodes;
    a non-Gaussian process noise and a non-integer n_grid are refused by name."""
    from pfrepro.noise import GaussianMixtureNoise

    m = lg(0.9, 1.0, 0.5)                                # model prior N(0, 1)
    y = m.simulate(5, 2, np.random.default_rng(1)).y
    g = GridFilter(m, bounds=(-20.0, 30.0), n_grid=2001, m0=[4.0], P0=[[0.3]])
    assert g.m0.tolist() == [4.0] and g.P0.tolist() == [[0.3]]
    kf = KalmanFilter(m, m0=[4.0], P0=[[0.3]]).filter(y)
    r = g.filter(y)
    np.testing.assert_allclose(r.x, kf.x, atol=1e-4)
    np.testing.assert_allclose(r.P, kf.P, atol=1e-4)
    d = GridFilter(m)
    assert d.n_grid == 6001 and d.grid[0] == -60.0 and d.grid[-1] == 60.0
    bad = lg(0.9, 1.0, 0.5)
    bad.process_noise = GaussianMixtureNoise([0.5, 0.5], [[[1.0]], [[2.0]]])
    with pytest.raises(TypeError, match="non-Gaussian process noise"):   # the capability check
        GridFilter(bad, bounds=(-5.0, 5.0), n_grid=401)
    with pytest.raises(TypeError, match="n_grid must be a positive integer"):
        GridFilter(m, bounds=(-5.0, 5.0), n_grid=40.5)


def test_lost_mass_is_summed_over_steps_per_run():
    """F = 1, Q = 1, prior N(4.5, 1) on the grid (-5, 5): the first prediction pushes
    P(x + w > 5 or < -5) of the (grid-truncated) prior off the grid -- computed here by
    quadrature, 0.206 --; y_1 = y_2 = 0 with R = 0.01 pulls the mass to 0, where step 2 loses
    only P(abs(N(0, 1.01)) > 5) = 6e-7. lost_mass is per run and cumulative: after 2 steps it is the step-1 loss, for each
    of the two runs (not the last step's loss, not a sum over runs)."""
    from scipy import integrate, stats

    m = LinearGaussianModel([[1.0]], [[1.0]], [[1.0]], [[0.01]], x0=[4.5], m0=[4.5], P0=[[1.0]])
    prior = stats.norm(4.5, 1.0)
    off = integrate.quad(lambda x: prior.pdf(x) * (stats.norm.sf(5 - x) + stats.norm.cdf(-5 - x)), -5, 5)[0]
    step1 = off / (prior.cdf(5) - prior.cdf(-5))
    assert 0.20 < step1 < 0.21
    g = GridFilter(m, bounds=(-5.0, 5.0), n_grid=801)
    y = np.zeros((2, 2, 1))
    with pytest.warns(GridMassWarning):
        one = g.filter(y[:, :1]).diagnostics["lost_mass"]
    with pytest.warns(GridMassWarning):
        d = g.filter(y).diagnostics
    two, steps = d["lost_mass"], d["lost_mass_steps"]
    # to O(dx): the two end nodes stand for half cells (measured 0.29 % at dx = 0.0125)
    np.testing.assert_allclose(one, [step1, step1], rtol=5e-3)
    np.testing.assert_allclose(steps[:, 0], one, rtol=1e-12)
    np.testing.assert_allclose(steps[:, 1], 2 * stats.norm.sf(5 / np.sqrt(1.01)), rtol=0.05)  # step 2: 6e-7
    np.testing.assert_allclose(two, 1 - (1 - steps[:, 0]) * (1 - steps[:, 1]), rtol=1e-12)


# -- mass leaving the grid (issue 34, item 5) -------------------------------------------------------
def test_grid_too_narrow_for_the_posterior_warns_and_lost_mass_is_a_fraction():
    """UNGM with bounds (-1, 1): the posterior lives on about (-20, 20), so the grid mean sits in
    (-1, 1), about 10 away from the truth. Before: silent, lost_mass 48.5 (a sum of per-step
    fractions, not a mass). Now: one GridMassWarning naming the runs, lost_mass in [0, 1]."""
    import warnings

    m = UNGM.zhang2016()
    sim = m.simulate(50, 4, np.random.default_rng(0))
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        g = GridFilter(m, bounds=(-1.0, 1.0), n_grid=401).filter(sim.y)
    msgs = [str(w.message) for w in rec if issubclass(w.category, GridMassWarning)]
    assert len(msgs) == 1 and "in 4 of 4 runs [0, 1, 2, 3]" in msgs[0] and "widen bounds (-1, 1)" in msgs[0]
    d = g.diagnostics
    assert np.all((d["lost_mass"] >= 0) & (d["lost_mass"] <= 1)) and np.all(d["lost_mass"] > 0.99)
    assert d["lost_mass_steps"].shape == (4, 50) and np.all((d["lost_mass_steps"] >= 0) & (d["lost_mass_steps"] <= 1))
    assert np.sqrt(np.mean((g.x[..., 0] - sim.x[:, 1:, 0]) ** 2)) > 5      # the wrong answer it warns about
    # wide enough: silent, and the lost fraction is round-off (never negative)
    with warnings.catch_warnings():
        warnings.simplefilter("error", GridMassWarning)
        ok = GridFilter(m, bounds=(-40.0, 40.0), n_grid=1601).filter(sim.y).diagnostics
    assert np.all((ok["lost_mass"] >= 0) & (ok["lost_mass"] < 1e-12))
    with pytest.raises(ValueError, match="lost_mass_tol"):
        GridFilter(m, bounds=(-40.0, 40.0), n_grid=1601, lost_mass_tol=2.0)


def test_theta_grid_reference_stuck_at_its_x_grid_edge_is_reported():
    """x_bounds (-3, 3) on the sec 5.1 model: the x posterior sticks to the grid's edge and drags
    θ's posterior to the end of its range (θ̂ about 0.01 for a true 0.5). Before: silent, with a
    lost_mass of 48 per θ. Now: one GridMassWarning, lost_mass in [0, 1], and the θ posterior's
    mass at the ends of its grid reported."""
    import warnings

    from pfrepro.experiments.dpf_hou2008 import model_51
    from pfrepro.filters.theta_grid import ThetaGridReference

    pm = model_51()
    ps = pm.simulate(50, 3, np.random.default_rng(0))
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        r = ThetaGridReference(pm, n_theta=21, n_grid=61, x_bounds=(-3.0, 3.0)).filter(ps.y)
    msgs = [str(w.message) for w in rec if issubclass(w.category, GridMassWarning)]
    assert len(msgs) == 1 and msgs[0].startswith("ThetaGridReference:") and "widen x_bounds (-3, 3)" in msgs[0]
    d = r.diagnostics
    assert d["lost_mass"].shape == (3, 21) and np.all((d["lost_mass"] >= 0) & (d["lost_mass"] <= 1))
    assert d["lost_mass_steps"].shape == (3, 50) and d["lost_mass_steps"].max() > 0.5
    assert np.all(d["theta"][:, -1] < 0.1) and np.all(d["theta_edge_mass"][:, -1] > 0.2)   # stuck at the edge
    with warnings.catch_warnings():
        warnings.simplefilter("error", GridMassWarning)
        good = ThetaGridReference(pm, n_theta=21, n_grid=201, x_bounds=(-40.0, 40.0)).filter(ps.y).diagnostics
    assert np.all(np.abs(good["theta"][:, -1] - 0.5) < 0.2) and np.all(good["lost_mass"] < 1e-12)
    assert np.all(good["theta_edge_mass"][:, -1] < 1e-3)
