"""Every filter of the package on its paper's model: wall time beside operation count.

For each configuration it measures

* ``single``: one run, seconds per time step (median of interleaved repeats), and
* ``batched``: ``--runs`` runs in one call, seconds per time step per run,

and divides by the particle count (ns per particle-step; the Kalman family per step), then
sets the time beside the deterministic operation count of :func:`pfrepro.cost.count_model_calls`
(model evaluations per step: transitions, likelihoods, f, h, Jacobians, flow moves). The
*time/count ratio* of a filter is its single-run ns per model evaluation divided by the
bootstrap PF's on the same model (1 = the filter's wall time is what its count predicts;
> 2 = an outlier to profile or explain). A table goes to ``benchmarks/results/bench_all.md``
and ``.csv`` with the machine's description and the date.

Run from the repository root with the project's environment active::

    python benchmarks/bench_all.py                 # all filters, a few minutes on 2 cores
    python benchmarks/bench_all.py --quick         # fewer repeats and steps
    python benchmarks/bench_all.py --only GPFF     # configurations whose name contains GPFF
    python benchmarks/bench_all.py --only APF,RPF  # ... any of these

It is a script, not a test: the book does not rerun it (the filters chapter shows the saved
CSV with its date and machine).
"""
from __future__ import annotations

import argparse
import datetime as _dt
import gc
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from pfrepro.cost import SAME_MODEL_RATIO, SAME_N_RATIO, UNGM_RATIO, count_model_calls, repeat_range_columns
from pfrepro.montecarlo import filter_streams, truth_streams

RESULTS = Path(__file__).resolve().parent / "results"
ROOT = Path(__file__).resolve().parent.parent
#: the copy the book shows (committed; the book never reruns the benchmark)
BOOK_CSV = ROOT / "book" / "data" / "bench_all.csv"


# ----------------------------------------------------------------------------- configurations
def configurations():
    """(name, family, model_key, N or None, builder(model)) for every filter of the package."""
    from pfrepro import filters as F
    from pfrepro.filters.auxiliary import AuxiliaryParticleFilter
    from pfrepro.filters.gaussian_proposal import GaussianProposalParticleFilter
    from pfrepro.filters.jump_markov_pf import JumpMarkovParticleFilter
    from pfrepro.filters.pfpf import ParticleFlowParticleFilter
    from pfrepro.filters.regularized import RegularizedParticleFilter
    from pfrepro.filters.smc2 import SMC2
    from pfrepro.experiments import cmspf_ning2011 as CMS
    from pfrepro.experiments import dpf_hou2008 as DPF
    from pfrepro.experiments import immpfor_zhou2017 as IMM

    c = []
    add = lambda name, fam, key, N, build: c.append((name, fam, key, N, build))  # noqa: E731
    # Kalman family (per step)
    add("KF (CWPA)", "Kalman", "cwpa", None, lambda m: F.KalmanFilter(m))
    add("EKF (BOT)", "Kalman", "bot", None, lambda m: F.ExtendedKalmanFilter(m))
    add("UKF (BOT)", "Kalman", "bot", None, lambda m: F.UnscentedKalmanFilter(m))
    add("IMM-EKF", "Kalman", "imm", None, lambda s: IMM.imm_ekf())
    # bootstrap PF, every scheme (the reference of each model)
    for scheme in ("systematic", "stratified", "multinomial", "residual"):
        add(f"PF {scheme} (UNGM)", "PF", "ung", 1000, lambda m, s=scheme: F.BootstrapParticleFilter(m, 1000, resampling=s))
    add("PF systematic (BOT)", "PF", "bot", 1000, lambda m: F.BootstrapParticleFilter(m, 1000))
    add("PF systematic (UNGM Ning)", "PF", "ung_ning", 200, lambda m: F.BootstrapParticleFilter(m, 200))
    # the IMM scenario's reference: a bootstrap PF on its first mode model (CV, the same measurement
    # model), N = 1500 as the IMM particle filters' 3 x 500 -- what an evaluation of this model costs
    add("PF systematic (IMM, CV mode)", "PF", "imm", 1500, lambda s: F.BootstrapParticleFilter(s.models[0], 1500))
    # the same PF at N = 100, the particle count of the GPFF and LEDH rows: what an evaluation costs when
    # the fixed work of a run's step (a generator call per run, numpy's cost per call) is spread over
    # 100 particles instead of 1000 (references, not among the 28)
    for key, label in (("ung", "UNGM"), ("bot", "BOT")):
        add(f"PF systematic ({label}, N = 100)", "PF", key, 100, lambda m: F.BootstrapParticleFilter(m, 100))
    # GPFF per field and integrator
    for field in ("eq41", "eq43"):
        for integ in ("euler", "midpoint", "rk4"):
            add(f"GPFF {field} {integ} (UNGM)", "GPFF", "ung", 100,
                lambda m, f=field, i=integ: F.GaussianParticleFlowFilter(m, 100, field=f, integrator=i,
                                                                         on_divergence="drop"))
    add("GPFF eq43 euler (BOT)", "GPFF", "bot", 100, lambda m: F.GaussianParticleFlowFilter(m, 100, on_divergence="drop"))
    add("GPFF(1000) eq43 euler (UNGM)", "GPFF", "ung", 1000,
        lambda m: F.GaussianParticleFlowFilter(m, 1000, on_divergence="drop"))
    # the papers' particle filters
    add("CMS-PF (UNGM Ning)", "CMS-PF", "ung_ning", 200, lambda m: CMS.cms(m, 200))
    add("ESPF (UNGM Ning)", "ESPF", "ung_ning", 200, lambda m: CMS.espf(m, 200))
    add("DPF (UNGM θ)", "DPF", "theta", None, lambda m: DPF.dpf_51(m))
    add("DEKF (UNGM θ)", "DPF", "theta", None, lambda m: DPF.dekf_51(m))
    add("Liu-West (UNGM θ)", "DPF", "theta", None, lambda m: DPF.liu_west_51(m))
    add("IMMPF(500)", "IMM", "imm", 500, lambda s: IMM.immpf(N=500))
    add("IMMPFOR(500)", "IMM", "imm", 500, lambda s: IMM.immpfor(N=500))
    # today's methods
    add("APF (UNGM)", "today", "ung", 1000, lambda m: AuxiliaryParticleFilter(m, 1000))
    add("RPF (UNGM)", "today", "ung", 1000, lambda m: RegularizedParticleFilter(m, 1000))
    add("EKF-proposal PF (BOT)", "today", "bot", 1000, lambda m: GaussianProposalParticleFilter(m, 1000))
    add("UT-proposal PF (BOT)", "today", "bot", 1000,
        lambda m: GaussianProposalParticleFilter(m, 1000, proposal="unscented"))
    add("PFPF(EDH) (BOT)", "today", "bot", 1000, lambda m: ParticleFlowParticleFilter(m, 1000, flow="edh"))
    add("PFPF(LEDH) (BOT)", "today", "bot", 100, lambda m: ParticleFlowParticleFilter(m, 100, flow="ledh"))
    add("JMPF (IMM)", "today", "imm", 1500, lambda s: JumpMarkovParticleFilter(IMM.filter_system(), 1500))
    add("SMC² 50x20 (UNGM θ)", "today", "theta", None, lambda m: SMC2(m, 50, 20))
    return c


def models():
    """The paper models by key (built lazily)."""
    from pfrepro.experiments import cmspf_ning2011 as CMS
    from pfrepro.experiments import dpf_hou2008 as DPF
    from pfrepro.experiments import immpfor_zhou2017 as IMM
    from pfrepro.models import CWPA, UNGM, BearingsOnly

    return {"ung": UNGM.zhang2016, "ung_ning": CMS.model, "bot": BearingsOnly.zhang2016,
            "cwpa": CWPA, "theta": DPF.model_51, "imm": IMM.filter_system}


def _particle_count(filt, N):
    """Particles per step the count is spread over (DPF: its n_x state and n_theta parameter
    particles; IMM: N per mode · modes)."""
    if N is not None:
        r = getattr(getattr(filt, "system", None), "r", None)
        return N * (r if r and type(filt).__name__.startswith("IMM") else 1)
    if hasattr(filt, "n_x") and hasattr(filt, "n_theta"):
        # SMC2: an x-filter of n_x particles per parameter particle; the dual PF: two sets side by side
        if type(filt).__name__ == "SMC2":
            return filt.n_x * filt.n_theta
        return filt.n_x + filt.n_theta
    return getattr(filt, "n_particles", None)


def _timed(filt, y, rng_seed, name):
    runs = y.shape[0]
    gc.collect()
    gc.disable()
    try:
        rng = filter_streams(rng_seed, name, runs)
        c0, t0 = time.process_time(), time.perf_counter()
        filt.filter(y, rng)
        return time.perf_counter() - t0, time.process_time() - c0
    finally:
        gc.enable()


def steady_heap() -> bool:
    """Tell glibc's allocator to keep what this process frees (``mallopt``: no trimming of the heap,
    blocks up to 32 MB from the heap instead of fresh mappings); ``False`` where the C library is
    not glibc. Without it, whether a filter's large temporaries come back as fresh pages (a page
    fault per 4 kB, every call) depends on the thresholds glibc adapts to what the process freed
    before: in one process the filters timed earlier set them, in a process of its own the filter's
    own sizes do, and the same code measured up to two fifths slower or faster between the two."""
    import ctypes
    import ctypes.util

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
    return bool(mallopt(M_TRIM_THRESHOLD, 2**30)) and bool(mallopt(M_MMAP_THRESHOLD, 32 * 2**20))


def _worker(conn, filt, y, seed, name, blas_threads):
    """One configuration's timing process: answers ``"single"`` / ``"batched"`` with (wall, CPU)
    of one call and ``"warm-up"`` with ``None`` once warm, until ``None``. A process of its own,
    so that the allocator's state (what the heap kept or gave back after other filters' calls, and
    the page faults that follow) is this filter's alone: a filter's time does not depend on which
    filters ran before it."""
    if blas_threads is not None:
        import threadpoolctl

        threadpoolctl.threadpool_limits(blas_threads, user_api="blas")
    while (what := conn.recv()) is not None:
        if what == "warm-up":
            # one call of each kind: the heap settles to this filter's own pattern of temporaries
            # (glibc raises its mmap threshold to the chunks a process frees), which every repeat meets
            _timed(filt, y[:1], seed, name)
            _timed(filt, y, seed, name)
            conn.send(None)
        else:
            conn.send(_timed(filt, y[:1] if what == "single" else y, seed, name))
    conn.close()


def measure(configs, T: int, runs: int, repeats: int, seed: int = 2026, blas_threads=None, isolate: bool = True):
    """Time every configuration: ``repeats`` interleaved rounds (every filter once per round, so a
    drift of the machine's load hits every filter alike), each filter in a worker process of its
    own (``isolate``; forked, so it holds the parent's filters and data, and the allocator settings
    of :func:`steady_heap` where the caller made them), warmed up one at a time and timed one call
    at a time."""
    import multiprocessing as mp

    built, keys = {}, {}
    mk = models()
    sims = {}
    rows = []
    for name, fam, key, N, build in configs:
        if key not in sims:
            m = mk[key]()
            sims[key] = (m, m.simulate(T, runs, truth_streams(seed, runs)))
        m, sim = sims[key]
        filt = build(m)
        built[name] = (filt, sim.y, fam, N)
        keys[name] = key
    single = {n: [] for n in built}
    batched = {n: [] for n in built}
    single_cpu = {n: [] for n in built}
    batched_cpu = {n: [] for n in built}
    if isolate:
        ctx = mp.get_context("fork")
        workers = {}
        for n, (filt, y, _, _) in built.items():
            here, there = ctx.Pipe()
            proc = ctx.Process(target=_worker, args=(there, filt, y, seed, n, blas_threads), daemon=True)
            proc.start()
            workers[n] = (here, proc)
        for here, _ in workers.values():            # one at a time: no worker runs beside a timed one
            here.send("warm-up")
            here.recv()

        def timed(n, what):
            workers[n][0].send(what)
            return workers[n][0].recv()
    else:
        for n, (filt, y, _, _) in built.items():        # warm-up
            _timed(filt, y[:1], seed, n)

        def timed(n, what):
            filt, y = built[n][:2]
            return _timed(filt, y[:1] if what == "single" else y, seed, n)
    try:
        for _ in range(repeats):
            for n in built:
                for store, cpu, what in ((single, single_cpu, "single"), (batched, batched_cpu, "batched")):
                    wall, c = timed(n, what)
                    store[n].append(wall)
                    cpu[n].append(c)
    finally:
        if isolate:
            for conn, proc in workers.values():
                conn.send(None)
                proc.join()
    for n, (filt, y, fam, N) in built.items():
        counts = count_model_calls(filt, y[:1])
        per_step = counts["model_evaluations"] / T
        P = _particle_count(filt, N)
        s = float(np.median(single[n])) / T
        b = float(np.median(batched[n])) / T / runs
        rows.append({"filter": n, "family": fam, "model": keys[n], "particles": P, "count per step": per_step,
                     "single s/step": s, "batched s/step/run": b,
                     "single CPU s/step": float(np.median(single_cpu[n])) / T,
                     "batched CPU s/step/run": float(np.median(batched_cpu[n])) / T / runs,
                     "single ns/particle-step": 1e9 * s / P if P else np.nan,
                     "batched ns/particle-step": 1e9 * b / P if P else np.nan,
                     "single ns/evaluation": 1e9 * s / per_step if per_step else np.nan,
                     "batched ns/evaluation": 1e9 * b / per_step if per_step else np.nan}
                    | {f"{REPEAT_COLUMN} {k}": t / T / runs for k, t in enumerate(batched[n], 1)})
    return derive(pd.DataFrame(rows).set_index("filter"))


#: the batched time of one repeat (``REPEAT_COLUMN k``, seconds per step and run): the ratios' range
REPEAT_COLUMN = "batched s/step/run, repeat"
#: rows that are yardsticks only, not among the particle filters the table judges
REFERENCE_ROWS = ("PF systematic (IMM, CV mode)", "PF systematic (UNGM, N = 100)", "PF systematic (BOT, N = 100)")

#: the models whose evaluation cost :func:`measure_models` compares (key, label)
MODEL_ROWS = (("ung", "scalar growth model (UNGM)"), ("ung_ning", "scalar growth model, Ning's noise"),
              ("bot", "bearings-only (4-D)"), ("imm", "manoeuvring target, CV mode (6-D)"))
#: where ``--book`` saves the per-model table
BOOK_MODELS_CSV = ROOT / "book" / "data" / "bench_models.csv"


def measure_models(runs: int = 100, N: int = 1000, repeats: int = 5, seed: int = 2026) -> pd.DataFrame:
    """What one model evaluation costs, model by model: CPU ns per state of a transition draw
    (``sample_transition`` on a ``(runs, N)`` cloud) and of a likelihood evaluation (``log_likelihood``), the median of ``repeats`` interleaved repeats.
    The count of :func:`pfrepro.cost.count_model_calls` counts each as one evaluation whatever the
    model; this table is what that unit costs, and why a filter's count is compared with the
    bootstrap PF on the filter's own model."""
    mk = models()
    rows, calls = {}, {}
    for key, label in MODEL_ROWS:
        m = mk[key]()
        if key == "imm":
            m = m.models[0]
        rng = filter_streams(seed, key, runs)
        x = m.sample_initial(rng, (runs, N))
        y = m.simulate(2, runs, truth_streams(seed, runs)).y[:, 0]
        calls[label] = {
            "transition": lambda m=m, x=x, rng=rng: m.sample_transition(x, 1, rng),
            "likelihood": lambda m=m, x=x, y=y: m.log_likelihood(y, x),
        }
        rows[label] = {"key": key, "state dimension": m.dim_x}
    times = {(lab, op): [] for lab in calls for op in calls[lab]}
    for _ in range(repeats + 1):                       # the first round warms up
        for lab, ops in calls.items():
            for op, f in ops.items():
                gc.collect()
                c0 = time.process_time()
                f()
                times[lab, op].append(time.process_time() - c0)
    for (lab, op), t in times.items():
        rows[lab][f"{op} ns/state"] = 1e9 * float(np.median(t[1:])) / (runs * N)
    df = pd.DataFrame(rows).T
    df = df.astype({c: int if c == "state dimension" else float for c in df.columns if c != "key"})
    df.index.name = "model"
    base = df.iloc[0]
    df["evaluation ns/state"] = (df["transition ns/state"] + df["likelihood ns/state"]) / 2
    df["vs growth model"] = df["evaluation ns/state"] / float(base["transition ns/state"] + base["likelihood ns/state"]) * 2
    return df


def _against_same_model(df: pd.DataFrame, val: pd.Series):
    """``val`` (ns per evaluation, one per row) divided by the bootstrap PF's on the row's own model,
    and (where the table has the particle counts) by that PF's with the row's own particle count
    (else the same-model PF's): the same-model and the same-N ratios (the second ``None`` without
    a ``particles`` column)."""
    is_pf = df.index.str.startswith("PF systematic")
    ref = {mkey: float(val[is_pf & (df["model"] == mkey)].iloc[0]) for mkey in df.loc[is_pf, "model"].unique()}
    base0 = float(val[is_pf].iloc[0]) if is_pf.any() else np.nan
    same = pd.Series([v / ref.get(mkey, base0) for v, mkey in zip(val, df["model"])], index=df.index)
    if "particles" not in df:
        return same, None
    # the bootstrap PF on the same model with the same particle count, where the table has one: the
    # fixed work of a run's step weighs alike in both, so the ratio is the count's prediction with
    # that work taken out (else the same-model PF)
    same_n = {(mkey, n): float(v) for mkey, n, v in zip(df.loc[is_pf, "model"], df.loc[is_pf, "particles"], val[is_pf])}
    return same, pd.Series([v / same_n.get((mkey, n), ref.get(mkey, base0))
                            for v, mkey, n in zip(val, df["model"], df["particles"])], index=df.index)


def derive(df: pd.DataFrame) -> pd.DataFrame:
    """The columns computed from the measured times and the counts: ns per evaluation and the
    time/count ratios against the bootstrap PF."""
    df = df.copy()
    per_step = df["count per step"].where(df["count per step"] > 0)
    df["single ns/evaluation"] = 1e9 * df["single s/step"] / per_step
    df["batched ns/evaluation"] = 1e9 * df["batched s/step/run"] / per_step
    ref = df.loc[df.index.str.startswith("PF systematic"), "single ns/evaluation"]
    base = float(ref.iloc[0]) if len(ref) else np.nan
    df["time/count vs PF (single)"] = df["single ns/evaluation"] / base
    refb = df.loc[df.index.str.startswith("PF systematic"), "batched ns/evaluation"]
    df[UNGM_RATIO] = df["batched ns/evaluation"] / float(refb.iloc[0]) if len(refb) else np.nan
    if "batched CPU s/step/run" in df:
        # the same ratio on CPU time: on a loaded machine (other processes on the cores) wall time
        # counts the waits, CPU time only this process's work
        cpu = 1e9 * df["batched CPU s/step/run"] / per_step
        refc = cpu[df.index.str.startswith("PF systematic")]
        df["time/count vs PF (batched, CPU)"] = cpu / float(refc.iloc[0]) if len(refc) else np.nan
    if "model" in df:
        # the count counts model evaluations, and an evaluation of one model costs what it costs
        # (the bearings-only h is two arctan2 and an angle wrap a particle, the UNGM's one cosine):
        # the count predicts a filter's time relative to the bootstrap PF on the SAME model, where
        # the table has one (else the first PF row, the UNGM's)
        df[SAME_MODEL_RATIO], same_n = _against_same_model(df, df["batched ns/evaluation"])
        if same_n is not None:
            df[SAME_N_RATIO] = same_n
        if "batched CPU s/step/run" in df:
            df["time/count vs same-model PF (batched, CPU)"] = _against_same_model(
                df, 1e9 * df["batched CPU s/step/run"] / per_step)[0]
        # the same ratios repeat by repeat (each against the reference PF of the same repeat, which ran
        # beside it: a drift of the load hits both), and their lowest and highest: a filter is within
        # its count in every repeat, over it in every repeat, or at the edge
        reps = sorted(int(c.rsplit(" ", 1)[1]) for c in df.columns if c.startswith(REPEAT_COLUMN))
        if reps:
            ratios = {SAME_MODEL_RATIO: [], SAME_N_RATIO: []}
            for r in reps:
                sm, sn = _against_same_model(df, 1e9 * df[f"{REPEAT_COLUMN} {r}"] / per_step)
                ratios[SAME_MODEL_RATIO].append(sm)
                if sn is not None:
                    ratios[SAME_N_RATIO].append(sn)
            for col, per_repeat in ratios.items():
                if per_repeat:
                    low, high = repeat_range_columns(col)
                    stacked = pd.concat(per_repeat, axis=1)
                    df[low], df[high] = stacked.min(axis=1), stacked.max(axis=1)
    return df


#: What the operation count does not see, by family: the reason a filter's time/count ratio
#: against the bootstrap PF exceeds 2 (written beside every such row of the table).
WHY = {
    "Kalman": "no particles: the count sees 2-4 model calls a step, the time is the filter's matrix "
              "algebra (gains, Cholesky factors, sigma points)",
    "GPFF": "nearly all of the counted evaluations are transitions, which on the growth model cost several "
            "times a likelihood evaluation (the bootstrap PF's count is half of each); and work a time step costs "
            "whatever N is, which at N = 100 the count (N transitions and 2d + 1 measurement calls) cannot "
            "spread: the transition's standard normals (as many as the bootstrap PF "
            "at N = 100 draws) are 35-42 % of a growth-model step and about a quarter of a bearings-only one; "
            "the rest is numpy calls on per-run arrays (the unscented transform, the flow's coefficients at "
            "every lambda and its map, the moments; on the bearings-only model also 20 checked Euler steps of "
            "the probes for the angle residual and about 4000 tiny matrix products a step)",
    "CMS-PF": "the partition of the 2N pool, the sort of the N weights that picks the big and small "
              "particles, and the chaotic carrier's burn-in (1000 iterations a chain) are work outside "
              "the model calls",
    "ESPF": "the filter makes six random draws a step per run (two normal, three uniform, one permutation: "
            "about a third of its step, against the bootstrap PF's two), and the fitness selection partitions "
            "the 3N pool, whose order every later sum keeps (a fifth of its step), outside the model calls",
    "DPF": "the parameter weights' Beta fits and the DEKF's augmented-state Jacobians are work "
           "outside the model calls",
    "IMM": "per mode: mixing, the per-mode likelihood normalisation and (IMMPFOR) the replacement's "
           "nearest-neighbour distances and joint whitening, outside the model calls",
    "today": "per-particle work the count does not see: a Jacobian or sigma-point set, a gain and a "
             "Cholesky factor for every particle (EKF/UKF proposal), N per-particle flows of 29 "
             "pseudo-time steps (LEDH), the flow's 29 n x n steps per run composed into one affine map "
             "(EDH), the kernel draw (RPF)",
    "PF": "work outside the model calls: the resampling scheme's own draws and search, numpy's fixed "
          "cost per step at small N",
}

#: A filter's own reason where it is not its family's (the first key its name starts with).
WHY_FILTER = {
    "PF multinomial": "the multinomial scheme sorts its N uniforms and binary-searches the cumulative "
                      "weights in them, run by run (about 40 % of its step), work outside the model calls",
    "IMMPFOR": "the replacement step (eqs 22-25, 40 % of its time: the joint whitening with the weighted and "
               "unweighted spreads of all 3 x 500 particles, the parents' nearest-neighbour steps over the 3 "
               "modes, the new particles' L z, the parent-slot draw) is work outside the model calls",
    "JMPF": "the mode draw, the sort of the particles by mode with its gathers and scatter, and the mode "
            "models' f (an einsum, several times slower than a matrix product, which keeps a run's numbers "
            "independent of the batch), outside the model calls",
}


def why(name: str, family: str) -> str:
    """The reason the count does not predict this filter's time: :data:`WHY_FILTER`, else :data:`WHY`."""
    for prefix, text in WHY_FILTER.items():
        if name.startswith(prefix):
            return text
    return WHY.get(family, "")


def recount(df: pd.DataFrame, T: int, seed: int = 2026) -> pd.DataFrame:
    """``df`` (a saved table) with its counts recomputed by today's :func:`pfrepro.cost.count_model_calls`
    on the same run 0 the measurement counted on, and the derived columns with them; the measured
    times are kept. (Counts are deterministic: they do not depend on the machine or its load.)"""
    mk = models()
    sims = {}
    out = df.copy()
    for name, fam, key, N, build in configurations():
        if name not in out.index:
            continue
        if key not in sims:
            m = mk[key]()
            sims[key] = (m, m.simulate(T, 1, truth_streams(seed, 1)))
        m, sim = sims[key]
        out.loc[name, "count per step"] = count_model_calls(build(m), sim.y[:1])["model_evaluations"] / T
    return annotate(derive(out.drop(columns=["why", "particle filter"], errors="ignore")))


#: Why an evaluation of the bearings-only or IMM model costs more than one of the UNGM: what every
#: filter on that model pays, and why the same-model column is the count's yardstick.
MODEL_COST = ("an evaluation of this model costs more than one of the scalar growth model's, which the count "
              "(one evaluation either way) does not see: a 4-D (bearings-only) or 6-D (manoeuvring target) "
              "state whose transition draws correlated noise through a matrix product, and a measurement with "
              "an arctan2 and an angle wrap (and, for the manoeuvring target, a range and a range rate); "
              "against the bootstrap PF on its own model the filter is within 2x of its count")
def annotate(df: pd.DataFrame, limit: float = 2.0) -> pd.DataFrame:
    """Add the ``particle filter`` and ``why`` columns.

    ``particle filter``: the rows :func:`pfrepro.cost.count_predicted` counts (particles, not the
    Kalman family, not the :data:`REFERENCE_ROWS`). ``why`` says, for a ratio above ``limit``,
    what the count does not see: :data:`WHY` of the family where the filter exceeds it against the
    bootstrap PF on its own model (the yardstick); :data:`MODEL_COST` where it is within it there but
    not against the growth-model PF. (A run alone pays numpy's fixed cost per call at every step,
    which a batch shares: the one-run ratios are in the table, without a note.)"""
    out = df.copy()
    out["particle filter"] = (out["particles"].notna() & (out["family"] != "Kalman")
                              & ~out.index.isin(REFERENCE_ROWS))
    nan = pd.Series(np.nan, index=out.index)
    same = out.get(SAME_MODEL_RATIO, nan)
    whys = []
    for name, fam, sm, b, one in zip(out.index, out["family"], same, out[UNGM_RATIO],
                                     out["time/count vs PF (single)"]):
        if fam == "Kalman" or sm > limit:
            whys.append(why(name, fam) if max(sm, b, one) > limit else "")
        elif b > limit and out.loc[name, "model"] in ("bot", "imm"):
            whys.append(MODEL_COST)
        else:
            whys.append("")
    out["why"] = whys
    return out


def machine() -> str:
    import threadpoolctl

    blas = [f"{i['internal_api']} {i['version']} ({i.get('architecture', '?')}, {i['num_threads']} threads)"
            for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"]
    try:
        load = os.getloadavg()[0]
    except OSError:
        load = float("nan")
    return (f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python "
            f"{platform.python_version()}, numpy {np.__version__}, BLAS {'; '.join(blas)}, "
            f"load average {load:.1f} at start, {_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M} UTC")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="T = 20, 2 repeats, 20 runs")
    ap.add_argument("--only", default="", help="configurations whose name contains this text (comma: any of them)")
    ap.add_argument("--T", type=int, default=50)
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=str(RESULTS / "bench_all"), help="path stem of the .md and .csv")
    ap.add_argument("--book", action="store_true",
                    help=f"also save the table and its machine line for the book ({BOOK_CSV.relative_to(ROOT)})")
    ap.add_argument("--blas-threads", type=int, default=None,
                    help="limit the BLAS thread pool (threadpoolctl) for the whole measurement; on a "
                         "machine whose cores other processes use, a threaded BLAS call over (runs x N) "
                         "rows waits for its threads and the wait is counted (default: BLAS's own)")
    ap.add_argument("--same-process", action="store_true",
                    help="time every filter in this process (the old way) instead of a worker process of its own")
    ap.add_argument("--recount", action="store_true",
                    help="recompute the counts (and the columns derived from them) of the book's saved table, "
                         "keeping its measured times; no timing is run")
    a = ap.parse_args(argv)
    if a.recount:
        meta = json.loads(BOOK_CSV.with_suffix(".json").read_text(encoding="utf-8"))
        df = recount(pd.read_csv(BOOK_CSV, index_col=0), int(meta["T"]))
        df.to_csv(BOOK_CSV, float_format="%.6g")
        meta["recounted"] = (f"counts recomputed {_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M} UTC "
                             "(times from the measurement above)")
        BOOK_CSV.with_suffix(".json").write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
        print(df[["count per step", "time/count vs PF (single)", "time/count vs PF (batched)"]].round(2).to_string())
        return 0
    T, runs, repeats = (20, 20, 2) if a.quick else (a.T, a.runs, a.repeats)
    only = a.only.split(",")
    configs = [c for c in configurations() if any(o in c[0] for o in only) or c[0].startswith("PF systematic")]
    info = machine()
    if a.blas_threads is not None:
        import threadpoolctl

        threadpoolctl.threadpool_limits(a.blas_threads, user_api="blas")
        info += f", BLAS limited to {a.blas_threads} thread(s) for the measurement"
    keeps_freed = False
    if not a.same_process:
        # set before the workers fork, which inherit it; the per-model table below is measured under it too
        keeps_freed = steady_heap()
        info += ", each filter timed in a process of its own" + (" whose allocator keeps what it frees"
                                                                 if keeps_freed else "")
    df = annotate(measure(configs, T, runs, repeats, blas_threads=a.blas_threads, isolate=not a.same_process))
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    df.to_csv(out.with_suffix(".csv"), float_format="%.6g")
    with open(out.with_suffix(".md"), "w", encoding="utf-8") as fh:
        fh.write(f"# Every filter: wall time beside operation count\n\nMachine: {info}.\n"
                 f"T = {T} steps, single run and {runs} runs batched, median of {repeats} interleaved repeats.\n\n")
        fh.write(df.round(3).to_markdown())
        fh.write("\n")
    per_model = measure_models(runs, 1000, max(repeats, 5))
    per_model.to_csv(out.with_name(out.name + "_models.csv"), float_format="%.6g")
    if a.book:
        if a.only or a.quick:
            ap.error("--book saves the full table only (no --only, no --quick)")
        BOOK_CSV.parent.mkdir(parents=True, exist_ok=True)
        df.to_csv(BOOK_CSV, float_format="%.6g")
        per_model.to_csv(BOOK_MODELS_CSV, float_format="%.6g")
        BOOK_CSV.with_suffix(".json").write_text(json.dumps(
            {"machine": info, "T": T, "runs": runs, "repeats": repeats, "blas_threads": a.blas_threads,
             "worker_processes": not a.same_process, "allocator_keeps_freed": keeps_freed,
             "script": "benchmarks/bench_all.py"}, indent=1) + "\n", encoding="utf-8")
    print(info)
    cols = ["count per step", "single ns/particle-step", "batched ns/particle-step",
            "time/count vs PF (single)", "time/count vs PF (batched)", "time/count vs PF (batched, CPU)"]
    print(df[[c for c in cols if c in df]].round(2).to_string())
    print(per_model.round(2).to_string())
    return 0


if __name__ == "__main__":
    sys.exit(main())
