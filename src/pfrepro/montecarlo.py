"""Monte Carlo runner: model + filters + settings + seed -> estimates, errors, timings.

Randomness is split by name, not by order: the truth uses the stream
``SeedSequence([seed, 0])`` and each filter ``SeedSequence([seed, 1, crc32(name)])``,
so adding a filter to an experiment never changes the numbers of the others.
"""
from __future__ import annotations

import gc
import time
import zlib
from dataclasses import dataclass, field

import numpy as np

from .filters.base import FilterResult
from .metrics import mse, rmse
from .models.base import Simulation
from .rng import RunStreams
from .validation import check_positive_int

__all__ = ["MonteCarloResult", "run_monte_carlo", "filter_rng", "truth_rng", "truth_streams", "filter_streams",
           "time_single_run", "time_filters"]


def truth_rng(seed: int) -> np.random.Generator:
    """Generator for the simulated truth and measurements of experiment ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), 0]))


def filter_rng(seed: int, name: str) -> np.random.Generator:
    """Generator for the filter called ``name`` in experiment ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), 1, zlib.crc32(name.encode())]))


def truth_streams(seed: int, runs: int, start: int = 0) -> RunStreams:
    """Per-run streams of the truth of runs ``start`` to ``start + runs - 1`` of experiment ``seed``.

    Run i's stream is ``SeedSequence([seed, 0], spawn_key=(i,))``: it does not depend on
    how many runs the experiment has or how they are split (see :mod:`pfrepro.rng`).
    """
    return RunStreams.from_entropy([int(seed), 0], runs, start)


def filter_streams(seed: int, name: str, runs: int, start: int = 0) -> RunStreams:
    """Per-run streams of the filter called ``name`` (keyed by name: adding a filter changes no other)."""
    return RunStreams.from_entropy([int(seed), 1, zlib.crc32(name.encode())], runs, start)


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
    repeats = check_positive_int(repeats, "repeats")
    for filt in filters.values() if warmup else ():
        _timed_call(filt, y_one_run, rng_seed)
    times = {name: [] for name in filters}
    for r in range(repeats):
        for name, filt in filters.items():
            times[name].append(_timed_call(filt, y_one_run, rng_seed + r))
    return {name: float(np.median(v)) for name, v in times.items()}


@dataclass
class MonteCarloResult:
    """Everything an experiment produced; ``results[name]`` is that filter's FilterResult."""

    sim: Simulation
    results: dict[str, FilterResult]
    batch_seconds: dict[str, float]
    seconds_per_run: dict[str, float] = field(default_factory=dict)
    seed: int = 0

    @property
    def x_true(self) -> np.ndarray:
        """The true states x_1..x_T, aligned with the estimates, shape ``(runs, T, dim_x)``."""
        return self.sim.x[:, 1:]

    def mse(self, name: str) -> np.ndarray:
        """Per-run MSE (eq 56 of Zhang et al.)."""
        return mse(self.x_true, self.results[name].x)

    def rmse(self, name: str) -> np.ndarray:
        """Per-run RMSE."""
        return rmse(self.x_true, self.results[name].x)

    # -- exports (pfrepro.export) ----------------------------------------------------------
    def to_frame(self, component_names=None, filters=None):
        """Tidy ``pandas.DataFrame`` of every filter: columns ``filter, run, k, component,
        estimate, truth, error`` (see :func:`pfrepro.export.monte_carlo_frame`)."""
        from .export import monte_carlo_frame

        return monte_carlo_frame(self, component_names, filters)

    def to_csv(self, path, component_names=None, filters=None):
        """Write :meth:`to_frame` to ``path`` as CSV; returns the path."""
        from .export import write_table

        return write_table(self.to_frame(component_names, filters), path)


def run_monte_carlo(model, filters: dict, T: int, runs: int, seed: int, *, time_per_run: bool = False,
                    timing_repeats: int = 3, sim: Simulation | None = None) -> MonteCarloResult:
    """Simulate ``runs`` runs of ``model`` and run every filter on the same data in one batched call each.

    Parameters
    ----------
    filters : mapping name -> filter object (anything with ``filter(y, rng)``).
    time_per_run : also measure each filter's wall time on a single run
        (median of ``timing_repeats``, interleaved across the filters: :func:`time_filters`),
        the figure the papers' timing tables report.
    sim : reuse an existing simulation instead of simulating (``T``/``runs`` must match).
    """
    T = check_positive_int(T, "T")
    runs = check_positive_int(runs, "runs")
    if sim is None:
        sim = model.simulate(T, runs, truth_rng(seed))
    elif sim.y.shape[:2] != (runs, T):
        raise ValueError(f"sim has shape {sim.y.shape[:2]}, expected (runs, T) = {(runs, T)}")
    results, batch = {}, {}
    for name, filt in filters.items():
        t0 = time.perf_counter()
        results[name] = filt.filter(sim.y, rng=filter_rng(seed, name))
        batch[name] = time.perf_counter() - t0
    per_run = time_filters(filters, sim.y[:1], seed, timing_repeats) if time_per_run else {}
    return MonteCarloResult(sim=sim, results=results, batch_seconds=batch, seconds_per_run=per_run, seed=seed)
