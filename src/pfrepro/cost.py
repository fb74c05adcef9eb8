"""Deterministic cost counts, and measured time with an interval, for the cost claims.

Wall time moves with machine load and, for one small run, measures Python's per-call
overhead more than an algorithm's work. A cost claim ("A costs less than B", "its
cost grows more slowly with N") is therefore decided here on a *count* of what a
filter asks of its model, which is exact and load-independent, and measured time is
shown beside it as context (median and interval over interleaved repeats).

Counting. :func:`count_model_calls` runs a filter once with its model wrapped in a
:class:`CountingModel` proxy: every call of a counted method adds the number of states
passed through it, ``prod(x.shape[:-1])`` (a particle cloud ``(runs, N, d)`` counts
``runs * N``; a single state ``(d,)`` counts 1). No filter code changes. The counted
methods and their column names (a column is named after its method unless the table gives
another name):

=========================================== ==========================================
column (the model method it counts)         what it is
=========================================== ==========================================
``transitions`` (``sample_transition``)     states drawn from p(x_k | x_{k-1})
``likelihoods`` (``log_likelihood``)        likelihood evaluations p(y_k | x)
``f``                                       noise-free transitions (EKF/UKF, ESPF, grid)
``h``                                       measurement-function evaluations (UKF, GPFF)
``jacobian_f``                              Jacobians of f (EKF)
``jacobian_h``                              Jacobians of h (EKF)
=========================================== ==========================================

Parameterised models (:class:`~pfrepro.models.parameterized.ParameterizedModel`: ``f(x, k,
theta)``, ``sample_transition(x, k, theta, rng)``, ``jacobian_f(x, k, theta)``) evaluate the
model once per *state × parameter* pair of the broadcast of ``x`` and ``theta``: ``f`` at one
state estimate ``(runs, 1, d)`` and ``N_θ`` parameter draws ``(runs, N_θ, 1)`` is ``runs * N_θ``
evaluations (the dual PF's parameter weights), not ``runs``. The proxy counts
``prod(broadcast(x.shape[:-1], theta.shape[:-1]))`` for these calls (``theta`` with its
trailing ``dim_theta`` axis, as the models take it; a scalar or a ``(dim_theta,)`` vector
broadcasts to every state).

A jump-Markov system (``models``: one model per mode) is counted through its mode
models: the proxy hands out proxies of them that add to the same columns (the jump-Markov
PF's transition of a particle in mode j is a call of mode j's ``f``).

Calls a model makes to itself (``sample_transition`` calls ``f``,
``log_likelihood`` calls ``h``) are not counted twice: the proxy sees only what the
filter asks. ``model_evaluations`` is the sum of the six columns, a unit-cost model in
which each state passed through the model interface costs one. ``flow`` counts the
states moved per evaluation of a particle-flow field (Gaussian particle flow filter;
counted by wrapping :func:`pfrepro.flow.integrate_flow` for the duration of the
count); it is reported beside the total, not in it (with the eq (41) field each flow
evaluation also evaluates ``h`` at every particle, which ``h`` counts already).

Timing. :func:`time_repeats` times each filter on one run, the repeats interleaved
across the filters (A, B, C, A, B, C, ...) so load drifts hit all alike, and returns
every repeat; :func:`time_summary` gives the median of each filter and of each
ratio to a reference, with the range over repeats as its interval (for 7 repeats the
[min, max] of a sample is a distribution-free confidence interval for the median at
level 1 - 2 * 0.5**7 = 98.4 %).
"""
from __future__ import annotations

import copy
import math
from contextlib import contextmanager

import numpy as np
import pandas as pd

from . import flow as _flow
from .montecarlo import time_filter_repeats

__all__ = ["COUNTED", "COUNT_COLUMNS", "PRINTED_COLUMNS", "CountingModel", "count_model_calls", "cost_counts",
           "time_repeats", "time_summary", "median_interval", "imm_evaluations", "smc2_evaluations",
           "count_predicted", "repeat_range_columns", "SAME_MODEL_RATIO", "SAME_N_RATIO", "UNGM_RATIO"]

#: counted model method -> column name
COUNTED = {"sample_transition": "transitions", "log_likelihood": "likelihoods", "f": "f", "h": "h",
           "jacobian_f": "jacobian_f", "jacobian_h": "jacobian_h"}
#: columns of :func:`cost_counts`
COUNT_COLUMNS = list(COUNTED.values()) + ["model_evaluations", "flow"]
#: further columns of :func:`cost_counts` — the algorithm as printed (see :func:`count_model_calls`)
PRINTED_COLUMNS = ["flow_calls", "flow_printed", "resampled", "printed_operations"]

# the positional index of the state argument of each counted method
_STATE_ARG = {"sample_transition": 0, "log_likelihood": 1, "f": 0, "h": 0, "jacobian_f": 0, "jacobian_h": 0}
_STATE_KW = {"sample_transition": "x", "log_likelihood": "x", "f": "x", "h": "x", "jacobian_f": "x",
             "jacobian_h": "x"}


#: the positional index of the parameter argument of the counted methods that take one
#: (:class:`~pfrepro.models.parameterized.ParameterizedModel`; absent for a plain model)
_THETA_ARG = {"sample_transition": 2, "f": 2, "jacobian_f": 2}


def _lead(x) -> tuple:
    shape = np.shape(x)
    return tuple(shape[:-1]) if len(shape) >= 1 else ()


def _n_states(x, theta=None) -> int:
    """States passed through one call: ``prod(x.shape[:-1])``, broadcast against the parameter's
    leading axes when a parameter array is given (one model evaluation per state × parameter pair)."""
    lead = _lead(x)
    if theta is not None:
        lead = np.broadcast_shapes(lead, _lead(theta))
    return int(math.prod(lead))


class CountingModel:
    """Proxy around a state-space model that counts the states passed through each method.

    Every attribute is the wrapped model's; the methods in :data:`COUNTED` are
    wrapped so that each call adds ``prod(x.shape[:-1])`` to ``counts[column]``.
    """

    def __init__(self, model):
        object.__setattr__(self, "_model", model)
        object.__setattr__(self, "counts", {c: 0 for c in COUNTED.values()})

    def __getattr__(self, name):
        attr = getattr(self._model, name)
        if name == "models" and isinstance(attr, (list, tuple)):
            # a jump-Markov system's mode models: their calls count into the same columns
            return [_SharedCounter(m, self.counts) for m in attr]
        if name not in COUNTED:
            return attr
        column, pos, kw = COUNTED[name], _STATE_ARG[name], _STATE_KW[name]
        tpos = _THETA_ARG.get(name)
        counts = self.counts

        def counted(*args, **kwargs):
            x = kwargs[kw] if kw in kwargs else args[pos]
            theta = None
            if tpos is not None:   # a parameterised model's call f(x, k, theta): count x × theta
                theta = kwargs["theta"] if "theta" in kwargs else (args[tpos] if len(args) > tpos else None)
                if theta is not None and not isinstance(theta, np.ndarray):
                    theta = None if np.ndim(theta) == 0 else np.asarray(theta)
            counts[column] += _n_states(x, theta)
            return attr(*args, **kwargs)

        return counted

    def __setattr__(self, name, value):
        setattr(self._model, name, value)

    def __repr__(self) -> str:
        return f"CountingModel({self._model!r})"


class _SharedCounter(CountingModel):
    """A :class:`CountingModel` that adds to another proxy's ``counts`` (a mode model of a system)."""

    def __init__(self, model, counts):
        object.__setattr__(self, "_model", model)
        object.__setattr__(self, "counts", counts)


@contextmanager
def _count_flow(counter: dict):
    """Count states per flow-field evaluation while the block runs (restores on exit)."""
    original = _flow.integrate_flow

    def integrate_flow(x, field, grid, method="euler"):
        def counted_field(z, lam):
            counter["flow"] += _n_states(z)
            counter["flow_calls"] += 1
            return field(z, lam)

        return original(x, counted_field, grid, method)

    _flow.integrate_flow = integrate_flow
    try:
        yield
    finally:
        _flow.integrate_flow = original


def _with_model(filt, proxy):
    """A shallow copy of ``filt`` whose model is ``proxy`` (the filter itself is untouched)."""
    if hasattr(filt, "model") or hasattr(filt, "system"):
        c = copy.copy(filt)
        if hasattr(filt, "model"):
            c.model = proxy
        if hasattr(filt, "system"):       # a jump-Markov filter reads its system, not .model
            c.system = proxy
        if hasattr(filt, "mode_filters"):  # an IMM Kalman filter: each mode filter's model counts too
            c.mode_filters = [_with_model(f, _SharedCounter(_model_of(f), proxy.counts)) for f in filt.mode_filters]
        return c
    if hasattr(filt, "filt"):  # thin wrappers (e.g. a filter timed with a precomputed carrier)
        c = copy.copy(filt)
        c.filt = _with_model(filt.filt, proxy)
        return c
    raise TypeError(f"cannot count the model calls of {type(filt).__name__}: it has no .model")


def _model_of(filt):
    if hasattr(filt, "model"):
        return filt.model
    if hasattr(filt, "system"):
        return filt.system
    if hasattr(filt, "filt"):
        return _model_of(filt.filt)
    raise TypeError(f"{type(filt).__name__} has no .model")


def count_model_calls(filt, y, rng=None, **filter_kw) -> dict:
    """Run ``filt.filter(y, rng=rng)`` once with a counting proxy around its model.

    Returns a dict with the six counted columns, ``model_evaluations`` (their sum),
    ``flow`` (states moved per flow-field evaluation, summed) and the algorithm *as printed*:
    ``flow_calls`` (flow-field evaluations: lambda steps times integrator stages),
    ``flow_printed`` (``flow_calls * n_particles``: every particle moved at every stage, as
    the paper's algorithm does, even where an implementation moves only probe points),
    ``resampled`` (particles copied by resampling: ``n_particles`` per resampling event in
    the filter's ``resampled`` diagnostics) and ``printed_operations`` (model evaluations +
    ``flow_printed`` + ``resampled``). ``rng``: a Generator
    (default: ``numpy.random.default_rng(0)``); the counts of the filters in this book
    do not depend on it except through data-dependent control flow (e.g. a diverged
    run that is dropped), which the fixed default makes reproducible.
    """
    proxy = CountingModel(_model_of(filt))
    counted = _with_model(filt, proxy)
    flow_counter = {"flow": 0, "flow_calls": 0}
    rng = np.random.default_rng(0) if rng is None else rng
    with _count_flow(flow_counter):
        result = counted.filter(y, rng=rng, **filter_kw)
    out = dict(proxy.counts)
    out["model_evaluations"] = sum(proxy.counts.values())
    out["flow"] = flow_counter["flow"]
    n_particles = int(getattr(filt, "n_particles", 0) or 0)
    runs = int(np.shape(y)[0]) if np.ndim(y) == 3 else 1
    out["flow_calls"] = flow_counter["flow_calls"]
    out["flow_printed"] = flow_counter["flow_calls"] * n_particles * runs
    diag = getattr(result, "diagnostics", None) or {}
    resampled = diag.get("resampled") if isinstance(diag, dict) else None
    out["resampled"] = int(np.sum(resampled)) * n_particles if resampled is not None else 0
    out["printed_operations"] = out["model_evaluations"] + out["flow_printed"] + out["resampled"]
    return out


def cost_counts(filters: dict, y_one_run, rng_seed: int = 0) -> pd.DataFrame:
    """:func:`count_model_calls` of every filter on the same run; one row per filter.

    ``y_one_run``: measurements ``(1, T, dim_y)`` (one run). Columns
    :data:`COUNT_COLUMNS` (totals over the run) plus ``per step`` (model evaluations
    divided by T).
    """
    y = np.asarray(y_one_run, dtype=float)
    if y.ndim != 3 or y.shape[0] != 1:
        raise ValueError(f"y_one_run must be one run, shape (1, T, dim_y); got {y.shape}")
    rows = {name: count_model_calls(f, y, np.random.default_rng(rng_seed)) for name, f in filters.items()}
    df = pd.DataFrame(rows).T[COUNT_COLUMNS + PRINTED_COLUMNS].astype(np.int64)
    df["per step"] = df["model_evaluations"] / y.shape[1]
    df.index.name = "filter"
    return df


# --------------------------------------------------------------------------------- timing
def time_repeats(filters: dict, y_one_run, rng_seed: int = 0, repeats: int = 7, *,
                 warmup: bool = True) -> pd.DataFrame:
    """Single-run wall times of every filter, ``repeats`` interleaved repeats; all repeats returned.

    Returns a DataFrame (rows: repeat 0..repeats-1, columns: filters) of seconds. One
    untimed warm-up call per filter first (``warmup``); repeat r uses the seed
    ``rng_seed + r`` for every filter; the garbage collector is paused in each call.
    """
    times = time_filter_repeats(filters, y_one_run, rng_seed, repeats, warmup=warmup)
    return pd.DataFrame(times, index=pd.RangeIndex(len(next(iter(times.values()), [])), name="repeat"))


def median_interval(values) -> tuple[float, float, float]:
    """(median, min, max) of a sample: the median with its range over repeats."""
    v = np.asarray(values, dtype=float).ravel()
    if v.size == 0 or not np.all(np.isfinite(v)):
        raise ValueError("median_interval needs finite values")
    return float(np.median(v)), float(v.min()), float(v.max())


def time_summary(times: pd.DataFrame, reference: str | None = None) -> pd.DataFrame:
    """Median and [min, max] over repeats of each filter's time and, with ``reference``,
    of the per-repeat ratio time / time(reference) (ratios within one repeat share the
    machine's load of that moment)."""
    rows = {}
    for name in times.columns:
        med, lo, hi = median_interval(times[name])
        row = {"time median [s]": med, "time min [s]": lo, "time max [s]": hi}
        if reference is not None:
            rmed, rlo, rhi = median_interval(times[name] / times[reference])
            row.update({"ratio median": rmed, "ratio min": rlo, "ratio max": rhi})
        rows[name] = row
    df = pd.DataFrame(rows).T
    df.index.name = "filter"
    return df


#: column of a ``benchmarks/bench_all.py`` table: a filter's batched ns per counted model
#: evaluation divided by the bootstrap PF's on the filter's own model
SAME_MODEL_RATIO = "time/count vs same-model PF (batched)"
#: the same ratio against the bootstrap PF on the filter's own model with the filter's particle count
SAME_N_RATIO = "time/count vs same-model PF, same N (batched)"
#: the same ratio against the bootstrap PF on the scalar growth model (UNGM)
UNGM_RATIO = "time/count vs PF (batched)"


def repeat_range_columns(ratio: str) -> tuple:
    """The columns of a benchmark table holding the lowest and the highest of a ratio over the
    benchmark's repeats (each repeat's filter time divided by the reference PF's of the same repeat)."""
    return f"{ratio}, lowest repeat", f"{ratio}, highest repeat"


def count_predicted(bench: pd.DataFrame, limit: float = 2.0) -> pd.DataFrame:
    """The particle filters of a benchmark table and whether each costs what its count predicts.

    The count (:func:`count_model_calls`) is a unit-cost model: every state passed through the
    model costs one evaluation. What one evaluation costs depends on the model (a bearings-only
    evaluation is a 4-D state with two ``arctan2`` and an angle wrap, a growth-model one is a
    scalar and a cosine), so a filter's count predicts its time relative to the bootstrap PF on
    the *same* model: the ratio :data:`SAME_MODEL_RATIO`, batched over runs as every experiment
    runs. A filter is within its count when that ratio is at most ``limit``; the ratio against
    the growth-model PF (:data:`UNGM_RATIO`) is returned beside it, and, where the table has it,
    the ratio against the same-model PF with the filter's own particle count
    (:data:`SAME_N_RATIO`): a run's step has work that does not grow with N (a random-generator
    call per run, numpy's fixed cost per call), which weighs more per evaluation at N = 100 than
    at N = 1000, in the bootstrap PF as in any filter.

    Parameters
    ----------
    bench : pandas.DataFrame
        A table written by ``benchmarks/bench_all.py``: one row per filter (index), with the
        columns ``particles``, :data:`SAME_MODEL_RATIO` and :data:`UNGM_RATIO`, and optionally
        ``particle filter`` (a boolean that leaves out reference rows); without it, every row
        with a particle count is a particle filter.
    limit : float, optional
        The largest ratio that counts as within (2: the issue's and the chapter's rule).

    Returns
    -------
    pandas.DataFrame
        One row per particle filter: ``same model`` and ``UNGM`` (the two ratios), ``within``
        (same-model ratio <= ``limit``) and ``within vs UNGM``; with :data:`SAME_N_RATIO` in the
        table also ``same N`` and ``within at the same N``. Where the table has a ratio's range
        over the benchmark's repeats (:func:`repeat_range_columns`), also ``within in every
        repeat`` (its highest <= ``limit``) and ``over in every repeat`` (its lowest > ``limit``),
        and for the same-N ratio ``within in every repeat at the same N`` and ``over in every
        repeat at the same N``; a filter in neither is at the edge.

    Raises
    ------
    ValueError
        If a column is missing, ``limit`` is not a positive number, or a particle filter has
        no same-model ratio.
    """
    if not (isinstance(limit, (int, float)) and math.isfinite(limit) and limit > 0):
        raise ValueError(f"limit must be a positive number, got {limit!r}")
    missing = [c for c in ("particles", SAME_MODEL_RATIO, UNGM_RATIO) if c not in bench.columns]
    if missing:
        raise ValueError(f"the benchmark table has no column(s) {missing}")
    is_pf = (bench["particle filter"].astype(bool) if "particle filter" in bench.columns
             else bench["particles"].notna())
    rows = bench.loc[is_pf]
    same = rows[SAME_MODEL_RATIO].astype(float)
    if same.isna().any():
        raise ValueError(f"particle filters without a same-model ratio: {list(same.index[same.isna()])}")
    ungm = rows[UNGM_RATIO].astype(float)
    out = pd.DataFrame({"same model": same, "UNGM": ungm, "within": same <= limit, "within vs UNGM": ungm <= limit},
                       index=rows.index)
    if SAME_N_RATIO in bench.columns:
        same_n = rows[SAME_N_RATIO].astype(float)
        out["same N"] = same_n
        out["within at the same N"] = same_n <= limit
    # the ratio's range over the repeats, where the table has it: within (or over) in every repeat,
    # or at the edge -- a count of filters within the limit that a rerun cannot flip
    for ratio, label in ((SAME_MODEL_RATIO, ""), (SAME_N_RATIO, " at the same N")):
        low, high = repeat_range_columns(ratio)
        if low in bench.columns and high in bench.columns:
            out["within in every repeat" + label] = rows[high].astype(float) <= limit
            out["over in every repeat" + label] = rows[low].astype(float) > limit
    return out


def imm_evaluations(result, n_particles: int, r: int = 3) -> np.ndarray:
    """Deterministic cost per run of an IMM particle filter (``pfrepro.filters.imm``), in model evaluations.

    r N state transitions per step (one per particle and mode) plus the likelihood evaluations
    and, for IMMPFOR, the density evaluations of eq 25, both from the filter's diagnostics
    (``likelihood_evals``, ``density_evals``). The one count behind the IMM chapter's equal-compute
    particle number and the synthesis chapter's cost column.

    Parameters
    ----------
    result : FilterResult
        Output of ``IMMParticleFilter.filter`` or ``IMMPFOR.filter`` (``x`` of shape (runs, T, n)).
    n_particles : int
        N per mode of that filter.
    r : int, optional
        Number of modes.

    Returns
    -------
    numpy.ndarray
        (runs,) evaluations per run over the whole horizon.
    """
    d = result.diagnostics
    T = np.asarray(result.x).shape[1]
    lik = np.asarray(d["likelihood_evals"], float)
    den = np.asarray(d.get("density_evals", np.zeros_like(lik)), float)
    return r * n_particles * T + lik + den


def smc2_evaluations(result, n_theta: int, n_x: int) -> np.ndarray:
    """Deterministic cost per run of :class:`~pfrepro.filters.smc2.SMC2`, in model evaluations.

    Every PF step of every θ-particle draws N_x transitions and evaluates N_x likelihoods; the
    filter makes T such steps plus ``pmmh_steps`` (its diagnostic: the PF steps rerun by the
    particle-marginal Metropolis-Hastings moves, which depend on the data), so a run costs
    2 M N_x (T + pmmh_steps): what :func:`count_model_calls` counts on that run, for every run
    at once (the count varies from run to run, unlike the other filters').

    Parameters
    ----------
    result : FilterResult
        Output of ``SMC2.filter`` (``x`` of shape (runs, T, n)).
    n_theta, n_x : int
        M and N_x of that filter.

    Returns
    -------
    numpy.ndarray
        (runs,) evaluations per run over the whole horizon.
    """
    T = np.asarray(result.x).shape[1]
    pmmh = np.asarray(result.diagnostics["pmmh_steps"], float)
    return 2.0 * n_theta * n_x * (T + pmmh)
