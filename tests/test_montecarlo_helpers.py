"""pfrepro.montecarlo's helpers, by hand-computed cases (issue 21, mutation testing): the
stream keys, the run chunks, the concatenation of chunk results, map_runs with a thread pool,
the result's per-run metrics and divergence count, the input checks."""
from __future__ import annotations

import concurrent.futures
import functools
import zlib

import numpy as np
import pytest

from pfrepro import montecarlo as mc
from pfrepro.filters.base import FilterResult
from pfrepro.models import LinearGaussianModel
from pfrepro.models.base import Simulation


def test_stream_keys_are_the_documented_seed_sequences():
    """truth: SeedSequence([seed, 0]) (per run: spawn key i); filter `name`: [seed, 1, crc32(name)]."""
    def draw(entropy, key=None):
        ss = np.random.SeedSequence(entropy) if key is None else np.random.SeedSequence(entropy, spawn_key=(key,))
        return np.random.default_rng(ss).random(3)

    np.testing.assert_array_equal(mc.truth_rng(7).random(3), draw([7, 0]))
    np.testing.assert_array_equal(mc.filter_rng(7, "PF").random(3), draw([7, 1, zlib.crc32(b"PF")]))
    np.testing.assert_array_equal(mc.truth_streams(7, 2, start=3).random((2, 3)),
                                  np.stack([draw([7, 0], 3), draw([7, 0], 4)]))
    np.testing.assert_array_equal(mc.filter_streams(7, "PF", 2, start=1).random((2, 3)),
                                  np.stack([draw([7, 1, zlib.crc32(b"PF")], 1), draw([7, 1, zlib.crc32(b"PF")], 2)]))
    np.testing.assert_array_equal(mc.truth_streams(7, 1).random((1, 3)), draw([7, 0], 0)[None])
    np.testing.assert_array_equal(mc.filter_streams(7, "PF", 1).random((1, 3)),
                                  draw([7, 1, zlib.crc32(b"PF")], 0)[None])


class _Pool:
    """Stands in for an executor: only the worker count matters to run_chunks."""

    def __init__(self, n):
        self._max_workers = n


class _Client:
    def nthreads(self):
        return {"a": 2, "b": 1}


class _DaskLike:
    _client = _Client()


def test_run_chunks_by_hand():
    assert mc.run_chunks(10) == [(0, 10)]
    assert mc.run_chunks(10, chunks=3) == [(0, 4), (4, 4), (8, 2)]
    assert mc.run_chunks(3, chunks=5) == [(0, 1), (1, 1), (2, 1)]
    assert mc.run_chunks(10, _Pool(2)) == [(0, 3), (3, 3), (6, 3), (9, 1)]          # 2 per worker
    assert mc.run_chunks(12, _DaskLike()) == [(0, 2), (2, 2), (4, 2), (6, 2), (8, 2), (10, 2)]  # 3 threads
    assert mc._n_workers(_Pool(5)) == 5 and mc._n_workers(_DaskLike()) == 3
    assert mc._n_workers(object()) >= 1
    with pytest.raises(ValueError, match="chunks must be >= 1"):
        mc.run_chunks(4, chunks=0)
    with pytest.raises(ValueError, match="runs must be >= 1"):
        mc.run_chunks(0)


def test_concat_of_chunk_results_by_hand():
    a = FilterResult(np.zeros((2, 3, 1)), np.ones((2, 3, 1, 1)),
                     {"ess": np.array([[1.0], [2.0]]), "n_collapsed": 1, "N": 50})
    b = FilterResult(np.ones((1, 3, 1)), 2 * np.ones((1, 3, 1, 1)),
                     {"ess": np.array([[3.0]]), "n_collapsed": 2, "N": 50})
    c = mc._concat([a, b])
    np.testing.assert_array_equal(c.x[:, 0, 0], [0.0, 0.0, 1.0])
    np.testing.assert_array_equal(c.P[:, 0, 0, 0], [1.0, 1.0, 2.0])
    np.testing.assert_array_equal(c.diagnostics["ess"][:, 0], [1.0, 2.0, 3.0])
    assert c.diagnostics["n_collapsed"] == 3 and type(c.diagnostics["n_collapsed"]) is int
    assert c.diagnostics["N"] == 50
    assert mc._concat([FilterResult(np.zeros((1, 2, 1)), None, {}),
                       FilterResult(np.zeros((2, 2, 1)), None, {})]).P is None
    assert mc._concat([a]) is a
    s = mc._concat([Simulation(np.zeros((1, 4, 1)), np.zeros((1, 3, 1))),
                    Simulation(np.ones((2, 4, 1)), np.ones((2, 3, 1)))])
    assert s.x.shape == (3, 4, 1) and s.y.shape == (3, 3, 1) and s.y[1, 0, 0] == 1.0
    t = mc._concat([(np.array([1]), [np.array([2])]), (np.array([3]), [np.array([4])])])
    assert type(t) is tuple and t[0].tolist() == [1, 3] and type(t[1]) is list and t[1][0].tolist() == [2, 4]
    with pytest.raises(ValueError, match="chunks disagree on the scalar 'N'"):
        mc._concat_dict([{"N": 50}, {"N": 60}])
    with pytest.raises(TypeError, match="cannot concatenate chunk results of type str"):
        mc._concat(["a", "b"])


def _chunk(start, size):
    return np.arange(start, start + size) ** 2, {"n_diverged": size, "first": np.array([start])}


def test_map_runs_serial_and_threads_give_the_same_run_order():
    serial = mc.map_runs(_chunk, 7)
    assert serial[0].tolist() == [i * i for i in range(7)] and serial[1]["n_diverged"] == 7
    with concurrent.futures.ThreadPoolExecutor(2) as ex:
        par = mc.map_runs(_chunk, 7, ex, chunks=3)
    assert par[0].tolist() == serial[0].tolist() and par[1]["n_diverged"] == 7
    assert par[1]["first"].tolist() == [0, 3, 6]


def test_result_metrics_divergence_count_and_names():
    x = np.zeros((3, 3, 2))                                # x_0 .. x_2: x_true = x[:, 1:]
    x[:, 1:, 0] = 1.0
    est = np.zeros((3, 2, 2))
    est[1, 0, 0] = np.nan
    est[2] = 1.0                                           # run 2: error (0, -1) at both steps
    r = mc.MonteCarloResult(sim=Simulation(x, np.zeros((3, 2, 1))),
                            results={"A": FilterResult(est, None, {}), "B": FilterResult(np.zeros((3, 2, 2)), None, {})},
                            batch_seconds={})
    np.testing.assert_array_equal(r.x_true, x[:, 1:])
    assert r.n_diverged() == {"A": 1, "B": 0}
    np.testing.assert_allclose(r.mse("B"), [0.5, 0.5, 0.5])     # (1 + 0) / 2 per step
    np.testing.assert_allclose(r.rmse("B"), [1.0, 1.0, 1.0])
    np.testing.assert_allclose(r.rmse("A")[[0, 2]], [1.0, 1.0])
    with pytest.raises(KeyError, match=r"no filter named 'C' in this result; filters: \['A', 'B'\]"):
        r.mse("C")


def test_checks_name_the_argument():
    assert mc.check_seed(np.int64(3)) == 3 and type(mc.check_seed(np.int64(3))) is int
    for bad in (True, 1.5, None, "1"):
        with pytest.raises(TypeError, match=r"^seed must be an integer >= 0, got "):
            mc.check_seed(bad)
    with pytest.raises(ValueError, match=r"^base must be >= 0, got -1$"):
        mc.check_seed(-1, "base")
    m = LinearGaussianModel([[0.9]], [[1.0]], [[1.0]], [[1.0]], [0.0])
    with pytest.raises(TypeError, match="model must be a state-space model with a simulate method"):
        mc._check_mc_inputs(None, {}, None)
    mc._check_mc_inputs(None, {}, None, sim=object())       # a given sim needs no model
    with pytest.raises(TypeError, match=r"filters must be a dict \{name: filter\}, got list"):
        mc._check_mc_inputs(m, [], None)
    with pytest.raises(TypeError, match="every name must be a string, got 1"):
        mc._check_mc_inputs(m, {1: object()}, None)
    with pytest.raises(TypeError, match=r"filters\['f'\] must be a filter"):
        mc._check_mc_inputs(m, {"f": object()}, None)
    with pytest.raises(TypeError, match="executor must be a concurrent.futures.Executor"):
        mc._check_mc_inputs(m, {}, object())
    ex = concurrent.futures.ThreadPoolExecutor(1)
    ex.shutdown()
    with pytest.raises(ValueError, match="executor has been shut down"):
        mc._check_mc_inputs(m, {}, ex)


def test_run_monte_carlo_checks_sim_shape_and_reuses_it():
    from pfrepro.filters import KalmanFilter

    m = LinearGaussianModel([[0.9]], [[1.0]], [[1.0]], [[1.0]], [0.0])
    sim = m.simulate(4, 2, mc.truth_streams(5, 2))
    with pytest.raises(ValueError, match=r"sim has shape \(2, 4\), expected \(runs, T\) = \(3, 4\)"):
        mc.run_monte_carlo(m, {"KF": KalmanFilter(m)}, 4, 3, 5, sim=sim)
    r = mc.run_monte_carlo(m, {"KF": KalmanFilter(m)}, 4, 2, 5, sim=sim)
    assert r.sim is sim and r.seed == 5 and r.seconds_per_run == {} and r.timing_repeats == {}
    fresh = mc.run_monte_carlo(m, {"KF": KalmanFilter(m)}, 4, 2, 5)
    np.testing.assert_array_equal(fresh.sim.y, sim.y)                     # the same truth streams
    np.testing.assert_array_equal(fresh.results["KF"].x, KalmanFilter(m).filter(sim.y).x)
    with concurrent.futures.ThreadPoolExecutor(2) as ex:
        par = mc.run_monte_carlo(m, {"KF": KalmanFilter(m)}, 4, 2, 5, executor=ex, chunks=2)
    np.testing.assert_array_equal(par.sim.y, sim.y)
    np.testing.assert_array_equal(par.results["KF"].x, fresh.results["KF"].x)
    t = mc.run_monte_carlo(m, {"KF": KalmanFilter(m)}, 4, 2, 5, sim=sim, time_per_run=True, timing_repeats=2)
    assert len(t.timing_repeats["KF"]) == 2 and t.seconds_per_run["KF"] == float(np.median(t.timing_repeats["KF"]))


class _Recorder:
    """A 'filter' that records the seed of every rng it is given."""

    def __init__(self):
        self.seeds = []

    def filter(self, y, rng=None):
        self.seeds.append(rng.bit_generator.seed_seq.entropy)


def test_timing_repeats_seeds_warmup_and_median():
    """One untimed warm-up call per filter (seed rng_seed), then repeats interleaved across the
    filters with seeds rng_seed + r; time_filters is the median of time_filter_repeats."""
    a, b = _Recorder(), _Recorder()
    reps = mc.time_filter_repeats({"a": a, "b": b}, np.zeros((1, 2, 1)), rng_seed=10, repeats=3)
    assert a.seeds == [10, 10, 11, 12] and b.seeds == [10, 10, 11, 12]
    assert list(reps) == ["a", "b"] and all(len(v) == 3 and min(v) >= 0 for v in reps.values())
    c = _Recorder()
    mc.time_filter_repeats({"c": c}, np.zeros((1, 2, 1)), rng_seed=5, repeats=2, warmup=False)
    assert c.seeds == [5, 6]
    d = _Recorder()
    t = mc.time_single_run(d, np.zeros((1, 2, 1)), rng_seed=3, repeats=2)
    assert d.seeds == [3, 3, 4] and isinstance(t, float) and 0 <= t < 5
    e = _Recorder()
    med = mc.time_filters({"e": e}, np.zeros((1, 2, 1)), rng_seed=0, repeats=3)
    assert list(med) == ["e"] and e.seeds == [0, 0, 1, 2] and 0 <= med["e"] < 5


class _Unpicklable:
    def __init__(self):
        self.ok = 1
        self.fn = lambda x: x

    def simulate(self, *a):
        pass


def test_pickling_checks_name_the_object_and_attribute():
    with pytest.raises(TypeError, match=r"^model cannot be sent to a process pool: it cannot be pickled "
                                        r"\(attribute fn\): "):
        mc._check_picklable({"model": _Unpicklable()})
    ex = concurrent.futures.ProcessPoolExecutor(1)             # no worker starts before a submit
    try:
        with pytest.raises(TypeError, match=r"^model cannot be sent to a process pool"):
            mc._check_mc_inputs(_Unpicklable(), {}, ex)
    finally:
        ex.shutdown()
    with pytest.raises(ValueError, match=r"^max_workers must be >= 1, got 0$"):
        mc.process_pool(0)


def test_run_monte_carlo_argument_names_batch_seconds_and_progress(capsys):
    from pfrepro.filters import KalmanFilter

    m = LinearGaussianModel([[0.9]], [[1.0]], [[1.0]], [[1.0]], [0.0])
    with pytest.raises(ValueError, match=r"^T must be >= 1, got 0$"):
        mc.run_monte_carlo(m, {}, 0, 2, 0)
    with pytest.raises(ValueError, match=r"^runs must be >= 1, got 0$"):
        mc.run_monte_carlo(m, {}, 3, 0, 0)
    r = mc.run_monte_carlo(m, {"KF": KalmanFilter(m)}, 3, 2, 0, progress=True)
    assert 0 <= r.batch_seconds["KF"] < 30          # a wall time, not a clock reading
    assert "Monte Carlo" in capsys.readouterr().err


def test_progress_bar_counts_tasks_names_the_filter_and_leaves_no_line(capsys):
    """The bar's total is the number of tasks: serial, 1 simulation + 2 filters = 3; with an
    executor and 2 chunks, 2 simulation chunks + 2 filters x 2 chunks = 6. Its postfix names the
    filter being run, and it is cleared when done (leave=False: nothing is left in a notebook's
    or terminal's output, the last character written is a carriage return)."""
    from pfrepro.filters import KalmanFilter

    m = LinearGaussianModel([[0.9]], [[1.0]], [[1.0]], [[1.0]], [0.0])
    filters = {"KF": KalmanFilter(m), "K2": KalmanFilter(m)}
    mc.run_monte_carlo(m, filters, 3, 2, 0, progress=True)
    err = capsys.readouterr().err
    assert "Monte Carlo:   0%" in err and "| 0/3 [" in err
    assert "chunk/s, KF]" in err and "chunk/s, K2]" in err
    assert err.endswith("\r") and "\n" not in err
    with concurrent.futures.ThreadPoolExecutor(2) as ex:
        par = mc.run_monte_carlo(m, filters, 3, 4, 0, progress=True, executor=ex, chunks=2)
    err = capsys.readouterr().err
    assert "| 0/6 [" in err and "chunk/s, KF]" in err and "chunk/s, K2]" in err
    assert err.endswith("\r") and "\n" not in err
    # batch_seconds with an executor: the sum of the chunks' wall times, a float per filter
    assert all(type(v) is float and 0 <= v < 30 for v in par.batch_seconds.values())
    assert list(par.batch_seconds) == ["KF", "K2"]
    mc.run_monte_carlo(m, filters, 3, 2, 0, sim=Simulation(par.sim.x[:2], par.sim.y[:2]), progress=True)
    assert "| 0/2 [" in capsys.readouterr().err                  # a given sim: the 2 filters only


class _Slotted:
    """No __dict__: its attributes live in slots (a str __slots__ in the subclass below)."""

    __slots__ = ("ok", "fn", "__weakref__")

    def __init__(self):
        self.ok = 1
        self.fn = lambda x: x


class _SlottedChild(_Slotted):
    __slots__ = "gen"

    def __init__(self):
        super().__init__()
        self.gen = (i for i in range(3))


class _SlottedWithDict(_Slotted):
    __slots__ = ("__dict__",)                                # slots and a __dict__

    def __init__(self):
        super().__init__()
        self.lam = lambda: 0


def test_pickling_check_of_objects_without_a_dict():
    """An unpicklable object without __dict__ is still reported as a TypeError naming it: a lock
    (no attributes to name), a slotted object (the bad slots are named, a held weak reference is
    not an attribute pickle would send)."""
    import threading
    import weakref

    with pytest.raises(TypeError, match=r"^filters\['f'\] cannot be sent to a process pool: it cannot be "
                                        r"pickled: TypeError: cannot pickle '_thread.lock' object$"):
        mc._check_picklable({"filters['f']": threading.Lock()})
    obj = _SlottedChild()
    ref = weakref.ref(obj)                                   # obj.__weakref__ is now set (unpicklable)
    with pytest.raises(TypeError, match=r"^model cannot be sent to a process pool: it cannot be pickled "
                                        r"\(attribute gen, fn\): "):
        mc._check_picklable({"model": obj})
    assert ref() is obj
    with pytest.raises(TypeError, match=r"\(attribute lam, fn\): "):   # the __dict__ slot is not an attribute
        mc._check_picklable({"model": _SlottedWithDict()})
    assert mc._attributes(_Slotted())["ok"] == 1 and "__weakref__" not in mc._attributes(obj)


def _nested(start, size):
    """A chunk result with dict-valued and FilterResult-valued entries, a setting that is a tuple
    of scalars, and a count nested one dict down."""
    runs = np.arange(start, start + size, dtype=float)
    res = FilterResult(runs[:, None, None] * np.ones((1, 2, 1)), None,
                       {"per_mode": {"ess": runs[:, None] + 0.5, "n_diverged": size % 2}, "levels": (0.1, 0.9)})
    return {"res": res, "sub": {"x": runs ** 2, "pair": (runs, [runs + 1])}, "levels": (0.025, 0.975), "name": "a"}


def test_chunked_dict_valued_results_equal_the_serial_call():
    """map_runs cut into chunks (serially or on threads) returns exactly the serial result for
    results whose diagnostics hold dicts and FilterResults (concatenated per run, counts added),
    and settings that are tuples of scalars (shared by every chunk, kept once)."""
    serial = mc.map_runs(_nested, 7)
    assert serial["res"].diagnostics["per_mode"]["n_diverged"] == 1          # 7 % 2, one chunk
    for chunks, ex in ((3, None), (7, None), (3, concurrent.futures.ThreadPoolExecutor(2))):
        try:
            got = mc.map_runs(_nested, 7, ex, chunks=chunks)
        finally:
            if ex is not None:
                ex.shutdown()
        np.testing.assert_array_equal(got["res"].x, serial["res"].x)
        d = got["res"].diagnostics
        np.testing.assert_array_equal(d["per_mode"]["ess"], serial["res"].diagnostics["per_mode"]["ess"])
        assert d["levels"] == (0.1, 0.9) and got["levels"] == (0.025, 0.975) and got["name"] == "a"
        np.testing.assert_array_equal(got["sub"]["x"], np.arange(7.0) ** 2)
        np.testing.assert_array_equal(got["sub"]["pair"][0], np.arange(7.0))
        np.testing.assert_array_equal(got["sub"]["pair"][1][0], np.arange(7.0) + 1)
        # chunks of sizes (3, 3, 1) -> 1 + 1 + 1; (1,) * 7 -> 7: a count is summed over chunks
        assert d["per_mode"]["n_diverged"] == {3: 3, 7: 7}[chunks]
    with pytest.raises(ValueError, match=r"chunks disagree on the scalar 'levels'"):
        mc._concat_dict([{"levels": (0.1, 0.9)}, {"levels": (0.1, 0.8)}])
    assert not mc._has_runs_axis(np.float64(1.0)) and not mc._has_runs_axis(np.array(2.0))
    assert mc._has_runs_axis([1.0, np.zeros(2)]) and not mc._has_runs_axis([1.0, "a"])


class _Late:
    """A model-like object; its class is given a module the pool's workers never had."""

    def simulate(self, T, runs, streams):  # pragma: no cover - never reached in the worker
        raise AssertionError


def test_a_class_defined_after_the_pool_started_gives_a_clear_error():
    # the notebook pitfall: workers forked before a class existed cannot unpickle its objects,
    # die, and the pool reports "terminated abruptly"; the runner says why and what to do
    import sys
    import types
    from concurrent.futures.process import BrokenProcessPool

    with mc.process_pool(1) as pool:
        assert pool.submit(int, "1").result() == 1              # the worker exists now
        late = types.ModuleType("pfrepro_test_defined_late")
        sys.modules[late.__name__] = late
        try:
            cls = type("LateModel", (_Late,), {"__module__": late.__name__})
            late.LateModel = cls
            with pytest.raises(BrokenProcessPool, match="defined in the notebook"):
                mc.map_runs(functools.partial(_call_simulate, cls()), 4, pool)
        finally:
            del sys.modules[late.__name__]


def _call_simulate(model, start, size):  # pragma: no cover - runs in the worker
    return model.simulate(1, size, None)
