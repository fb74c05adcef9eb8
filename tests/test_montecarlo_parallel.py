"""Per-run streams for every stochastic filter, and run_monte_carlo / map_runs over executors.

Run i's numbers depend on the experiment seed, the filter's name and i only: they are
bit-identical in batches of 1, 8 and 100 runs, when the experiment grows from 10 to 20
runs, and serially, in a ProcessPoolExecutor and on a real dask LocalCluster.
"""
import concurrent.futures
import sys
from concurrent.futures import ProcessPoolExecutor
from functools import partial

import numpy as np
import pytest

from pfrepro.filters import (BootstrapParticleFilter, ExtendedKalmanFilter, GaussianParticleFlowFilter,
                             GridFilter, UnscentedKalmanFilter)
from pfrepro.filters.cmspf import CMSParticleFilter, OracleCMSParticleFilter
from pfrepro.filters.espf import EvolutionSamplingParticleFilter
from pfrepro.models import CWPA, UNGM, BearingsOnly, StateSpaceModel
from pfrepro.montecarlo import (filter_streams, map_runs, process_pool, progress_enabled, run_chunks,
                                run_monte_carlo, truth_streams)

SEED = 2024
UNG = UNGM.zhang2016()
NING = UNGM.ning2011()


def stochastic_filters():
    """Every stochastic filter of the package, small N, on a model it is used with."""
    return {
        "PF systematic": (UNG, BootstrapParticleFilter(UNG, 40)),
        "PF residual ESS": (UNG, BootstrapParticleFilter(UNG, 40, resampling="residual", ess_threshold=0.5)),
        "PF multinomial 2-D": (CWPA(), BootstrapParticleFilter(CWPA(), 30, resampling="multinomial",
                                                               ess_threshold=0.7)),
        "CMS-PF logistic": (NING, CMSParticleFilter(NING, 40)),
        "CMS-PF randn": (NING, CMSParticleFilter(NING, 40, carrier="randn", n_th=1.0)),
        "ESPF": (NING, EvolutionSamplingParticleFilter(NING, 41)),
        "GPFF eq43": (UNG, GaussianParticleFlowFilter(UNG, 30, n_steps=5, field="eq43",
                                                                on_divergence="drop")),
        "GPFF BOT": (BearingsOnly.zhang2016(), GaussianParticleFlowFilter(BearingsOnly.zhang2016(), 30, n_steps=5)),
        "GPFF drop": (UNG, GaussianParticleFlowFilter(UNG, 30, n_steps=5, field="eq41", on_divergence="drop")),
    }


@pytest.mark.parametrize("name", list(stochastic_filters()))
def test_run_i_identical_in_batches_of_1_8_and_100(name):
    model, filt = stochastic_filters()[name]
    T = 8
    sim = model.simulate(T, 100, truth_streams(SEED, 100))
    np.testing.assert_array_equal(model.simulate(T, 8, truth_streams(SEED, 8)).y, sim.y[:8])
    full = filt.filter(sim.y, filter_streams(SEED, name, 100))
    for runs in (1, 8):
        part = filt.filter(sim.y[:runs], filter_streams(SEED, name, runs))
        np.testing.assert_array_equal(part.x, full.x[:runs])
    tail = filt.filter(sim.y[57:], filter_streams(SEED, name, 43, start=57))
    np.testing.assert_array_equal(tail.x, full.x[57:])
    one = filt.filter(sim.y[90:91], filter_streams(SEED, name, 1, start=90))
    np.testing.assert_array_equal(one.x, full.x[90:91])


@pytest.mark.parametrize("make", [
    lambda: (UNG, GridFilter(UNG, bounds=(-40, 40), n_grid=2001)),
    lambda: (UNG, ExtendedKalmanFilter(UNG)),
    lambda: (UNG, UnscentedKalmanFilter(UNG)),
], ids=["Grid", "EKF", "UKF"])
def test_deterministic_filters_identical_in_batches(make):
    """Issue 21: the grid filter's posterior mean was a BLAS matrix-vector product whose
    summation order depends on the number of rows (1e-14 differences between batch sizes)."""
    model, filt = make()
    sim = model.simulate(12, 37, truth_streams(SEED, 37))
    full = filt.filter(sim.y)
    for sl in (slice(0, 1), slice(0, 3), slice(5, 13), slice(36, 37)):
        part = filt.filter(sim.y[sl])
        np.testing.assert_array_equal(part.x, full.x[sl])
        np.testing.assert_array_equal(part.P, full.P[sl])


def test_oracle_cms_is_batch_invariant():
    filt = OracleCMSParticleFilter(NING, 40)
    sim = NING.simulate(6, 8, truth_streams(SEED, 8))
    full = filt.filter(sim.y, filter_streams(SEED, "o", 8), x_true=sim.x)
    part = filt.filter(sim.y[3:5], filter_streams(SEED, "o", 2, start=3), x_true=sim.x[3:5])
    np.testing.assert_array_equal(part.x, full.x[3:5])


def _mc(executor=None, runs=12, chunks=None):
    filters = {k: v[1] for k, v in stochastic_filters().items() if v[0] is NING or k.startswith("CMS")}
    return run_monte_carlo(NING, filters, 10, runs, SEED, executor=executor, chunks=chunks, progress=False)


def _same(a, b, runs=None):
    sl = slice(None) if runs is None else slice(0, runs)
    np.testing.assert_array_equal(a.sim.x[sl], b.sim.x[sl])
    np.testing.assert_array_equal(a.sim.y[sl], b.sim.y[sl])
    assert list(a.results) == list(b.results)
    for name in a.results:
        np.testing.assert_array_equal(a.results[name].x[sl], b.results[name].x[sl])
        for key, v in a.results[name].diagnostics.items():
            if runs is None:
                np.testing.assert_array_equal(v, b.results[name].diagnostics[key])


def test_growing_runs_keeps_the_first_runs():
    _same(_mc(runs=10), _mc(runs=20), runs=10)


def _chunk_pf(start, size, *, T=10):
    sim = UNG.simulate(T, size, truth_streams(SEED, size, start))
    res = BootstrapParticleFilter(UNG, 50).filter(sim.y, filter_streams(SEED, "PF", size, start))
    return res.x[..., 0], {"y": sim.y, "ll": res.diagnostics["log_evidence"]}


def test_serial_process_pool_and_dask_cluster_are_bit_identical():
    serial = _mc()
    serial_chunked = _mc(chunks=5)
    _same(serial, serial_chunked)
    ref = map_runs(_chunk_pf, 12)
    with ProcessPoolExecutor(2) as pool:
        _same(serial, _mc(pool))
        _same(serial, _mc(pool, chunks=7))
        got = map_runs(partial(_chunk_pf), 12, pool, chunks=5)
        np.testing.assert_array_equal(got[0], ref[0])
        np.testing.assert_array_equal(got[1]["ll"], ref[1]["ll"])
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=":0",
                                  silence_logs=50) as cluster, distributed.Client(cluster) as client:
        ex = client.get_executor()
        _same(serial, _mc(ex))
        got = map_runs(_chunk_pf, 12, ex)
        np.testing.assert_array_equal(got[0], ref[0])


def _blas_threads(start, size):
    from threadpoolctl import threadpool_info
    n = max((p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"), default=1)
    return np.full((size,), n)


def test_process_pool_gives_one_blas_thread_per_worker_and_serial_numbers():
    with process_pool(2) as pool:
        assert pool._max_workers == 2
        np.testing.assert_array_equal(map_runs(_blas_threads, 4, pool, chunks=4), np.ones(4))
        _same(_mc(), _mc(pool))
    with pytest.raises(ValueError, match="max_workers"):
        process_pool(0)


def test_run_chunks_and_progress_switch(monkeypatch):
    assert run_chunks(10) == [(0, 10)]
    assert run_chunks(10, chunks=3) == [(0, 4), (4, 4), (8, 2)]
    assert run_chunks(2, chunks=8) == [(0, 1), (1, 1)]
    with pytest.raises(ValueError, match="chunks"):
        run_chunks(5, chunks=0)
    monkeypatch.setenv("CI", "1")
    assert progress_enabled(None) is False and progress_enabled(True) is True
    monkeypatch.delenv("CI")
    assert progress_enabled(False) is False


def test_progress_bar_when_forced(capsys):
    run_monte_carlo(UNG, {"PF": BootstrapParticleFilter(UNG, 20)}, 5, 4, SEED, progress=True)
    assert "Monte Carlo" in capsys.readouterr().err


@pytest.mark.parametrize("make", [
    lambda m: BootstrapParticleFilter(m, 50),
    lambda m: BootstrapParticleFilter(m, 50, ess_threshold=0.5),
    lambda m: CMSParticleFilter(m, 50),
    lambda m: EvolutionSamplingParticleFilter(m, 50),
])
def test_weight_collapse_is_one_clear_warning_not_numpy_noise(make):
    """An outlier measurement makes every likelihood underflow: no numpy RuntimeWarning leaks,
    one WeightCollapseWarning names the count, the diagnostics record it, estimates stay finite."""
    import warnings

    from pfrepro.filters.particle import WeightCollapseWarning
    from pfrepro.models import LinearGaussianModel

    model = LinearGaussianModel([[0.5]], [[1.0]], [[1.0]], [[1e-4]], [0.0], P0=[[1.0]])
    y = np.zeros((3, 5, 1))
    y[1, 2] = 1e200          # squared residual overflows: every log-weight -inf
    y[2, 3] = -1e200
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = make(model).filter(y, rng=filter_streams(SEED, "collapse", 3))
    kinds = [type(w.message) for w in caught]
    assert kinds == [WeightCollapseWarning], [str(w.message) for w in caught]
    assert "2 of 15 run-steps" in str(caught[0].message)
    coll = res.diagnostics["collapsed"]
    assert coll[1, 2] and coll[2, 3] and coll.sum() == 2 and res.diagnostics["n_collapsed"] == 2
    assert np.all(np.isfinite(res.x))


def test_bootstrap_pf_run_blocks_change_no_number(monkeypatch):
    """A batch larger than BLOCK_PARTICLES is filtered in blocks of runs (per-run streams): the
    numbers, the diagnostics and the single collapse warning are those of one batched call."""
    import warnings

    from pfrepro.filters import particle

    sim = UNG.simulate(15, 7, truth_streams(SEED, 7))
    pf = BootstrapParticleFilter(UNG, 40, ess_threshold=0.5)
    one = pf.filter(sim.y, filter_streams(SEED, "pf", 7))
    monkeypatch.setattr(particle, "BLOCK_PARTICLES", 3 * 40)     # blocks of 3, 3 and 1 runs
    blocked = pf.filter(sim.y, filter_streams(SEED, "pf", 7))
    np.testing.assert_array_equal(blocked.x, one.x)
    for key in ("ess", "resampled", "log_evidence", "collapsed"):
        np.testing.assert_array_equal(blocked.diagnostics[key], one.diagnostics[key])
    # an overflowing residual in runs of two different blocks: one warning for the call, with the total
    y_bad = sim.y.copy()
    y_bad[1, 2] = 1e200
    y_bad[5, 4] = -1e200
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        res = pf.filter(y_bad, filter_streams(SEED, "pf", 7))
    coll = [w for w in rec if issubclass(w.category, particle.WeightCollapseWarning)]
    assert len(coll) == 1 and "2 of 105 run-steps" in str(coll[0].message)
    assert res.diagnostics["n_collapsed"] == 2


# -- a run's arithmetic does not depend on the batch (multi-dimensional models, chunks of one run) -----
class _Inline(concurrent.futures.Executor):
    """An executor running each task at submit, in this process: chunks without processes."""

    _max_workers = 2

    def submit(self, fn, *args, **kwargs):
        f = concurrent.futures.Future()
        try:
            f.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # noqa: BLE001 - handed to the caller
            f.set_exception(exc)
        return f


class _OwnModel(StateSpaceModel):
    """A reader's own model written as the tutorial says (``x @ F.T``, ``x[..., 0]``): a
    constant-velocity target measured in range and bearing."""

    def __init__(self):
        dt = 0.5
        self.F = np.array([[1, 0, dt, 0], [0, 1, 0, dt], [0, 0, 1, 0], [0, 0, 0, 1.0]])
        Q = 0.05 * np.array([[dt ** 3 / 3, 0, dt ** 2 / 2, 0], [0, dt ** 3 / 3, 0, dt ** 2 / 2],
                             [dt ** 2 / 2, 0, dt, 0], [0, dt ** 2 / 2, 0, dt]])
        super().__init__(4, 2, Q, np.diag([0.1, 0.01]), [10.0, 5.0, -0.3, 0.2], [10.0, 5.0, -0.3, 0.2],
                         np.diag([1.0, 1.0, 0.1, 0.1]))

    def f(self, x, k):
        return x @ self.F.T

    def h(self, x):
        return np.stack([np.hypot(x[..., 0], x[..., 1]), np.arctan2(x[..., 1], x[..., 0])], axis=-1)


def _dense_linear():
    from conftest import random_linear_model

    m = random_linear_model(7, nx=3, ny=2)
    m.truth_init = "prior"           # the initial state drawn through the Cholesky factor of P0 too
    return m


MULTI_D = {"linear 3-D": _dense_linear, "CWPA": CWPA.zhang2016,
           "CWPA mixture": lambda: CWPA.zhang2016("mixture"), "BOT": BearingsOnly.zhang2016, "own model": _OwnModel}


@pytest.mark.parametrize("name", list(MULTI_D))
def test_truth_of_a_run_is_the_same_in_every_split(name):
    """Runs 5 split 1+4, 2+3, 4+1, 1+1+1+1+1 equal the serial batch bit for bit (a 2-D (runs, n) @ F.T
    had given a lone run other last bits: 1e-16 in the truth, 1e-14 after the filters)."""
    model = MULTI_D[name]()
    full = model.simulate(20, 5, truth_streams(SEED, 5))
    for split in ((1, 4), (2, 3), (4, 1), (1, 1, 1, 1, 1)):
        starts = np.cumsum((0,) + split[:-1])
        parts = [model.simulate(20, n, truth_streams(SEED, n, int(s))) for s, n in zip(starts, split)]
        np.testing.assert_array_equal(np.concatenate([p.x for p in parts]), full.x, err_msg=str(split))
        np.testing.assert_array_equal(np.concatenate([p.y for p in parts]), full.y, err_msg=str(split))


@pytest.mark.parametrize("name", ["linear 3-D", "CWPA", "BOT"])
def test_run_monte_carlo_in_chunks_of_one_run_equals_serial(name):
    """Truth and every filter that uses the model's f and h (EKF, UKF, PF, GPFF) in chunks of one run
    and of two and three runs: bit-identical to one serial batch. (The Kalman filter, which applies
    the matrices itself, is a filter's own arithmetic and is not covered here.)"""
    model = MULTI_D[name]()
    filters = {"EKF": ExtendedKalmanFilter(model), "UKF": UnscentedKalmanFilter(model), "PF": BootstrapParticleFilter(model, 40),
               "GPFF": GaussianParticleFlowFilter(model, 20, n_steps=4)}
    serial = run_monte_carlo(model, filters, 12, 5, SEED, progress=False)
    for chunks in (5, 2):
        _same(serial, run_monte_carlo(model, filters, 12, 5, SEED, executor=_Inline(), chunks=chunks,
                                      progress=False))


def test_batch_matmul_rows_do_not_depend_on_the_batch():
    from pfrepro.models.base import batch_matmul

    rng = np.random.default_rng(3)
    for n in (2, 3, 4, 6):
        A = rng.standard_normal((n + 1, n))
        X = rng.standard_normal((9, 40, n))
        for runs in range(1, 9):
            np.testing.assert_array_equal(batch_matmul(X[:runs, 0], A)[0], batch_matmul(X[:1, 0], A)[0])
            np.testing.assert_array_equal(batch_matmul(X[:runs], A)[0], batch_matmul(X[:1], A)[0])
        np.testing.assert_allclose(batch_matmul(X[:, 0], A), X[:, 0] @ A.T, rtol=1e-13, atol=1e-13)
        np.testing.assert_array_equal(batch_matmul(X, A), X @ A.T)       # clouds: the matmul itself
    with pytest.raises(ValueError, match="batch_matmul"):
        batch_matmul(np.ones((3, 2)), np.ones((2, 3)))


# -- code identity on every task ------------------------------------------------------------------
def _double(start, size):
    return np.arange(start, start + size) * 2


def test_code_identity_is_checked_on_every_task(monkeypatch):
    from pfrepro import _codeid as codeid

    ident = codeid.identity()
    assert "pfrepro.models.linear" in ident and "pfrepro.montecarlo" in ident and "numpy" in ident
    assert codeid.differences(ident) == []
    np.testing.assert_array_equal(codeid.checked_call(ident, _double, 2, 3), [4, 6, 8])
    other = dict(ident, **{"pfrepro.models.linear": "0" * 16})
    with pytest.raises(codeid.CodeIdentityError, match=r"worker process \d+ .*pfrepro\.models\.linear differ"):
        codeid.checked_call(other, _double, 0, 1)
    with pytest.raises(codeid.CodeIdentityError, match=r"numpy .* \(sender 0\.0\)"):
        codeid.checked_call(dict(ident, numpy="0.0"), _double, 0, 1)

    def imports_other_code(start, size):      # a module imported while the task runs, from other sources
        monkeypatch.setitem(codeid._RECORDS, "pfrepro.lazily_imported", "f" * 16)
        return _double(start, size)

    with pytest.raises(codeid.CodeIdentityError, match="pfrepro.lazily_imported"):
        codeid.checked_call(ident, imports_other_code, 0, 1)
    # map_runs and run_monte_carlo submit through the check (the expected identity is this process's)
    seen = []

    class Spy(_Inline):
        def submit(self, fn, *args, **kwargs):
            seen.append((fn, args[0]))
            return super().submit(fn, *args, **kwargs)

    np.testing.assert_array_equal(map_runs(_double, 4, Spy(), chunks=2), _double(0, 4))
    run_monte_carlo(UNG, {"PF": BootstrapParticleFilter(UNG, 10)}, 3, 2, SEED, executor=Spy(), progress=False)
    assert seen and all(fn is codeid.checked_call and exp == codeid.identity() for fn, exp in seen)


def test_stale_module_is_named(tmp_path, monkeypatch):
    """A module whose file changed after this process imported it is stale (the worker's hint)."""
    from pfrepro import _codeid as codeid

    mod = tmp_path / "pfrepro_stale_probe.py"
    mod.write_text("X = 1\n")
    fake = type(sys)("pfrepro.stale_probe")
    fake.__file__ = str(mod)
    monkeypatch.setitem(sys.modules, "pfrepro.stale_probe", fake)
    monkeypatch.delitem(codeid._RECORDS, "pfrepro.stale_probe", raising=False)
    assert "pfrepro.stale_probe" not in codeid.stale_modules()     # recorded now, as on disk
    mod.write_text("X = 2\n")
    assert "pfrepro.stale_probe" in codeid.stale_modules()
    monkeypatch.delitem(codeid._RECORDS, "pfrepro.stale_probe")
