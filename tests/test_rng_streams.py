"""Per-run random streams (pfrepro.rng): run i does not depend on the batch around it."""
import numpy as np
import pytest

from pfrepro.filters import BootstrapParticleFilter, KalmanFilter
from pfrepro.models import UNGM
from pfrepro.rng import RunStreams, check_rng, take_runs


def streams(runs, start=0):
    return RunStreams.from_entropy([7, 1, 99], runs, start)


def test_draws_have_runs_axis_first_and_are_batch_invariant():
    big, small = streams(8), streams(3, start=5)
    a = big.standard_normal((8, 4, 2))
    b = small.standard_normal((3, 4, 2))
    np.testing.assert_array_equal(a[5:], b)
    with pytest.raises(ValueError, match="runs axis first"):
        big.standard_normal((4, 8))
    u = streams(8).uniform(np.arange(8.0)[:, None], np.arange(8.0)[:, None] + 1, (8, 5))
    assert np.all((u >= np.arange(8.0)[:, None]) & (u < np.arange(8.0)[:, None] + 1))


def test_take_runs_narrows_streams_only():
    rs = streams(5)
    sub = take_runs(rs, np.array([False, True, False, True, False]))
    assert len(sub) == 2 and sub[0] is rs[1] and sub[1] is rs[3]
    g = np.random.default_rng(0)
    assert take_runs(g, [1, 2]) is g


def test_check_rng_refuses_ints_and_randomstate():
    for bad in (0, None, np.random.RandomState(0)):
        with pytest.raises(TypeError, match="numpy.random.Generator"):
            check_rng(bad)


@pytest.mark.parametrize("ess_threshold", [None, 0.5])
def test_pf_run_is_identical_in_batches_of_1_8_and_20(ess_threshold):
    model = UNGM.zhang2016()
    sim = model.simulate(30, runs=20, rng=RunStreams.from_entropy([1, 0], 20))
    sim1 = model.simulate(30, runs=1, rng=RunStreams.from_entropy([1, 0], 1))
    np.testing.assert_array_equal(sim.x[:1], sim1.x)
    pf = BootstrapParticleFilter(model, 200, ess_threshold=ess_threshold)
    full = pf.filter(sim.y, RunStreams.from_entropy([1, 1], 20)).x
    for runs in (1, 8):
        part = pf.filter(sim.y[:runs], RunStreams.from_entropy([1, 1], runs)).x
        np.testing.assert_array_equal(part, full[:runs])
    tail = pf.filter(sim.y[13:], RunStreams.from_entropy([1, 1], 7, start=13)).x
    np.testing.assert_array_equal(tail, full[13:])


def test_kalman_log_likelihood_matches_filterpy():
    from filterpy.kalman import KalmanFilter as FPKF
    from pfrepro.models import LinearGaussianModel

    F = np.array([[1.0, 1.0], [0.0, 1.0]])
    H = np.array([[1.0, 0.0]])
    G = np.array([[0.5], [1.0]])
    model = LinearGaussianModel(F, H, G @ G.T * 0.1, np.array([[2.0]]), x0=[0.0, 1.0], m0=[0.0, 1.0],
                                P0=np.eye(2))
    sim = model.simulate(25, runs=2, rng=np.random.default_rng(3))
    res = KalmanFilter(model).filter(sim.y)
    for r in range(2):
        kf = FPKF(dim_x=2, dim_z=1)
        kf.x, kf.P, kf.F, kf.H, kf.Q, kf.R = np.array([0.0, 1.0]), np.eye(2), F, H, model.Q, model.R
        ll = []
        for z in sim.y[r]:
            kf.predict()
            kf.update(z)
            ll.append(kf.log_likelihood)
        np.testing.assert_allclose(res.diagnostics["log_likelihood"][r], ll, rtol=1e-10)
