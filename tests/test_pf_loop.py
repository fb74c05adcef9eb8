"""The shared particle-filter loop (filters/smc_steps.ParticleLoop) and PFPF-EDH as one affine map.

* A filter that supplies only the bootstrap move (transition draw, likelihood weight) to the
  loop IS the bootstrap PF: bit-identical estimates, evidence, ESS and resampling flags when it
  resamples by the ESS rule (the bootstrap PF's every-step mode normalises 1/N-weights in a
  different order: equal to 1e-12 there).
* EDH's A and b are the same for every particle of a run, so PFPF(EDH) composes the Euler steps
  of the flow into one affine map per run and applies it once; the map agrees with the flow
  moved step by step to 1e-10 (positions of order 10), on the bearings-only model (nonlinear h)
  and a 4-D linear one, and its log-determinant is the step-by-step one.
"""
import numpy as np
import pytest

from pfrepro.filters import BootstrapParticleFilter
from pfrepro.filters.pfpf import ParticleFlowParticleFilter
from pfrepro.filters.smc_steps import ParticleLoop
from pfrepro.models import BearingsOnly, LinearGaussianModel, UNGM
from pfrepro.montecarlo import filter_streams, truth_streams

from conftest import random_linear_model


class LoopBootstrap(ParticleLoop):
    """The bootstrap PF written as the loop's move step only."""

    name = "loop bootstrap"

    def __init__(self, model, n_particles, ess_threshold=None):
        super().__init__(model)
        self.n_particles, self.resampling, self.ess_threshold = n_particles, "systematic", ess_threshold

    def _move(self, k, x, logw, yk, rng, state):
        x = self.model.sample_transition(x, k, rng)
        return x, self.model.log_likelihood(yk, x)


@pytest.mark.parametrize("make_model, threshold", [(UNGM.zhang2016, 0.5),
                                                   (lambda: random_linear_model(3, nx=4, ny=2), 0.05)])
def test_the_loop_with_the_bootstrap_move_is_the_bootstrap_pf(make_model, threshold):
    model = make_model()
    runs, T = 5, 25
    y = model.simulate(T, runs, truth_streams(4, runs)).y
    a = LoopBootstrap(model, 300, ess_threshold=threshold).filter(y, filter_streams(1, "x", runs))
    b = BootstrapParticleFilter(model, 300, ess_threshold=threshold).filter(y, filter_streams(1, "x", runs))
    assert np.array_equal(a.x, b.x)
    for key in ("log_evidence", "ess", "resampled", "collapsed"):
        assert np.array_equal(a.diagnostics[key], b.diagnostics[key]), key
    assert 0 < b.diagnostics["resampled"].mean() < 1          # both branches of the ESS rule ran
    a = LoopBootstrap(model, 300).filter(y, filter_streams(1, "x", runs))
    b = BootstrapParticleFilter(model, 300).filter(y, filter_streams(1, "x", runs))
    np.testing.assert_allclose(a.x, b.x, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(a.diagnostics["log_evidence"], b.diagnostics["log_evidence"], rtol=1e-12)


def _flow_inputs(model, runs, N, seed):
    rng = np.random.default_rng(seed)
    n = model.dim_x
    mean = np.broadcast_to(model.m0, (runs, n)) + rng.normal(size=(runs, n))
    A = rng.normal(size=(runs, n, n))
    P = A @ np.swapaxes(A, -1, -2) + np.eye(n)
    eta = mean[:, None, :] + np.einsum("rij,rnj->rni", np.linalg.cholesky(P), rng.normal(size=(runs, N, n)))
    y = model.h(mean + rng.normal(size=(runs, n))) + 0.1 * rng.normal(size=(runs, model.dim_y))
    return eta, mean, P, y


@pytest.mark.parametrize("make_model", [BearingsOnly.zhang2016, lambda: random_linear_model(5, nx=4, ny=2)])
def test_edh_affine_map_is_the_step_by_step_flow(make_model):
    model = make_model()
    f = ParticleFlowParticleFilter(model, 50, flow="edh")
    eta, mean, P, y = _flow_inputs(model, 3, 50, 8)
    one, ld_one = f._flow(eta.copy(), mean.copy(), P, y)
    steps, ld_steps = f._flow_steps(eta.copy(), mean.copy(), P, y)
    scale = np.abs(steps).max()
    assert np.abs(one - steps).max() <= 1e-10 * max(scale, 1.0)
    assert np.abs(ld_one - ld_steps).max() <= 1e-12
    # the map's own determinant is the log-determinant reported
    M, c, ld = f.edh_map(mean, P, y)
    np.testing.assert_allclose(np.log(np.abs(np.linalg.det(M))), ld, rtol=0, atol=1e-10)
    # and the map moves a particle as the flow does: M eta + c
    np.testing.assert_allclose(np.einsum("rij,rnj->rni", M, eta) + c[:, None], steps, rtol=0,
                               atol=1e-10 * max(scale, 1.0))


def test_edh_map_changes_the_flow_only_in_the_last_bits_of_a_filter_run():
    """The whole filter, composed map against step-by-step flow (same draws): estimates within
    1e-9 of each other on the bearings-only benchmark."""
    model = BearingsOnly.zhang2016()
    runs, T = 3, 20
    y = model.simulate(T, runs, truth_streams(2, runs)).y
    f = ParticleFlowParticleFilter(model, 200, flow="edh")
    a = f.filter(y, filter_streams(3, "p", runs))
    f._flow = f._flow_steps                       # the step-by-step flow, as before the map
    b = f.filter(y, filter_streams(3, "p", runs))
    np.testing.assert_allclose(a.x, b.x, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(a.diagnostics["log_det"], b.diagnostics["log_det"], rtol=0, atol=1e-9)


# ------------------------------------------------------------------ closed forms over particles
from pfrepro.filters.small_linalg import (cholesky_components, cholesky_small, inv_components,  # noqa: E402
                                          mm_components)


@pytest.mark.parametrize("n", [1, 2, 3, 4, 6, 7])
def test_cholesky_small_is_lapacks_factor(n):
    rng = np.random.default_rng(n)
    B = rng.normal(size=(5, 7, n, n))
    A = B @ np.swapaxes(B, -1, -2) + 0.1 * np.eye(n)
    np.testing.assert_allclose(cholesky_small(A), np.linalg.cholesky(A), rtol=1e-12, atol=1e-13)
    bad = A.copy()
    bad[2, 3] = -np.eye(n)
    with pytest.raises(np.linalg.LinAlgError):
        cholesky_small(bad)


def test_component_products_and_inverses_are_numpys():
    rng = np.random.default_rng(0)
    A, B = rng.normal(size=(4, 2, 3, 5)), rng.normal(size=(2, 3, 3, 5))
    mv = lambda X: np.moveaxis(X, (0, 1), (-2, -1))            # noqa: E731  small axes last
    np.testing.assert_allclose(mv(mm_components(A, B)), mv(A) @ mv(B), rtol=1e-13, atol=1e-14)
    for m in (1, 2, 3):
        S = rng.normal(size=(m, m, 3, 5)) + 3 * np.eye(m)[:, :, None, None]
        np.testing.assert_allclose(mv(inv_components(S)), np.linalg.inv(mv(S)), rtol=1e-12, atol=1e-13)
    C = rng.normal(size=(3, 3, 4))
    P = mm_components(C, np.swapaxes(C, 0, 1)) + np.eye(3)[:, :, None]
    np.testing.assert_allclose(mv(cholesky_components(P)), np.linalg.cholesky(mv(P)), rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize("make_model", [BearingsOnly.zhang2016, lambda: random_linear_model(5, nx=4, ny=2),
                                        lambda: random_linear_model(6, nx=3, ny=3)])
def test_ledh_written_out_over_the_small_axes_is_the_stacked_flow(make_model):
    """LEDH's flow written out per term (and its determinant by the matrix determinant lemma)
    against the same flow with stacked matrices (edh_coefficients, the n x n determinant)."""
    model = make_model()
    f = ParticleFlowParticleFilter(model, 20, flow="ledh")
    eta, mean, P, y = _flow_inputs(model, 3, 20, 9)
    bar = eta + 0.1 * np.random.default_rng(1).normal(size=eta.shape)    # a linearisation point each
    a, ld_a = f._ledh_flow(eta.copy(), bar.copy(), P, y)
    b, ld_b = f._flow_steps(eta.copy(), bar.copy(), P, y)
    assert np.abs(a - b).max() <= 1e-10 * max(np.abs(b).max(), 1.0)
    assert np.abs(ld_a - ld_b).max() <= 1e-10
