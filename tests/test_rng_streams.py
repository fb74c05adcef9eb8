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


def per_run(entropy, runs, start=0):
    """The definition: run i's stream is default_rng(SeedSequence(entropy, spawn_key=(i,)))."""
    return [np.random.default_rng(np.random.SeedSequence(entropy, spawn_key=(i,))) for i in range(start, start + runs)]


def test_every_draw_is_each_runs_own_generator_draw():
    """Every RunStreams method against the definition: slice i is what run i's own Generator
    (entropy, spawn key i) returns for run i's parameters and size[1:] -- no parameter of
    another run, no draw of another stream, the dtype and the keyword arguments passed through."""
    ent = [3, 1, 42]
    R = 3
    loc = np.array([[-1.0], [0.0], [5.0]])
    scale = np.array([0.5, 1.0, 2.0])[:, None, None]
    cases = [
        ("standard_normal", lambda s: s.standard_normal((R, 4, 2)), lambda g, i: g.standard_normal((4, 2))),
        ("standard_normal f32", lambda s: s.standard_normal((R, 5), dtype=np.float32),
         lambda g, i: g.standard_normal(5, dtype=np.float32)),
        ("random", lambda s: s.random((R, 3, 2)), lambda g, i: g.random((3, 2))),
        ("random f32", lambda s: s.random((R, 6), dtype=np.float32), lambda g, i: g.random(6, dtype=np.float32)),
        ("normal", lambda s: s.normal(loc, 2.0, (R, 4)), lambda g, i: g.normal(loc[i], 2.0, 4)),
        ("normal scale", lambda s: s.normal(1.0, scale, (R, 2, 3)), lambda g, i: g.normal(1.0, scale[i], (2, 3))),
        ("normal per column", lambda s: s.normal(np.arange(4.0), 1.0, (R, 4)), lambda g, i: g.normal(np.arange(4.0), 1.0, 4)),
        ("normal default", lambda s: s.normal(size=(R, 4)), lambda g, i: g.normal(0.0, 1.0, 4)),
        ("uniform", lambda s: s.uniform(loc, loc + 2.0, (R, 4)), lambda g, i: g.uniform(loc[i], loc[i] + 2.0, 4)),
        ("uniform default", lambda s: s.uniform(size=(R, 4)), lambda g, i: g.uniform(0.0, 1.0, 4)),
        ("beta", lambda s: s.beta(2.0, scale[:, 0], (R, 4)), lambda g, i: g.beta(2.0, scale[i, 0], 4)),
        ("gamma", lambda s: s.gamma(scale[:, 0], 3.0, (R, 4)), lambda g, i: g.gamma(scale[i, 0], 3.0, 4)),
        ("gamma default", lambda s: s.gamma(2.0, size=(R, 4)), lambda g, i: g.gamma(2.0, 1.0, 4)),
        ("exponential", lambda s: s.exponential(scale[:, 0], (R, 4)), lambda g, i: g.exponential(scale[i, 0], 4)),
        ("exponential default", lambda s: s.exponential(size=(R, 4)), lambda g, i: g.exponential(1.0, 4)),
        ("poisson", lambda s: s.poisson(3.0 * scale[:, 0], (R, 4)), lambda g, i: g.poisson(3.0 * scale[i, 0], 4)),
        ("poisson default", lambda s: s.poisson(size=(R, 4)), lambda g, i: g.poisson(1.0, 4)),
        ("integers", lambda s: s.integers(2, 9, (R, 5)), lambda g, i: g.integers(2, 9, 5)),
        ("integers one bound", lambda s: s.integers(7, size=(R, 5)), lambda g, i: g.integers(0, 7, 5)),
        ("integers int8", lambda s: s.integers(0, 100, (R, 5), dtype=np.int8),
         lambda g, i: g.integers(0, 100, 5, dtype=np.int8)),
        ("choice", lambda s: s.choice(4, (R, 6), p=[0.1, 0.2, 0.3, 0.4]),
         lambda g, i: g.choice(4, 6, p=[0.1, 0.2, 0.3, 0.4])),
        ("choice no replace", lambda s: s.choice(np.array([1.5, 2.5, 3.5, 4.5]), (R, 3), replace=False),
         lambda g, i: g.choice(np.array([1.5, 2.5, 3.5, 4.5]), 3, replace=False)),
    ]
    for name, draw, ref in cases:
        got = draw(RunStreams.from_entropy(ent, R))
        want = np.stack([np.asarray(ref(g, i)) for i, g in enumerate(per_run(ent, R))])
        assert got.shape == want.shape and got.dtype == want.dtype, name
        np.testing.assert_array_equal(got, want, err_msg=name)
    x = np.arange(R * 2 * 5).reshape(R, 2, 5)
    for axis in (1, 2):
        got = RunStreams.from_entropy(ent, R).permuted(x, axis=axis)
        want = np.stack([g.permuted(x[i], axis=axis - 1) for i, g in enumerate(per_run(ent, R))])
        np.testing.assert_array_equal(got, want, err_msg=f"permuted axis {axis}")
    for bad in (None, 0):
        with pytest.raises(ValueError, match="runs axis first and axis >= 1"):
            RunStreams.from_entropy(ent, R).permuted(x, axis=bad)
    with pytest.raises(ValueError, match=r"^RunStreams\.permuted needs"):
        RunStreams.from_entropy(ent, R).permuted(x, axis=0)
    with pytest.raises(ValueError, match="runs axis first"):
        RunStreams.from_entropy(ent, R).permuted(x[:2], axis=1)


def test_from_entropy_start_and_container_protocol():
    """Runs start .. start + runs - 1 of the experiment: from_entropy(e, 2, start=3) holds runs
    3 and 4 of from_entropy(e, 5); an int entropy equals the one-element sequence; slicing
    keeps RunStreams, indexing gives the Generator; the repr names the run count."""
    a, b = RunStreams.from_entropy(11, 5), RunStreams.from_entropy(11, 2, start=3)
    np.testing.assert_array_equal(a.random((5, 3))[3:], b.random((2, 3)))
    np.testing.assert_array_equal(RunStreams.from_entropy(11, 2).random((2, 4)),
                                  RunStreams.from_entropy([11], 2).random((2, 4)))
    np.testing.assert_array_equal(RunStreams.from_entropy(11, 2).random((2, 4)),
                                  np.stack([g.random(4) for g in per_run(11, 2)]))
    assert len(a) == 5 and repr(a) == "RunStreams(runs=5)"
    s = a[1:4]
    assert isinstance(s, RunStreams) and len(s) == 3 and s[0] is a[1] and list(s) == [a[1], a[2], a[3]]
    assert isinstance(a[2], np.random.Generator) and list(iter(a)) == list(a._gens)
    assert RunStreams.from_entropy(11, 2, start=np.int64(3)).random((2, 1)).shape == (2, 1)
    for bad_start in (True, 1.0, "1"):
        with pytest.raises(TypeError, match="start must be an integer >= 0"):
            RunStreams.from_entropy(11, 2, start=bad_start)
    with pytest.raises(ValueError, match=r"^runs must be >= 1, got 0$"):
        RunStreams.from_entropy(11, 0)
    with pytest.raises(ValueError, match="need runs >= 1 and start >= 0"):
        RunStreams.from_entropy(11, 2, start=-1)
    for bad in (True, [1, -2], 1.5, [np.True_]):
        with pytest.raises(ValueError, match="entropy must be an int >= 0"):
            RunStreams.from_entropy(bad, 2)
    with pytest.raises(ValueError, match=r"^RunStreams needs at least one generator \(one per run\)$"):
        RunStreams([])
    with pytest.raises(TypeError, match="holds numpy.random.Generator objects"):
        RunStreams([np.random.default_rng(0), np.random.RandomState(0)])


def test_size_checks_name_the_method_and_accept_numpy_ints():
    """size must be (runs, ...) of integers >= 0: a numpy-int or list size is read as the
    tuple, a zero-length trailing axis is allowed; None, a bool, a nested size or a wrong
    runs count raise ValueError naming the method."""
    rs = RunStreams.from_entropy(5, 3)
    ref = RunStreams.from_entropy(5, 3)
    np.testing.assert_array_equal(rs.standard_normal(np.array([3, 2])), ref.standard_normal((3, 2)))
    np.testing.assert_array_equal(rs.random([np.int64(3), 2]), ref.random((3, 2)))
    assert rs.random((3, 0)).shape == (3, 0) and rs.random([3, 0]).shape == (3, 0)
    with pytest.raises(ValueError, match=r"RunStreams\.random needs size=\(runs, \.\.\.\)"):
        rs.random()
    with pytest.raises(ValueError, match=r"RunStreams\.normal: size must be a tuple of integers >= 0"):
        rs.normal(size=(3, True))
    with pytest.raises(ValueError, match=r"RunStreams\.uniform: size must be a tuple"):
        rs.uniform(size=[[3, 2]])
    with pytest.raises(ValueError, match=r"^RunStreams\.integers: size \(2, 4\) must start with the number of runs \(3\); every draw of a batched filter has the runs axis first$"):
        rs.integers(4, size=(2, 4))
    with pytest.raises(ValueError, match=r"RunStreams\.choice: size \(\) must start"):
        rs.choice(3, size=())
    with pytest.raises(ValueError, match=r"^RunStreams\.standard_normal: size \(2, 4\) must start"):
        rs.standard_normal((2, 4))
    a = np.array([10, 20, 30])                 # an array a with p: one probability per element
    np.testing.assert_array_equal(rs.choice(a, size=(3, 2), p=[0.0, 0.0, 1.0]), np.full((3, 2), 30))


def test_check_rng_and_run_stream():
    """check_rng returns what it accepts (a Generator or RunStreams), names the argument when
    it refuses; is_rng agrees; run_stream gives run i's generator or the shared one."""
    from pfrepro.rng import is_rng, run_stream

    g, rs = np.random.default_rng(0), RunStreams.from_entropy(0, 3)
    assert check_rng(g) is g and check_rng(rs) is rs
    assert is_rng(g) and is_rng(rs) and not is_rng(0) and not is_rng(None)
    with pytest.raises(TypeError, match=r"^seed must be a numpy\.random\.Generator .* got int: 7$"):
        check_rng(7, "seed")
    assert run_stream(rs, 2) is rs[2] and run_stream(g, 2) is g
