"""Monte Carlo runner: model + filters + settings + seed -> estimates, errors, timings.

Randomness is split by name, not by order, and by run: run i of the truth draws from
``SeedSequence([seed, 0], spawn_key=(i,))`` and run i of the filter called ``name`` from
``SeedSequence([seed, 1, crc32(name)], spawn_key=(i,))`` (:func:`truth_streams`,
:func:`filter_streams`). So adding a filter never changes the numbers of the others,
growing an experiment from 100 to 200 runs keeps the first 100 bit-identical, and any
split of the runs over processes or machines (``executor=``) gives the same numbers.

Parallel work: :func:`run_monte_carlo` and :func:`map_runs` accept any
``concurrent.futures.Executor`` (a ``ProcessPoolExecutor``, or a dask.distributed
``Client.get_executor()``); the runs are cut into contiguous chunks, each chunk builds
the streams of its own runs (``start=``), and the chunks' results are concatenated
in run order -- bit-identical to the serial call.

Every task sent to an executor carries this process's code identity
(:func:`code_identity`); a worker whose loaded pfrepro code or numpy/scipy/Python
versions differ refuses it with a :class:`CodeIdentityError` naming the worker,
which stops the call. On a dask cluster, a call whose scheduler has had no worker for
``worker_timeout`` seconds (:func:`dask_executor`) stops with a :class:`WorkersLostError`
instead of waiting for ever.
"""
from __future__ import annotations

import gc
import math
import os
import sys
import concurrent.futures
import time
import zlib
from time import monotonic as _monotonic   # the cluster watch's clock (tests replace time.perf_counter)
from dataclasses import dataclass, field

import numpy as np

from . import _codeid as codeid
from ._codeid import CodeIdentityError
from ._codeid import identity as code_identity
from .metrics import mse, rmse
from .models.base import Simulation
from .results import FilterResult
from .rng import RunStreams
from .validation import check_positive_int

__all__ = ["MonteCarloResult", "run_monte_carlo", "map_runs", "run_chunks", "process_pool", "dask_executor", "filter_rng", "truth_rng",
           "WorkersLostError", "DEFAULT_WORKER_TIMEOUT", "CodeIdentityError", "code_identity",
           "truth_streams", "filter_streams", "time_single_run", "time_filters", "time_filter_repeats", "progress_enabled"]


def truth_rng(seed: int) -> np.random.Generator:
    """Generator for the simulated truth and measurements of experiment ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), 0]))


def _name_key(name) -> int:
    """The stream key of a filter name (its CRC-32); the name must be a string."""
    if not isinstance(name, str):
        raise TypeError(f"name must be the filter's name (a string), got {name!r}")
    return zlib.crc32(name.encode())


def filter_rng(seed: int, name: str) -> np.random.Generator:
    """Generator for the filter called ``name`` in experiment ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), 1, _name_key(name)]))


def truth_streams(seed: int, runs: int, start: int = 0) -> RunStreams:
    """Per-run streams of the truth of runs ``start`` to ``start + runs - 1`` of experiment ``seed``.

    Run i's stream is ``SeedSequence([seed, 0], spawn_key=(i,))``: it does not depend on
    how many runs the experiment has or how they are split (see :mod:`pfrepro.rng`).
    """
    return RunStreams.from_entropy([int(seed), 0], runs, start)


def filter_streams(seed: int, name: str, runs: int, start: int = 0) -> RunStreams:
    """Per-run streams of the filter called ``name`` (keyed by name: adding a filter changes no other)."""
    return RunStreams.from_entropy([int(seed), 1, _name_key(name)], runs, start)


def _timed_call(filt, y, rng_seed: int) -> float:
    """Wall time of one ``filt.filter(y)`` call with the garbage collector paused.

    As in ``timeit``: a collection triggered by earlier allocations of the
    notebook would otherwise land inside a few-millisecond run at random.
    """
    rng = np.random.default_rng(rng_seed)
    gc_was_enabled = gc.isenabled()
    gc.disable()
    try:
        t0 = time.perf_counter()
        filt.filter(y, rng=rng)
        return time.perf_counter() - t0
    finally:
        if gc_was_enabled:
            gc.enable()


def time_single_run(filt, y_one_run, rng_seed: int = 0, repeats: int = 3, warmup: bool = True) -> float:
    """Median wall time (s) of ``filt`` on one run (the papers' 'time per run')."""
    return time_filters({"f": filt}, y_one_run, rng_seed, repeats, warmup=warmup)["f"]


def time_filters(filters: dict, y_one_run, rng_seed: int = 0, repeats: int = 7, *,
                 warmup: bool = True) -> dict:
    """Median single-run wall time of each filter, with the repeats interleaved across filters.

    Interleaving (filter A, B, C, A, B, C, ...) exposes every filter to the same
    drifts of machine load, so the *ratios* the chapters report are steadier than
    timing each filter in its own block. One untimed warm-up call per filter comes
    first: the first one-run call of a filter pays one-off costs (allocator, caches)
    that would otherwise inflate whichever configuration happens to be timed first.
    Repeat r uses the seed ``rng_seed + r``; ``warmup=False`` skips the warm-up
    (for a caller that has just warmed the filters up itself).
    """
    times = time_filter_repeats(filters, y_one_run, rng_seed, repeats, warmup=warmup)
    return {name: float(np.median(v)) for name, v in times.items()}


def time_filter_repeats(filters: dict, y_one_run, rng_seed: int = 0, repeats: int = 7, *,
                        warmup: bool = True) -> dict:
    """Every repeat of :func:`time_filters` (same interleaving, warm-up and seeds):
    ``{name: [seconds of repeat 0, 1, ...]}``."""
    repeats = check_positive_int(repeats, "repeats")
    for filt in filters.values() if warmup else ():
        _timed_call(filt, y_one_run, rng_seed)
    times = {name: [] for name in filters}
    for r in range(repeats):
        for name, filt in filters.items():
            times[name].append(_timed_call(filt, y_one_run, rng_seed + r))
    return times


@dataclass
class MonteCarloResult:
    """Everything an experiment produced; ``results[name]`` is that filter's FilterResult."""

    sim: Simulation
    results: dict[str, FilterResult]
    batch_seconds: dict[str, float]
    seconds_per_run: dict[str, float] = field(default_factory=dict)
    seed: int = 0
    #: every interleaved single-run timing repeat behind ``seconds_per_run`` (``{name — [s, ...]}``),
    #: for callers that want the spread (e.g. :func:`pfrepro.cost.time_summary`) without timing again
    timing_repeats: dict[str, list[float]] = field(default_factory=dict)

    @property
    def x_true(self) -> np.ndarray:
        """The true states x_1..x_T, aligned with the estimates, shape ``(runs, T, dim_x)``."""
        return self.sim.x[:, 1:]

    def _result(self, name):
        try:
            return self.results[name]
        except (KeyError, TypeError):
            raise KeyError(f"no filter named {name!r} in this result; filters: {list(self.results)}") from None

    def mse(self, name: str) -> np.ndarray:
        """Per-run MSE (eq 56 of Zhang et al.)."""
        return mse(self.x_true, self._result(name).x)

    def rmse(self, name: str) -> np.ndarray:
        """Per-run RMSE."""
        return rmse(self.x_true, self._result(name).x)

    def n_diverged(self) -> dict:
        """Runs each filter lost (diverged/stopped: non-finite estimates), ``{name: count}``:
        report them beside every error statistic."""
        return {n: int((~np.all(np.isfinite(r.x.reshape(r.x.shape[0], -1)), axis=1)).sum())
                for n, r in self.results.items()}

    # -- exports (pfrepro.export) ----------------------------------------------------------
    def to_frame(self, component_names=None, filters=None):
        """Tidy ``pandas.DataFrame`` of every filter: columns ``filter, run, k, component,
        estimate, truth, error, diverged`` (see :func:`pfrepro.export.monte_carlo_frame`)."""
        from .export import monte_carlo_frame

        return monte_carlo_frame(self, component_names, filters)

    def to_csv(self, path, component_names=None, filters=None):
        """Write :meth:`to_frame` to ``path`` as CSV; returns the path."""
        from .export import write_table

        return write_table(self.to_frame(component_names, filters), path)


# -- progress ------------------------------------------------------------------------------
def progress_enabled(progress=None) -> bool:
    """Whether to show a progress bar: ``True``/``False`` force it; ``None`` (auto) shows one
    only when stderr is a terminal and the ``CI`` environment variable is not set
    (so the book build and CI stay silent)."""
    if progress is not None:
        return bool(progress)
    if os.environ.get("CI"):
        return False
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


class _NoBar:
    def update(self, n=1):
        pass

    def set_postfix_str(self, s):
        pass

    def close(self):
        pass


def _bar(progress, total: int, desc: str):
    if not progress_enabled(progress) or total <= 0:
        return _NoBar()
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, unit="chunk", leave=False)


# -- chunks and executors ------------------------------------------------------------------
def _one_blas_thread() -> None:
    """Pool-worker initialiser: one BLAS thread per worker process.

    OpenBLAS starts one thread per core in every process. With one worker per core, each
    worker's idle BLAS threads spin while its neighbour computes: on 2 cores the BOT PF at
    N = 16000 took 3.6x the serial CPU time per run in a plain ``ProcessPoolExecutor(2)``
    and the serial time with this initialiser. (dask.distributed workers already start
    with ``OPENBLAS_NUM_THREADS=1``.)
    """
    from threadpoolctl import threadpool_limits
    threadpool_limits(1)


def _retain_freed_memory() -> bool:
    """Pool-worker initialiser: glibc keeps freed memory for reuse instead of handing it back.

    A batched filter allocates and frees arrays of 0.1-30 MB at every time step. By default
    glibc serves such sizes with fresh ``mmap`` pages, or trims the heap when they are freed,
    so every step page-faults its temporaries in again: the IMM particle filters spent 6-10 %
    of their CPU time in the kernel on those faults. ``mallopt`` with the largest mmap
    threshold (32 MB) and a 1 GB trim threshold keeps them in the heap. It changes no number
    (only where the memory comes from); returns False, doing nothing, off glibc.
    """
    try:
        import ctypes
        libc = ctypes.CDLL("libc.so.6")
        M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
        return bool(libc.mallopt(M_MMAP_THRESHOLD, 32 << 20)) & bool(libc.mallopt(M_TRIM_THRESHOLD, 1 << 30))
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        return False


def _init_worker() -> None:
    """Pool-worker initialiser: :func:`_one_blas_thread` and :func:`_retain_freed_memory`."""
    _one_blas_thread()
    _retain_freed_memory()


def process_pool(max_workers: int | None = None):
    """A ``ProcessPoolExecutor`` for :func:`run_monte_carlo` / :func:`map_runs`.

    ``max_workers`` defaults to the number of cores. Each worker runs BLAS on one thread
    (``_one_blas_thread``): the parallelism is over runs, and BLAS threads on top of
    it oversubscribe the cores; and keeps freed memory for reuse (``_retain_freed_memory``).
    Use it as a context manager, or leave it to the interpreter's exit.
    """
    from concurrent.futures import ProcessPoolExecutor
    if max_workers is not None:
        max_workers = check_positive_int(max_workers, "max_workers")
    return ProcessPoolExecutor(max_workers=max_workers, initializer=_init_worker)


#: seconds a dask call waits while its scheduler has no worker before it stops (:class:`WorkersLostError`)
DEFAULT_WORKER_TIMEOUT = 60.0
#: seconds between two looks at the cluster while waiting for a task
_POLL_SECONDS = 0.5


class WorkersLostError(RuntimeError):
    """Every worker of the dask scheduler left (or the scheduler went away) during a call, for longer
    than the executor's ``worker_timeout``; the call's remaining tasks are cancelled."""


def dask_executor(client, worker_timeout: float = DEFAULT_WORKER_TIMEOUT):
    """A ``concurrent.futures`` executor on the workers of a dask.distributed ``client``, for
    :func:`run_monte_carlo` / :func:`map_runs`.

    ``worker_timeout``: a call that finds the scheduler without any worker (or the client
    disconnected) for this many seconds cancels its tasks and raises :class:`WorkersLostError`
    (a worker restarted by its nanny within that time changes nothing). Each task is checked
    against this process's code identity on the worker (module docstring).

    Runs ``_init_worker`` on every worker first (one BLAS thread, freed memory kept for
    reuse): a dask nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_`` set, which also
    fixes glibc's mmap threshold at 128 kB, so every temporary array of a batched filter is
    mapped and page-faulted in afresh. The Li et al. (2012) PF and grid filter on 100 runs
    (2 workers, 4 chunks each) spent 45-48 s in their tasks, against 14-16 s on a
    :func:`process_pool` (2), and 16-20 s after this call (2 cores under load 12).
    Workers that join later run without it (same numbers, slower).
    Tasks are submitted with ``pure=False`` (no hashing of their large arguments). Changes no
    number: the results are bit-identical to the serial call.
    """
    if not (isinstance(worker_timeout, (int, float)) and not isinstance(worker_timeout, bool)
            and 0 < worker_timeout < float("inf")):
        raise ValueError(f"worker_timeout must be a finite number of seconds > 0, got {worker_timeout!r}")
    client.run(_init_worker)
    ex = client.get_executor(pure=False)
    ex.pfrepro_worker_timeout = float(worker_timeout)
    return ex


def _dask_client(executor):
    client = getattr(executor, "_client", None)          # dask.distributed ClientExecutor
    return client if client is not None and hasattr(client, "scheduler_info") else None


class _WorkerWatch:
    """Raises :class:`WorkersLostError` once a dask executor's scheduler has had no worker (or the
    client has not been connected) for ``limit`` seconds. Reads the worker count the client
    refreshes in the background (every 2 s by default), so a look never blocks."""

    def __init__(self, client, limit: float):
        self.client, self.limit, self.since = client, float(limit), None

    def _ok(self) -> bool:
        if str(getattr(self.client, "status", "running")) != "running":
            return False
        info = getattr(self.client, "_scheduler_identity", None) or {}
        n = info.get("n_workers")
        if n is None:
            n = len(info.get("workers") or {}) if "workers" in info else None
        return n is None or n > 0

    def __call__(self) -> None:
        now = _monotonic()
        if self._ok():
            self.since = None
        elif self.since is None:
            self.since = now
        elif now - self.since >= self.limit:
            status = str(getattr(self.client, "status", "running"))
            why = "" if status == "running" else f" (the client lost the scheduler: {status})"
            raise WorkersLostError(
                f"the dask scheduler has had no worker for {self.limit:g} s{why}; the run is stopped. Start "
                f"workers (`dask worker ADDRESS --nthreads 1`) and run the command again")


def _watch(executor):
    client = _dask_client(executor)
    if client is None:
        return None
    return _WorkerWatch(client, getattr(executor, "pfrepro_worker_timeout", DEFAULT_WORKER_TIMEOUT))


def _submit(executor, expected: dict, fn, *args):
    """``executor.submit(fn, *args)`` run under the code-identity check (``pfrepro._codeid.checked_call``)."""
    return executor.submit(codeid.checked_call, expected, fn, *args)


def _n_workers(executor) -> int:
    """Best guess of the number of workers behind ``executor`` (for the default chunking)."""
    n = getattr(executor, "_max_workers", None)          # concurrent.futures pools
    if n:
        return int(n)
    client = getattr(executor, "_client", None)           # dask.distributed ClientExecutor
    if client is not None:
        try:
            return max(1, int(sum(client.nthreads().values())))
        except Exception:  # pragma: no cover - a client that cannot answer
            pass
    return os.cpu_count() or 1


def run_chunks(runs: int, executor=None, chunks: int | None = None) -> list[tuple[int, int]]:
    """Contiguous chunks ``(start, size)`` covering runs ``0 .. runs - 1``.

    Serial (``executor=None``): one chunk of all runs (the fastest batched call).
    With an executor: ``chunks`` chunks (default two per worker, for load balance),
    never more than ``runs``. The split changes no number (per-run streams).
    """
    runs = check_positive_int(runs, "runs")
    if chunks is None:
        chunks = 1 if executor is None else 2 * _n_workers(executor)
    chunks = min(check_positive_int(chunks, "chunks"), runs)
    size = math.ceil(runs / chunks)
    return [(s, min(size, runs - s)) for s in range(0, runs, size)]


def _concat(parts: list):
    """Concatenate per-chunk results along the runs axis (arrays, FilterResult, Simulation,
    tuples, lists and dicts of those). Scalars must agree across chunks, except the counts
    in :data:`_SUMMED_KEYS`, which are added."""
    first = parts[0]
    if len(parts) == 1:
        return first
    if isinstance(first, np.ndarray):
        return np.concatenate(parts, axis=0)
    if isinstance(first, FilterResult):
        return FilterResult(_concat([p.x for p in parts]),
                            None if first.P is None else _concat([p.P for p in parts]),
                            _concat_dict([p.diagnostics for p in parts]))
    if isinstance(first, Simulation):
        return Simulation(_concat([p.x for p in parts]), _concat([p.y for p in parts]))
    if isinstance(first, dict):
        return _concat_dict(parts)
    if isinstance(first, (tuple, list)):
        return type(first)(_concat(list(col)) for col in zip(*parts))
    raise TypeError(f"cannot concatenate chunk results of type {type(first).__name__}; "
                    "return arrays (runs axis first), FilterResults, or tuples/dicts of them")


#: diagnostics that count events over runs — a chunked call adds them up
_SUMMED_KEYS = frozenset({"n_collapsed", "n_diverged"})


def _concat_dict(parts: list[dict]) -> dict:
    out = {}
    for key in parts[0]:
        vals = [p[key] for p in parts]
        if key in _SUMMED_KEYS:
            out[key] = type(vals[0])(sum(vals))
        elif _has_runs_axis(vals[0]):
            out[key] = _concat(vals)
        elif all(np.array_equal(v, vals[0]) for v in vals[1:]):
            out[key] = vals[0]
        else:
            raise ValueError(f"chunks disagree on the scalar {key!r}: {vals}; it cannot be combined")
    return out


def _has_runs_axis(v) -> bool:
    """Whether a chunk's dict value is per-run data to concatenate (an array with an axis, a
    FilterResult, a Simulation, a dict, or a tuple/list holding one), not a setting (a scalar,
    a string, a tuple of scalars) that every chunk must share."""
    if isinstance(v, (FilterResult, Simulation, dict)):
        return True
    if isinstance(v, np.ndarray):
        return v.ndim != 0
    return isinstance(v, (tuple, list)) and any(_has_runs_axis(e) for e in v)


#: why a pool worker dies in practice, said where the reader sees the error
_BROKEN_POOL_HINT = (
    "a worker process of the pool died before returning its result. The usual cause: a model, "
    "filter or function whose class is defined in the notebook (or script) after the pool's "
    "workers were started; the workers started earlier cannot load it (a class defined in "
    "__main__ is pickled by name). Create the pool after defining every class it runs, or "
    "define the classes in a module. Other causes: the machine ran out of memory, or the worker "
    "was killed. The pool is unusable now; create a new one")


def _gather(futures: list, bar, watch=None) -> list:
    from concurrent.futures.process import BrokenProcessPool

    out = []
    try:
        for f in futures:
            if watch is not None:    # wait in short slices, looking at the cluster in between
                while not concurrent.futures.wait([f], timeout=_POLL_SECONDS).done:
                    watch()
            out.append(f.result())
            bar.update(1)
    except BaseException as e:
        for f in futures:
            f.cancel()
        if isinstance(e, BrokenProcessPool):
            raise BrokenProcessPool(_BROKEN_POOL_HINT) from e
        raise
    return out


def map_runs(fn, runs: int, executor=None, *, chunks: int | None = None, progress=None, desc: str = "runs"):
    """Apply ``fn(start, size)`` to contiguous chunks of the runs and concatenate the results.

    ``fn(start, size)`` must compute runs ``start .. start + size - 1`` only (drawing from
    streams built with ``start=``, e.g. :func:`truth_streams` / :func:`filter_streams`)
    and return an array with the runs axis first, a ``FilterResult``, a ``Simulation``,
    or a tuple/list/dict of those; the chunks' results are concatenated in run order.
    With an ``executor`` the chunks run in parallel (``fn`` must be picklable: a
    module-level function or a ``functools.partial`` of one); the result is bit-identical
    to ``executor=None``. This is the helper for heavy batched work that is not a plain
    :func:`run_monte_carlo` call.
    """
    parts = run_chunks(runs, executor, chunks)
    bar = _bar(progress, len(parts) if len(parts) > 1 else 0, desc)
    try:
        if executor is None:
            res = []
            for start, size in parts:
                res.append(fn(start, size))
                bar.update(1)
        else:
            expected = codeid.identity()
            res = _gather([_submit(executor, expected, fn, start, size) for start, size in parts], bar,
                          _watch(executor))
    finally:
        bar.close()
    return _concat(res)


def _simulate_chunk(model, T: int, seed: int, start: int, size: int) -> Simulation:
    return model.simulate(T, size, truth_streams(seed, size, start))


def _filter_chunk(filt, name: str, y, seed: int, start: int) -> tuple[FilterResult, float]:
    t0 = time.perf_counter()
    res = filt.filter(y, rng=filter_streams(seed, name, y.shape[0], start))
    return res, time.perf_counter() - t0


def check_seed(seed, name: str = "seed") -> int:
    """A seed is an int >= 0 (not a bool, a float such as 1.5, None or a string)."""
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"{name} must be an integer >= 0, got {seed!r}")
    if seed < 0:
        raise ValueError(f"{name} must be >= 0, got {seed}")
    return int(seed)


def _check_mc_inputs(model, filters, executor, sim=None):
    """run_monte_carlo's model, filters and executor, checked before any work starts."""
    if sim is None and (model is None or not callable(getattr(model, "simulate", None))):
        raise TypeError(f"model must be a state-space model with a simulate method, got {model!r}")
    if not isinstance(filters, dict):
        raise TypeError(f"filters must be a dict {{name: filter}}, got {type(filters).__name__}")
    for name, filt in filters.items():
        if not isinstance(name, str):
            raise TypeError(f"filters: every name must be a string, got {name!r}")
        if not callable(getattr(filt, "filter", None)):
            raise TypeError(f"filters[{name!r}] must be a filter (with a .filter method), got {filt!r}")
    if executor is not None:
        if not callable(getattr(executor, "submit", None)):
            raise TypeError(f"executor must be a concurrent.futures.Executor (or None), got {executor!r}")
        if getattr(executor, "_shutdown", False) or getattr(executor, "_shutdown_thread", False):
            raise ValueError("executor has been shut down; create a new one (montecarlo.process_pool)")
        if isinstance(executor, concurrent.futures.ProcessPoolExecutor):
            _check_picklable({"model": model, **{f"filters[{n!r}]": f for n, f in filters.items()}})


def _check_picklable(objects: dict):
    """Raise a TypeError naming the object and attribute that a process pool cannot pickle."""
    import pickle

    for label, obj in objects.items():
        try:
            pickle.dumps(obj)
        except Exception as exc:  # noqa: BLE001 - any pickling failure is reported the same way
            bad = [k for k, v in _attributes(obj).items() if not _pickles(v)]
            where = f" (attribute {', '.join(bad)})" if bad else ""
            raise TypeError(f"{label} cannot be sent to a process pool: it cannot be pickled{where}: "
                            f"{type(exc).__name__}: {exc}") from None


def _attributes(obj) -> dict:
    """The instance attributes pickle would send: ``__dict__`` and the classes' ``__slots__``
    (an object may have either, both, or neither)."""
    out = dict(getattr(obj, "__dict__", {}))
    for cls in type(obj).__mro__:
        slots = cls.__dict__.get("__slots__", ())
        for name in (slots,) if isinstance(slots, str) else slots:
            if name not in ("__dict__", "__weakref__") and hasattr(obj, name):
                out[name] = getattr(obj, name)
    return out


def _pickles(v) -> bool:
    import pickle

    try:
        pickle.dumps(v)
        return True
    except Exception:  # noqa: BLE001
        return False


def run_monte_carlo(model, filters: dict, T: int, runs: int, seed: int, *, executor=None, progress=None,
                    chunks: int | None = None, time_per_run: bool = False, timing_repeats: int = 3,
                    sim: Simulation | None = None) -> MonteCarloResult:
    """Simulate ``runs`` runs of ``model`` and run every filter on the same data, batched over runs.

    Random streams: run i's truth from ``truth_streams(seed, ...)``, run i of filter ``name``
    from ``filter_streams(seed, name, ...)``; run i's numbers depend on ``seed``, ``name``
    and i only (not on ``runs``, ``executor`` or ``chunks``).

    Parameters
    ----------
    filters : dict
        Mapping name -> filter object (anything with ``filter(y, rng)``).
    executor : concurrent.futures.Executor or None
        None (serial: one batched call per filter) or any
        ``concurrent.futures.Executor`` -- a ``ProcessPoolExecutor``, or a dask.distributed
        ``Client.get_executor()``. The runs are cut into ``chunks`` contiguous chunks (default
        two per worker), the truth and every (filter, chunk) become tasks, and the results are
        concatenated in run order: bit-identical to the serial call. Models and filters must
        be picklable.
    progress : bool or None
        None (auto: a ``tqdm`` bar only when stderr is a terminal and ``CI`` is unset),
        True or False.
    time_per_run : bool
        Also measure each filter's wall time on a single run
        (median of ``timing_repeats``, interleaved across the filters: :func:`time_filters`),
        the figure the papers' timing tables report. Always serial, in this process, after
        every parallel task has finished (never while the pool is working).
    sim : Simulation, optional
        Reuse an existing simulation instead of simulating (``T``/``runs`` must match).

    Notes
    -----
    ``batch_seconds[name]`` is the wall time of the filter's batched call (serial), or the sum
    of its chunks' wall times in the workers (with an executor).
    """
    T = check_positive_int(T, "T")
    runs = check_positive_int(runs, "runs")
    seed = check_seed(seed)
    _check_mc_inputs(model, filters, executor, sim)
    if sim is not None and sim.y.shape[:2] != (runs, T):
        raise ValueError(f"sim has shape {sim.y.shape[:2]}, expected (runs, T) = {(runs, T)}")
    parts = run_chunks(runs, executor, chunks)
    n_tasks = len(filters) * len(parts) + (sim is None) * len(parts)
    bar = _bar(progress, n_tasks, "Monte Carlo")
    results, batch = {}, {}
    try:
        if executor is None:
            if sim is None:
                sim = _simulate_chunk(model, T, seed, 0, runs)
                bar.update(1)
            for name, filt in filters.items():
                bar.set_postfix_str(name)
                results[name], batch[name] = _filter_chunk(filt, name, sim.y, seed, 0)
                bar.update(1)
        else:
            expected, watch = codeid.identity(), _watch(executor)
            if sim is None:
                sim = _concat(_gather([_submit(executor, expected, _simulate_chunk, model, T, seed, s, n)
                                       for s, n in parts], bar, watch))
            futures = {name: [_submit(executor, expected, _filter_chunk, filt, name, sim.y[s:s + n], seed, s)
                              for s, n in parts] for name, filt in filters.items()}
            try:
                for name, fs in futures.items():
                    bar.set_postfix_str(name)
                    out = _gather(fs, bar, watch)
                    results[name] = _concat([r for r, _ in out])
                    batch[name] = float(sum(t for _, t in out))
            except BaseException:
                for fs in futures.values():     # the other filters' tasks too
                    for f in fs:
                        f.cancel()
                raise
    finally:
        bar.close()
    reps = time_filter_repeats(filters, sim.y[:1], seed, timing_repeats) if time_per_run else {}
    per_run = {name: float(np.median(v)) for name, v in reps.items()}    # as time_filters
    return MonteCarloResult(sim=sim, results=results, batch_seconds=batch, seconds_per_run=per_run, seed=seed,
                            timing_repeats=reps)
