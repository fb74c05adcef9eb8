"""Each paper's method against today's methods on the paper's own benchmark.

The section "Against today's methods" at the end of each paper chapter: a small, paired
comparison on the first runs of the chapter's own truths (its seed, its per-run streams), the
paper's method at the paper's N against today's methods (:mod:`pfrepro.filters`: auxiliary,
regularised, EKF-proposal and particle-flow particle filters; SMC²; the jump-Markov PF) at the
same N with their defaults. Few runs (:data:`RUNS`, stated in the chapters), so the chapters run
it within seconds; the synthesis chapter has every method on 100 runs at equal budget.

Decision: per today's method, the paired per-run difference MSE(method) - MSE(paper's method),
two-sided z test, Holm over today's methods of that benchmark (:func:`pfrepro.stats.holm`,
family-wise ``ALPHA``): "better" / "worse" than the paper's method, or "no difference shown".
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from ..cost import cost_counts, smc2_evaluations
from ..filters import (AuxiliaryParticleFilter, GaussianProposalParticleFilter, JumpMarkovParticleFilter,
                       ParticleFlowParticleFilter, RegularizedParticleFilter, SMC2)
from ..metrics import mse
from ..montecarlo import run_monte_carlo

__all__ = ["RUNS", "ALPHA", "PAPERS", "spec", "against_today", "sentence", "styled", "theta_mse"]

#: runs per paper (the first runs of the chapter's truths); small so that each chapter's section stays
#: within seconds; BOT, the θ benchmark and the IMM scenario are the dearest per run
RUNS = {"gpff_zhang2016": 20, "ekf_pf_li2012": 30, "cmspf_ning2011": 50, "dpf_hou2008": 20, "immpfor_zhou2017": 20}
#: family-wise error rate over today's methods against the paper's method (Holm)
ALPHA = 0.05
PAPERS = tuple(RUNS)


def _today_pf(model, N: int) -> dict:
    return {f"APF({N})": AuxiliaryParticleFilter(model, N), f"RPF({N})": RegularizedParticleFilter(model, N),
            f"EKF-prop. PF({N})": GaussianProposalParticleFilter(model, N),
            f"PFPF-EDH({N})": ParticleFlowParticleFilter(model, N, flow="edh")}


def spec(paper: str) -> dict:
    """Benchmark of ``paper``: model, T, seed, the paper's method(s), today's methods, exact reference, error."""
    from . import cmspf_ning2011 as CMS
    from . import dpf_hou2008 as DPF
    from . import ekf_pf_li2012 as LI
    from . import gpff_zhang2016 as GPFF
    from . import immpfor_zhou2017 as IMM
    from .synthesis import JMPF_N, SMC2_SIZE

    if paper == "gpff_zhang2016":
        m = GPFF.BearingsOnly.zhang2016()
        return dict(title="bearings-only tracking (sec 5.3, Table 2)", model=m, T=200, seed=GPFF.SEEDS["bot"],
                    paper={"GPFF(100)": GPFF.bot_table_filters(m)["GPFF(100)"]}, today=_today_pf(m, 100),
                    reference=None, error="x")
    if paper == "ekf_pf_li2012":
        m = LI.make_model(1)
        f = LI.make_filters(m, ("PF", "Exact"))
        N = LI.N_PARTICLES
        return dict(title="UNGM model 1 (Table 1)", model=m, T=LI.T, seed=LI.SEED_TABLE,
                    paper={f"PF({N})": f["PF"]}, today=_today_pf(m, N), reference=("exact", f["Exact"]), error="x")
    if paper == "cmspf_ning2011":
        m = CMS.model()
        N = CMS.ASSUMPTIONS["N_table2"]
        return dict(title="UNGM (Table 2)", model=m, T=CMS.T, seed=CMS.SEEDS["table2"],
                    paper={f"CMS-PF({N})": CMS.cms(m, N)}, today=_today_pf(m, N), reference=("exact", CMS.grid(m)),
                    error="x")
    if paper == "dpf_hou2008":
        m = DPF.model_51()
        M, Nx = SMC2_SIZE
        return dict(title="UNGM with unknown θ (sec 5.1)", model=m, T=DPF.S51["T"], seed=DPF.SEED_51,
                    paper={f"DPF({DPF.S51['n_x']}+{DPF.S51['n_theta']})": DPF.dpf_51(m)},
                    today={f"SMC²({M}×{Nx})": SMC2(m, M, Nx)}, reference=("exact θ", DPF.grid_51(m)), error="theta")
    if paper == "immpfor_zhou2017":
        n = IMM.SCENARIO["N"]
        return dict(title="manoeuvring target (Table 1 scenario)", model=IMM.truth_system(),
                    T=IMM.SCENARIO["duration"], seed=IMM.SEEDS["main"],
                    paper={f"IMMPFOR({n})": IMM.immpfor(N=n)},
                    today={f"JMPF({JMPF_N})": JumpMarkovParticleFilter(IMM.filter_system(), JMPF_N)},
                    reference=None, error="position")
    raise ValueError(f"unknown paper {paper!r}; choose from {PAPERS}")


def _err(sp, mc, res):
    if sp["error"] == "theta":
        from .dpf_hou2008 import S51

        return np.mean((np.asarray(res.diagnostics["theta"], float) - S51["theta_true"]) ** 2, axis=1)
    if sp["error"] == "position":
        from .immpfor_zhou2017 import errors

        e = errors(mc.x_true, res.x)
        return np.mean(e * e, axis=1)
    return mse(mc.x_true, res.x)


def against_today(paper: str, runs: int | None = None, *, executor=None, given: dict | None = None,
                  y_check=None) -> dict:
    """Run the paper's method, today's methods and the exact reference (where there is one) on the first
    ``runs`` truths of the paper chapter's seed; return ``table`` (one row per method), ``best`` (today's
    method with the least mean MSE), ``runs`` and the spec's ``title``.

    ``given``: {name: per-run error over (at least) the same first runs} for the paper's method or the
    reference when the chapter already has them on its truths (not rerun; its cost is still counted on
    run 0), or {name: (per-run error, model evaluations per step)} for a filter the proxy cannot count
    (the IMM particle filters: :func:`pfrepro.cost.imm_evaluations`). ``y_check``: the chapter's
    measurements of (at least) these runs; they must equal the ones simulated here (same truths).
    Costs: :func:`pfrepro.cost.cost_counts` on run 0 (SMC²: its exact per-run count, mean over the runs)."""
    sp = spec(paper)
    runs = RUNS[paper] if runs is None else int(runs)
    given = given or {}
    every = {**sp["paper"], **sp["today"]}
    if sp["reference"] is not None:
        every[sp["reference"][0]] = sp["reference"][1]
    filters = {k: f for k, f in every.items() if k not in given}
    mc = run_monte_carlo(sp["model"], filters, sp["T"], runs, sp["seed"], executor=executor, progress=False,
                         chunks=None if executor is None else 2)
    if y_check is not None and not np.array_equal(np.asarray(y_check)[:runs], mc.sim.y):
        raise ValueError(f"{paper}: the chapter's measurements are not this benchmark's first {runs} runs")
    err = {k: _err(sp, mc, r) for k, r in mc.results.items()}
    cost = {}
    for k, v in given.items():
        e, c = v if isinstance(v, tuple) else (v, None)
        err[k] = np.asarray(e, float)[:runs]
        if c is not None:
            cost[k] = float(c)
    for k, f in filters.items():
        if isinstance(f, SMC2):
            cost[k] = float(np.mean(smc2_evaluations(mc.results[k], f.n_theta, f.n_x))) / sp["T"]
    counted = {k: f for k, f in every.items() if k not in cost and
               (sp["reference"] is None or k != sp["reference"][0])}
    steps = min(100, sp["T"])
    if counted:
        cc = cost_counts(counted, mc.sim.y[:1, :steps], rng_seed=sp["seed"])
        cost.update({k: float(cc.loc[k, "model_evaluations"]) / steps for k in counted})
    from ..stats import holm, p_two_sided

    (pname,) = list(sp["paper"])
    base = err[pname]
    ref = err[sp["reference"][0]] if sp["reference"] is not None else None
    rows, ps = [], []
    for k in [pname, *sp["today"]]:
        e = err[k]
        ok = np.isfinite(e).all()
        row = {"method": k, "evals/step": cost[k], "MSE": float(np.mean(e)) if ok else np.nan,
               "SE": float(np.std(e, ddof=1) / math.sqrt(runs)) if ok else np.nan, "diverged": int((~np.isfinite(e)).sum())}
        if ref is not None:
            row["MSE / exact"] = row["MSE"] / float(np.mean(ref))
        if k != pname:
            dd = e - base
            d, se = (float(dd.mean()), float(dd.std(ddof=1) / math.sqrt(runs))) if ok else (np.nan, np.nan)
            row.update({"minus paper": d, "± SE": se, "z": d / se if ok and se > 0 else np.nan})
            ps.append(p_two_sided(d, se) if ok else np.nan)
        rows.append(row)
    rej = holm(ps, ALPHA) if ps else np.zeros(0, bool)
    words = [""]
    for row, sig in zip(rows[1:], rej):
        if not np.isfinite(row["MSE"]):
            words.append("diverged")
        else:
            words.append(("worse" if row["minus paper"] > 0 else "better") if sig else "no difference shown")
    tab = pd.DataFrame(rows).set_index("method")
    tab["vs paper's (Holm)"] = words
    today_ok = tab.iloc[1:][np.isfinite(tab.iloc[1:]["MSE"])]
    best = today_ok["MSE"].idxmin() if len(today_ok) else None
    return {"table": tab, "paper_method": pname, "best": best, "runs": runs, "title": sp["title"],
            "reference": None if sp["reference"] is None else sp["reference"][0], "error": sp["error"]}


def sentence(out: dict) -> str:
    """One sentence of conclusion for the chapter, from :func:`against_today`'s result."""
    tab, p, b = out["table"], out["paper_method"], out["best"]
    unit = {"x": "MSE", "theta": "θ-MSE", "position": "position MSE (m²)"}[out["error"]]
    if b is None:
        return f"Every one of today's methods diverged on these {out['runs']} runs."
    r = tab.loc[b]
    word = r["vs paper's (Holm)"]
    rel = {"better": "better than", "worse": "worse than", "no difference shown": "not shown to differ from"}[word]
    ex = (f" ({r['MSE / exact']:.2f} against {tab.loc[p, 'MSE / exact']:.2f} times the exact {unit})"
          if "MSE / exact" in tab.columns else "")
    return (f"On the first {out['runs']} runs of this chapter's truths, the best of today's methods at the paper's N, "
            f"{b}, has {unit} {r['MSE']:.3g} against {tab.loc[p, 'MSE']:.3g} for {p}{ex}: {rel} the paper's method "
            f"(paired difference {r['minus paper']:+.3g} ± {r['± SE']:.2g}, z = {r['z']:.1f}; Holm over today's methods).")


def styled(out: dict):
    """The chapter's table: MSE ± SE, relative to the exact filter where there is one, the paired
    difference to the paper's method and the Holm decision."""
    tab = out["table"].copy()
    unit = {"x": "MSE", "theta": "θ-MSE", "position": "position MSE (m²)"}[out["error"]]
    show = pd.DataFrame(index=tab.index)
    show.index.name = "method"
    show["model evaluations per step"] = tab["evals/step"].map(lambda v: f"{v:.0f}")
    show[f"{unit} (± SE)"] = [f"{m:.3g} ± {s:.2g}" if np.isfinite(m) else "diverged"
                             for m, s in zip(tab["MSE"], tab["SE"])]
    if "MSE / exact" in tab.columns:
        show[f"{unit} / exact"] = tab["MSE / exact"].map(lambda v: f"{v:.3g}" if np.isfinite(v) else "–")
    show["minus the paper's method (± SE)"] = [f"{d:+.3g} ± {s:.2g}" if np.isfinite(d) else "–"
                                              for d, s in zip(tab["minus paper"], tab["± SE"])]
    show["z of the difference"] = tab["z"].map(lambda v: f"{v:+.1f}" if np.isfinite(v) else "–")
    show["against the paper's method"] = tab["vs paper's (Holm)"]
    return show.style.set_table_attributes('class="pf-text pf-scroll-phone"').set_caption(
        f"{out['title']}: the paper's method (first row) and today's methods at the paper's N, on the first "
        f"{out['runs']} runs of this chapter's truths; model evaluations per step (pfrepro.cost), mean ± SE over "
        f"the runs, paired difference to the paper's method (negative: today's method better), Holm over today's methods.")


def theta_mse(result) -> np.ndarray:
    """Per-run θ-MSE of a result with a ``theta`` diagnostic (the θ benchmark's error)."""
    from .dpf_hou2008 import S51

    return np.mean((np.asarray(result.diagnostics["theta"], float) - S51["theta_true"]) ** 2, axis=1)
