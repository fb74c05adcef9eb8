"""Verdicts of the synthesis (``book/70_synthesis.md``, claims key ``synthesis``; not a paper): every
method of the book against the plain baseline at equal cost, decided from
:func:`pfrepro.experiments.synthesis.run_all`'s results.

Equal budget (:func:`equal_budget`): a method of cost B is compared with the baseline (bootstrap PF,
systematic resampling every step; Liu-West on ``theta_hou``; the IMMPF on ``imm_zhou``) whose cost is
B, on the same truths: per run, the baseline's MSE is interpolated linearly in log cost between the
two configurations of its efficient frontier that bracket B (:func:`efficient_frontier`,
:func:`pf_at_cost`), and the paired per-run difference MSE(baseline at B) - MSE(method), in units of the
reference's MSE, is judged by the book's rule (:func:`judge_equal_budget`,
:func:`pfrepro.claims.judge_ordering`): better at 2 SE, worse when reversed, a tie only when the interval lies inside the benchmark's smallest effect of
interest (:data:`pfrepro.experiments.synthesis.MARGIN`), else too few runs with the runs a plan needs.
Outside the baseline's range of costs the nearest configuration is used and only the conclusion that
survives the cost mismatch is kept (no extrapolation: the PF's frontier on BOT kept improving beyond the
last point where it had looked flat).

Claims (:func:`record_claims`): per paper's method and benchmark, the implicit claim of its paper,
"it is better than the plain filter", re-tested at equal budget on the count axis (model
evaluations per step, exact and load-independent), with the verdict of :func:`judge_equal_budget`.
On bearings-only the paper's own start is the one admissible reading: the start centred on the truth
is shown and not counted (``excluded``, :data:`pfrepro.experiments.synthesis.BOT_CENTRED_EXCLUDED`).
The wall-time reading is context in the chapter's tables, never in a claim. Plus Li 2012's "PF beats
EKF" at the paper's N, judged by the Li chapter's own function
(:func:`pfrepro.verdicts.ekf_pf_li2012.pf_beats_ekf`), so the two chapters carry one word.

Rankings (:func:`ranking`): within a benchmark every pair of methods is compared (paired
difference, two-sided z test), Holm over all pairs of that benchmark; a method's rank is 1 + the
number of methods significantly better than it (so "not shown different" is symmetric and no chaining
arises; it is not a tie within the margin, which the rankings do not test).
What to use (:func:`what_to_use`): per benchmark, the cheapest method whose error is shown within
:data:`USE_MARGIN` of every other method's (:func:`close_to_best`, an equivalence test), or none. The takeaway
(:func:`takeaway`) and the chapter's numbers and phrases (:func:`prose`) are generated from these.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from ..choices import over
from ..claims import CAUSE_COUNT, CAUSE_RUNS, CAUSE_TIE, Z_CRIT, ClaimsRegistry, Judgement, judge, judge_ordering
from ..experiments import synthesis as S
from ..experiments.synthesis import (ALPHA, BOT_CENTRED_EXCLUDED, BOT_REF_TOL, BOT_READINGS, MARGIN, PF_N,
                                     BenchResult, _cost, _frontier_names)
from ..experiments.synthesis import distance_table
from ..metrics import mse
from ..prose import Md, join_and, plural, verdict_sentence
from ..stats import holm, p_two_sided, plan_runs, ratio_of_means
from .ekf_pf_li2012 import pf_beats_ekf

__all__ = ["efficient_frontier", "pf_at_cost", "equal_budget", "judge_equal_budget", "WORDS", "plan_table", "ranking",
           "verdict_table", "CLAIM_TEXT", "LI_CLAIM",
           "claim_rows", "record_claims", "MAIN_CLAIMS", "takeaway", "prose", "PAPER_METHODS", "overall",
           "summary_table", "dpf_vs_liu_west", "reference_convergence", "PROBLEM_CLASS", "what_to_use",
           "USE_MARGIN", "REF_SLOPE_MAX", "close_to_best", "recommend", "use_phrase", "use_sentence",
           "time_range_phrase", "below_line_sentence", "frontier_improves_phrase", "gaussian_phrase",
           "time_agrees_phrase", "reference_sentence", "bounds_sentence", "start_sentence"]


# ------------------------------------------------------------------------------- equal budget
def efficient_frontier(r: BenchResult, axis: str = "count") -> list[str]:
    """The baseline's configurations that no other configuration beats on both cost and mean MSE,
    sorted by cost (on the time axis a small-N PF can be slower than a larger one: per-call overhead
    dominates a one-run step, and the machine is shared; such a point is dominated and dropped)."""
    names = _frontier_names(r)
    c = {n: _cost(r, n, axis) for n in names}
    m = {n: float(r.err[n].mean()) for n in names}
    keep = [n for n in names if not any(c[o] <= c[n] and m[o] <= m[n] and (c[o], m[o]) != (c[n], m[n])
                                         for o in names)]
    return sorted(keep, key=c.get)


def pf_at_cost(r: BenchResult, target: float, axis: str = "count"):
    """Per-run MSE of the baseline (bootstrap PF; Liu-West on ``theta_hou``) at cost ``target``.

    Linear interpolation in log cost between the two points of the baseline's efficient frontier
    (:func:`efficient_frontier`) that bracket ``target``, run by run (so the result is paired with
    every method's per-run MSE). Returns ``(per_run_mse, where)`` with ``where`` = "inside",
    "below" (target cheaper than the cheapest frontier point: that point is used) or "above"
    (dearer than the dearest: that point is used). No extrapolation beyond the frontier's ends
    (an earlier "flat end" rule did so, and the BOT frontier kept improving beyond where it had
    looked flat).
    """
    names = efficient_frontier(r, axis)
    c = np.array([_cost(r, n, axis) for n in names])
    lc, lt = np.log(c), math.log(target)
    if lt <= lc[0]:
        return r.err[names[0]].to_numpy(), "inside" if np.isclose(lt, lc[0]) else "below"
    if lt >= lc[-1]:
        return r.err[names[-1]].to_numpy(), "inside" if np.isclose(lt, lc[-1]) else "above"
    j = int(np.searchsorted(lc, lt)) - 1
    w = (lt - lc[j]) / (lc[j + 1] - lc[j])
    return (1 - w) * r.err[names[j]].to_numpy() + w * r.err[names[j + 1]].to_numpy(), "inside"


def equal_budget(r: BenchResult, name: str, axis: str = "count") -> dict:
    """Method ``name`` against the baseline at the same cost on ``axis`` ("count" or "time").

    ``d`` = mean over runs of MSE(baseline at equal cost) - MSE(method), divided by the mean
    MSE of the reference (so d is in units of the optimum's MSE; d > 0: the method is better),
    ``se`` its paired standard error, ``p`` its two-sided p-value, ``runs`` the runs behind it,
    ``where`` where the method's cost lies on the baseline's frontier (:func:`pf_at_cost`; or
    "diverged", "not measured"), ``margin`` the benchmark's smallest effect of interest
    (:data:`pfrepro.experiments.synthesis.MARGIN`), ``judgement`` the book's verdict rule applied to it
    (:func:`judge_equal_budget`) and ``holds`` True (better) / False (worse) / None (undecided).
    """
    margin = MARGIN.get(r.bench.key, MARGIN["ung_zhang"])
    if not r.finite(name):
        e = {"d": np.nan, "se": np.nan, "p": np.nan, "where": "diverged", "cost": np.nan, "runs": len(r.err)}
    else:
        cost = _cost(r, name, axis)
        if not np.isfinite(cost):    # not timed (time_it=False): no comparison on that axis
            e = {"d": np.nan, "se": np.nan, "p": np.nan, "where": "not measured", "cost": cost, "runs": len(r.err)}
        else:
            pf, where = pf_at_cost(r, cost, axis)
            diff = (pf - r.err[name].to_numpy()) / r.err[r.ref].mean()
            d, se = float(diff.mean()), float(diff.std(ddof=1) / math.sqrt(diff.size))
            e = {"d": d, "se": se, "p": p_two_sided(d, se), "where": where, "cost": cost, "runs": int(diff.size)}
    e["margin"] = margin
    j = judge_equal_budget(e)
    e["judgement"] = j
    e["holds"] = {"reproduced": True, "not reproduced": False}.get(j.verdict)
    return e


def judge_equal_budget(e: dict) -> Judgement:
    """The book's verdict rule (:func:`pfrepro.claims.judge_ordering`) on one equal-budget comparison
    ``e`` (:func:`equal_budget`'s fields ``d``, ``se``, ``runs``, ``where``, ``margin``): better
    (*reproduced*) when shown at 2 SE, worse (*not reproduced*) when reversed, a tie only when the
    interval lies inside ``±margin``, else too few runs (with the runs a plan needs). What the cost
    mismatch at the frontier's ends does not support is *inconclusive* (the count does not decide): a
    method cheaper than the cheapest baseline that loses to it, or dearer than the dearest that beats
    it. A method that diverged loses (*not reproduced*); a comparison not measured is undecided.
    The one rule behind the claims, the verdict tables and their words (:data:`WORDS`)."""
    if e["where"] == "diverged":
        return Judgement("not reproduced")
    if e["where"] == "not measured":
        return Judgement("inconclusive", CAUSE_COUNT)
    j = judge_ordering(e["d"], e["se"], margin=e["margin"], runs=e["runs"])
    if (e["where"] == "below" and j.verdict == "not reproduced") or (
            e["where"] == "above" and j.verdict == "reproduced"):
        return Judgement("inconclusive", CAUSE_COUNT)
    return j


def ranking(r: BenchResult, names=None, alpha: float = ALPHA) -> pd.DataFrame:
    """Methods sorted by mean MSE ratio to the reference, with a family-wise rank.

    Every pair of finite methods is compared on its paired per-run MSE difference (two-sided z
    test); Holm's rule at ``alpha`` over all pairs of the benchmark decides which differences are
    significant. A method's rank is 1 + the number of methods significantly better than it, so two
    methods share a rank only if the same methods beat both; "tie" lists the methods with a lower
    mean MSE that it is not significantly worse than (no difference shown; not a tie within the
    margin, which rankings do not test). Diverged methods are listed last, unranked."""
    dt = distance_table(r)
    names = list(dt.index) if names is None else list(names)
    ok = [n for n in names if dt.loc[n, "diverged"] == 0]
    ok.sort(key=lambda n: dt.loc[n, "MSE / opt."])
    scale = r.err[r.ref].mean()
    pairs, ps = [], []
    for i, a in enumerate(ok):
        for b in ok[i + 1:]:
            dd = (r.err[b] - r.err[a]).to_numpy() / scale      # > 0: a better
            d, se = float(dd.mean()), float(dd.std(ddof=1) / math.sqrt(dd.size))
            pairs.append((a, b, d))
            ps.append(p_two_sided(d, se))
    rej = holm(ps, alpha) if ps else np.zeros(0, bool)
    beaten = {n: 0 for n in ok}
    tied = {n: [] for n in ok}
    for (a, b, d), sig in zip(pairs, rej):
        if sig:
            beaten[b if d > 0 else a] += 1
        else:
            tied[b].append(a)
    rows = []
    for n in ok:
        rows.append({"rank": 1 + beaten[n], "method": n, "MSE / opt.": dt.loc[n, "MSE / opt."],
                     "SE": dt.loc[n, "SE"], "evals/step": dt.loc[n, "evals/step"],
                     "tie": ("= " + ", ".join(tied[n])) if tied[n] else ""})
    for n in names:
        if n not in ok:
            k = int(dt.loc[n, "diverged"])
            rows.append({"rank": np.nan, "method": n, "MSE / opt.": np.nan, "SE": np.nan,
                         "evals/step": dt.loc[n, "evals/step"],
                         "tie": f"diverged ({k} run{'s' if k != 1 else ''})"})
    return pd.DataFrame(rows).set_index("method")


#: the word of an equal-budget comparison in the verdict tables, by the verdict of its claim
WORDS = {"reproduced": "better", "not reproduced": "worse", CAUSE_TIE: "tie (within the margin)",
         CAUSE_COUNT: "undecided (off frontier)", CAUSE_RUNS: "undecided (too few runs)"}


def _word(e) -> str:
    """The verdict word of an :func:`equal_budget` result (its :func:`judge_equal_budget` in words)."""
    if e["where"] in ("diverged", "not measured"):
        return e["where"]
    j = e["judgement"]
    return WORDS[j.verdict] if j.verdict != "inconclusive" else WORDS[j.cause]


def verdict_table(results, families=None, today: bool = False) -> pd.DataFrame:
    """One row per (benchmark, method of a paper, plus UKF/ESPF baselines where given):
    distance to the reference and the equal-budget comparison by count and by time, each judged by
    :func:`judge_equal_budget` (the claims' rule, per comparison; ``by count`` / ``by time`` its word).
    ``today=False``: the book's methods without today's; ``today=True``: today's methods only."""
    rows = []
    for key, r in results.items():
        dt = distance_table(r)
        for m in r.bench.methods:
            if m.family in ("PF",) or m.family == r.bench.baseline:
                continue
            if m.today != today:
                continue
            if families is not None and m.family not in families:
                continue
            ec, et = equal_budget(r, m.name, "count"), equal_budget(r, m.name, "time")
            rows.append({"benchmark": key, "method": m.name, "paper": m.paper or "",
                         "MSE / opt.": dt.loc[m.name, "MSE / opt."], "SE": dt.loc[m.name, "SE"],
                         "d count": ec["d"], "se count": ec["se"], "p count": ec["p"], "where count": ec["where"],
                         "runs": ec["runs"], "margin": ec["margin"],
                         "by count": _word(ec), "holds count": ec["holds"],
                         "d time": et["d"], "se time": et["se"], "p time": et["p"], "where time": et["where"],
                         "by time": _word(et), "holds time": et["holds"]})
    vt = pd.DataFrame(rows)
    if vt.empty:
        return vt
    for ax in ("count", "time"):
        vt[f"holds {ax}"] = pd.Series(list(vt[f"holds {ax}"]), dtype=object).to_numpy()
    vt["z count"] = vt["d count"] / vt["se count"]
    return vt


def dpf_vs_liu_west(r: BenchResult, n: int = 500) -> dict:
    """The DPF(n+n) against Liu-West on ``theta_hou`` under the two tests the book uses.

    ``synthesis``: θ-MSE per run, Liu-West interpolated at the DPF's model-evaluation count, the
    book's rule with the margin (the verdict table); ``dpf_chapter``: the DPF chapter's test on these
    runs -- Liu-West(n) against DPF(n+n) at equal *likelihood* count (2n each), per-run θ RMSE,
    paired difference Liu-West - DPF (negative: Liu-West better) with a 2-SE rule; ``mse_same_pair``:
    the same pair on θ-MSE. Each entry is (d, se, z)."""
    lw, dpf = r.err[f"Liu-West({n})"].to_numpy(), r.err[f"DPF({n}+{n})"].to_numpy()
    out = {}
    for key, a, b in (("dpf_chapter", np.sqrt(lw), np.sqrt(dpf)), ("mse_same_pair", lw, dpf)):
        dd = a - b
        d, se = float(dd.mean()), float(dd.std(ddof=1) / math.sqrt(dd.size))
        out[key] = (d, se, d / se)
    e = equal_budget(r, f"DPF({n}+{n})", "count")
    # in the synthesis' sign (baseline - method, > 0: DPF better), in units of the exact θ-MSE
    out["synthesis"] = (e["d"], e["se"], e["d"] / e["se"])
    return out


# ----------------------------------------------------------------------------------- claims
CLAIM_TEXT = {
    "gpff_zhang2016": "GPFF is better than the bootstrap PF",
    "cmspf_ning2011": "CMS-PF is better than the bootstrap PF",
    "dpf_hou2008": "the dual PF is better than the Liu-West filter",
    "immpfor_zhou2017": "IMMPFOR is better than the IMMPF",
}


def _cid(benchmark: str, method: str) -> str:
    cid = f"{benchmark}-{method}".lower()
    cid = "".join(ch if ch.isalnum() or ch in "-_" else "-" for ch in cid).strip("-")
    while "--" in cid:
        cid = cid.replace("--", "-")
    return cid


#: the Li 2012 claim (the one claim not at equal budget)
LI_CLAIM = "ung_li-pf-beats-ekf"


def _note(row, results=None) -> str:
    if row["where count"] == "diverged":
        r = None if results is None else results[row["benchmark"]]
        n = "" if r is None else f" in {r.diverged(row['method'])} of {len(r.err)} runs"
        return f"diverged{n}: worse than the baseline"
    # no wall time here: claims must be identical between two builds (the equal-time comparison is
    # in the chapter's verdict table, as context); the paired difference is in the test column
    out = (f"MSE/reference {row['MSE / opt.']:.3g} ± {row['SE']:.2g}; baseline − method at equal count in units of "
           f"the reference MSE ({row['by count']}; cost {row['where count']} the baseline's range")
    if row["by count"] == WORDS[CAUSE_COUNT]:
        out += f"; {row['d count']:.3g} ± {row['se count']:.2g}, z = {row['z count']:.2f}"
    return out + ")"


def claim_rows(vt: pd.DataFrame) -> pd.DataFrame:
    """The rows of the verdict table (:func:`verdict_table`) that are claims: the papers' methods,
    except on the centred bearings-only start (context: the paper excludes it, not a claim)."""
    if vt.empty:
        return vt
    return vt[(vt["paper"] != "") & (vt["benchmark"] != BOT_READINGS["centred"])]


def _claim_kwargs(e: dict) -> dict:
    """The verdict inputs of one equal-budget claim: the paired difference with its runs and margin, or
    a statement where no difference decides (diverged: worse; off frontier: the count does not decide)."""
    if e["where"] == "diverged":
        return dict(qualitative=False)
    j = e["judgement"]
    if j.verdict == "inconclusive" and j.cause == CAUSE_COUNT:
        return dict(qualitative=None)
    return dict(diff=e["d"], diff_se=e["se"], runs=e["runs"], margin=e["margin"])


def record_claims(reg: ClaimsRegistry, results) -> ClaimsRegistry:
    """Record the synthesis's claims in ``reg`` and return it.

    Per paper's method and benchmark, the implicit claim "<method> beats the baseline" re-tested
    at equal model-evaluation count (exact and load-independent), judged by
    :func:`judge_equal_budget` (the book's rule with the benchmark's margin): better -> reproduced,
    worse or diverged -> not reproduced, a tie inside the margin, too few runs (with the runs a plan
    needs) or a conclusion the frontier's range does not support -> inconclusive with that cause. On
    bearings-only the claim is decided on the paper's offset start; the centred start's difference is
    passed as a reading and ``excluded`` with the paper's lines (shown, not counted). The
    equal-wall-time comparison moves with the machine's load: it is context in the chapter's tables,
    never in a claim. Plus Li 2012's "PF beats EKF" (model 1, at the paper's N, not at equal cost),
    judged by the Li chapter's :func:`~pfrepro.verdicts.ekf_pf_li2012.pf_beats_ekf` with its printed
    effect.

    Parameters
    ----------
    reg : ClaimsRegistry
        The registry (``ClaimsRegistry("synthesis", choices=CHOICES)``).
    results : mapping
        Benchmark key -> :class:`~pfrepro.experiments.synthesis.BenchResult`, e.g. the
        :class:`~pfrepro.experiments.synthesis.SynthesisResults` of ``run_all``.

    Returns
    -------
    ClaimsRegistry
        ``reg``, with the claims added in the chapter's order.
    """
    vt = verdict_table(results)
    centred = BOT_READINGS["centred"]
    for _, row in claim_rows(vt).iterrows():
        bench, method = row["benchmark"], row["method"]
        text = f"{CLAIM_TEXT[row['paper']]} at equal model-evaluation count ({method}, {S.BENCH_NAME.get(bench, bench)})"
        e = equal_budget(results[bench], method, "count")
        kw = _claim_kwargs(e)
        note = _note(row, results)
        if bench == BOT_READINGS["offset"] and centred in results and "diff" in kw:
            ec = equal_budget(results[centred], method, "count")
            if np.isfinite(ec["d"]):
                kw.update(reading_diffs=over("bot_prior", {"offset": (e["d"], e["se"], e["runs"]),
                                                           "centred": (ec["d"], ec["se"], ec["runs"])}),
                          excluded={"bot_prior=centred": BOT_CENTRED_EXCLUDED}, depends_on=["bot_prior"])
            note += f"; centred start (context, not counted): {_word(ec)}"
        reg.add(_cid(bench, method), text, basis="count", source=f"{row['paper']}; benchmark {bench}", note=note,
                **kw)
    if "ung_li" in results:
        r = results["ung_li"]
        pf = f"PF({max(PF_N['ung_li'])})"
        kw = pf_beats_ekf(np.sqrt(r.err["EKF"].to_numpy()), np.sqrt(r.err[pf].to_numpy()), which=1)
        reg.add(LI_CLAIM, f"Li 2012: the bootstrap PF is better than the EKF ({pf} vs EKF, model 1)",
                source="ekf_pf_li2012 (l.181, Table 1); benchmark ung_li", **kw,
                note=f"per-run RMSE EKF − {pf} on this chapter's runs, judged by the Li chapter's function "
                     f"(pfrepro.verdicts.ekf_pf_li2012.pf_beats_ekf, printed effect: Table 1's EKF − PF, model 1); "
                     f"at the paper's N, not at equal cost (EKF {r.counts.loc['EKF', 'model evals / step']:.0f} "
                     f"model evaluations per step)")
    return reg


#: the main claims (the findings list them first) — each paper's method on its own paper's benchmark
#: at its paper's N (GPFF: the scalar model of sec 5.2 and bearings-only of sec 5.3; CMS-PF: Table 2's
#: N = 200; DPF: sec 5.1 at N_x = N_theta = 500; IMMPFOR: Table 1's N = 500 per mode), and Li 2012's PF vs EKF
MAIN_CLAIMS = (_cid("ung_zhang", "GPFF eq43 unif."), _cid("bot", "GPFF eq41 unif."),
               _cid("ung_ning", f"CMS-PF({S.CMS.ASSUMPTIONS['N_table2']})"),
               _cid("theta_hou", f"DPF({S.DPF_N[-1]}+{S.DPF_N[-1]})"),
               _cid("imm_zhou", f"IMMPFOR({S.IMM.SCENARIO['N']})"), LI_CLAIM)


#: the distance between replicates must fall at least this steeply in log N for the reference to count as converged
#: (the 1/N law gives -1; halfway leaves room for the Monte Carlo noise of a few runs, fixed before the runs)
REF_SLOPE_MAX = -0.5


def reference_convergence(conv: dict, r: BenchResult, tol: float = BOT_REF_TOL) -> dict:
    """Has the bearings-only reference (:func:`pfrepro.experiments.synthesis.bot_reference_filter`) converged?

    ``conv`` is :func:`pfrepro.experiments.synthesis.bot_reference_convergence`: two independent replicates of
    the reference filter at each N on the first runs. Their mean squared distance d²(N) (time- and
    component-averaged, the MSE's units) has expectation 2 v(N), v(N) the Monte Carlo variance of one estimate;
    a particle filter's v(N) falls as c / N, so N d²(N) stays level and log d² falls with slope -1 in log N.
    Returned: ``table`` (per N: d² mean and SE over the runs, N d², the MSE of the first replicate),
    ``slope`` (least-squares slope of log d² on log N; the 1/N law: -1), ``share`` (v(N_ref) / MSE of the
    reference on the benchmark ``r``'s runs, with v(N_ref) = d²(N_ref) / 2, or from the nearest N by the 1/N
    law), ``converged`` (``share`` < ``tol`` and d² falling at least as fast as 1/sqrt(N):
    slope < :data:`REF_SLOPE_MAX`), ``runs``, ``n_ref``."""
    tol = float(tol)
    if not 0 < tol < 1:
        raise ValueError(f"tol must be in (0, 1), got {tol!r}")
    xt = np.asarray(conv["x_true"], float)
    Ns = sorted({N for N, _ in conv["x"]})
    if len(Ns) < 2:
        raise ValueError("conv needs the reference at two particle numbers at least")
    runs = xt.shape[0]
    rows = []
    for N in Ns:
        a, b = np.asarray(conv["x"][(N, 0)], float), np.asarray(conv["x"][(N, 1)], float)
        d2 = np.mean((a - b) ** 2, axis=(1, 2))
        e = mse(xt, a)
        rows.append({"particles": N, "distance² between replicates": float(d2.mean()),
                     "its standard error": float(d2.std(ddof=1) / math.sqrt(runs)) if runs > 1 else float("nan"),
                     "particles × distance²": float(N * d2.mean()), "MSE against the truth": float(e.mean())})
    table = pd.DataFrame(rows).set_index("particles")
    d2 = table["distance² between replicates"].to_numpy()
    slope = float(np.polyfit(np.log(Ns), np.log(d2), 1)[0])
    n_ref = getattr(r.bench.reference.filt, "n_particles", Ns[-1])
    near = min(Ns, key=lambda N: abs(math.log(N / n_ref)))
    v_ref = table.loc[near, "distance² between replicates"] / 2 * near / n_ref
    share = float(v_ref / r.err[r.ref].mean())
    return {"table": table, "slope": slope, "share": share, "converged": bool(share < tol and slope < REF_SLOPE_MAX),
            "runs": runs, "n_ref": int(n_ref), "tol": tol}


def reference_sentence(rc: dict) -> Md:
    """Whether the bearings-only reference has converged (:func:`reference_convergence`), in words."""
    share = 100 * rc["share"]
    falls = (f"the distance between two independent runs of the reference filter falls with slope "
             f"{rc['slope']:.2f} in log N (the 1/N law of a particle filter's Monte Carlo variance: -1)")
    if rc["converged"]:
        return Md(f"It has converged: {falls}, and at N = {rc['n_ref']} its own Monte Carlo variance is "
                  f"{share:.1f} % of its MSE (the rule, fixed before the runs: below {100 * rc['tol']:.0f} %)")
    why = (f"its distance does not fall as N grows, slope not below {REF_SLOPE_MAX}" if rc["slope"] >= REF_SLOPE_MAX else
           f"its own Monte Carlo variance is {share:.1f} % of its MSE, not below {100 * rc['tol']:.0f} %")
    return Md(f"It has not converged by the rule fixed before the runs ({why}; {falls}): the ratios on "
              f"bearings-only are to the best estimate computed, not to the least MSE")


# ------------------------------------------------------------------------------ what to use (issue 22)
#: problem class of each benchmark (the closing table of the synthesis)
PROBLEM_CLASS = {"ung_zhang": "scalar, strongly nonlinear (UNGM, Q = R = 1)",
                 "ung_li": "scalar, strongly nonlinear (UNGM, Q = 10)",
                 "ung_ning": "scalar, strongly nonlinear (UNGM, σ_w² = 1)",
                 "bot": "bearings-only, prior offset from the truth",
                 "bot_centred": "bearings-only, prior centred (context: not the paper's start)",
                 "theta_hou": "unknown static parameter",
                 "imm_zhou": "manoeuvring target"}


#: the equivalence margin of the recommendation, stated before the runs. A method is recommended only when its mean
#: error is shown to be within 25 % of every other method's on its benchmark (the upper end of the paired ratio's
#: interval below 1 + USE_MARGIN); "not shown worse" is not enough, since a method with a wide standard error is
#: never shown worse. A quarter: well inside the gaps between the families on these benchmarks (a factor of 2 and
#: more), wider than the spread among the PF's own resampling schemes.
USE_MARGIN = 0.25


def close_to_best(err: pd.DataFrame, margin: float = USE_MARGIN, z: float = Z_CRIT) -> pd.DataFrame:
    """Which methods are shown to have an error close to the best of their benchmark (an equivalence test).

    Method m is *shown close to the best* when, against every other method b, the paired ratio of mean errors
    mean(e_m) / mean(e_b) (:func:`pfrepro.stats.ratio_of_means`, delta-method SE) has its upper bound
    ratio + ``z`` SE below 1 + ``margin``: whichever method is truly best, m's error is shown within the margin of
    it. Each comparison is at ``z``; m must pass all of them (an intersection-union test: no correction for the
    number of comparisons is needed). Against a method with a higher mean the ratio is below 1 and binds only
    when that method's error is very noisy. A method with non-finite errors (diverged runs) is not close.

    Parameters
    ----------
    err : pandas.DataFrame
        Per-run errors, one column per method, on common runs (at least 2).
    margin : float
        The equivalence margin (> 0), as a fraction of the best error.
    z : float
        Standard errors of the one-sided bound (> 0).

    Returns
    -------
    pandas.DataFrame
        Per method, sorted by mean error: ``mean``, ``worst upper bound`` (the largest ratio + z SE over the
        other methods), ``against`` (the method of that bound) and ``close`` (bool).
    """
    if not isinstance(err, pd.DataFrame):
        raise TypeError(f"err must be a pandas DataFrame of per-run errors, got {type(err).__name__}")
    margin, z = float(margin), float(z)
    if not (margin > 0 and math.isfinite(margin)):
        raise ValueError(f"margin must be a positive number, got {margin!r}")
    if not (z > 0 and math.isfinite(z)):
        raise ValueError(f"z must be a positive number, got {z!r}")
    if len(err) < 2:
        raise ValueError(f"err needs at least 2 runs, got {len(err)}")
    ok = [c for c in err.columns if np.all(np.isfinite(err[c].to_numpy(float)))]
    rows = {}
    for m in err.columns:
        if m not in ok:
            rows[m] = {"mean": float("nan"), "worst upper bound": float("inf"), "against": "", "close": False}
            continue
        worst, against = -math.inf, ""
        for b in ok:
            if b == m:
                continue
            ratio, se = ratio_of_means(err[m].to_numpy(float), err[b].to_numpy(float))
            if ratio + z * se > worst:
                worst, against = ratio + z * se, b
        if against == "":     # a single finite method: nothing to compare with
            worst = 1.0
        rows[m] = {"mean": float(err[m].mean()), "worst upper bound": float(worst), "against": against,
                   "close": bool(worst < 1 + margin)}
    return pd.DataFrame.from_dict(rows, orient="index").sort_values("mean", na_position="last")


def recommend(err: pd.DataFrame, cost, margin: float = USE_MARGIN, z: float = Z_CRIT):
    """The method to use: the cheapest of the methods :func:`close_to_best` shows close to the best (ties in
    cost: the lower mean error), or None when none is shown close. ``cost``: a mapping method -> cost (model
    evaluations per step). Returns ``(pick, table)`` with ``table`` from :func:`close_to_best`."""
    table = close_to_best(err, margin, z)
    missing = [m for m in err.columns if m not in cost]
    if missing:
        raise ValueError(f"cost has no entry for {missing}")
    close = [m for m in table.index if table.loc[m, "close"]]
    if not close:
        return None, table
    return min(close, key=lambda m: (float(cost[m]), table.loc[m, "mean"])), table


def what_to_use(results: dict, margin: float = USE_MARGIN) -> pd.DataFrame:
    """Per benchmark, the method to use (:func:`recommend`): the cheapest method whose error is shown within
    ``margin`` of the best of its benchmark, or none. With it: its MSE relative to the reference, its upper bound
    against the best, its count, the other methods shown close, and the best method by mean error."""
    rows = []
    for key, r in results.items():
        names = [m.name for m in r.bench.methods]
        cost = {n: float(r.counts.loc[n, "model evals / step"]) for n in names}
        pick, t = recommend(r.err[names], cost, margin)
        dt = distance_table(r)
        rel = lambda n: f"{dt.loc[n, 'MSE / opt.']:.3g} ± {dt.loc[n, 'SE']:.2g}"    # noqa: E731
        best = t.index[0]
        close = [n for n in t.index if t.loc[n, "close"] and n != pick]
        rows.append({"problem": PROBLEM_CLASS.get(key, key), "key": key,
                     "use": pick if pick is not None else "none shown close to the best",
                     "its MSE / reference": rel(pick) if pick is not None else "–",
                     "model evaluations per step": f"{cost[pick]:.0f}" if pick is not None else "–",
                     "its error / any other's (upper bound)": (f"{t.loc[pick, 'worst upper bound']:.2f}"
                                                               if pick is not None else "–"),
                     "best by mean (MSE / reference)": f"{best} ({dt.loc[best, 'MSE / opt.']:.3g})",
                     "also shown close": ", ".join(close) or "–"})
    return pd.DataFrame(rows).set_index("problem")


def use_phrase(use: dict) -> str:
    """"A on the X and Y settings, B for Z": the recommendations of :func:`what_to_use`, each method named once.

    ``use``: benchmark key -> the method to use, or None where none is shown close to the best. Benchmarks with
    the same pick share one phrase (so a method is never listed twice, "RPF(100) and RPF(100)")."""
    scalar: dict = {}
    for k in _SCALAR:
        if k in use:
            scalar.setdefault(use[k], []).append(_SETTING[k])
    parts = []
    if scalar:
        sub = [f"{'no method shown close to the best' if p is None else p} on the {join_and(st)} "
               f"setting{'s' if len(st) > 1 else ''}" for p, st in scalar.items()]
        parts.append(join_and(sub) + " of the scalar growth model")
    others: dict = {}
    for k in use:
        if k not in _SCALAR:
            others.setdefault(use[k], []).append(_PROBLEM_PHRASE.get(k, k))
    for p, s in others.items():
        parts.append(f"no method shown close to the best for {join_and(s)}" if p is None else f"{p} for {join_and(s)}")
    return join_and(parts)


# ------------------------------------------------------------------------ per method, over benchmarks
#: the papers' methods of the summary table (paper key, label), in the chapter's order
PAPER_METHODS = (("gpff_zhang2016", "GPFF (Zhang et al. 2016)"), ("cmspf_ning2011", "CMS-PF (Ning et al. 2011)"),
                 ("dpf_hou2008", "DPF (Hou & Yin 2008)"), ("immpfor_zhou2017", "IMMPFOR (Zhou et al. 2017)"))


_UNDECIDED = (WORDS[CAUSE_TIE], WORDS[CAUSE_COUNT], WORDS[CAUSE_RUNS], "not measured")


def overall(vt: pd.DataFrame, paper: str) -> str:
    """One phrase for a paper's method over all its benchmarks (the centred bearings-only start, context,
    left out), from its equal-count words in the verdict table ``vt`` (the verdicts rest on the count;
    the time reading is context)."""
    sub = vt[(vt["paper"] == paper) & (vt["benchmark"] != BOT_READINGS["centred"])] if not vt.empty else vt
    words = set(sub["by count"]) if not sub.empty else set()
    if not words:
        return "not run"
    lost = {"worse", "diverged"}
    if words <= lost:
        return "worse than the baseline at equal budget wherever it ran"
    if words == {"better"}:
        return "better than the baseline at equal budget wherever it ran"
    if words == {WORDS[CAUSE_TIE]}:
        return "a tie with the baseline within the margin wherever it ran"
    if "better" in words:
        return "better on some benchmarks and not on others"
    if words & lost:
        return "never shown better: worse on some benchmarks, undecided on the others"
    return "undecided wherever it ran: " + ", ".join(sorted(w.replace("undecided ", "").strip("()") for w in words))


def summary_table(results) -> pd.DataFrame:
    """Per paper's method: :func:`overall`'s phrase and how many of its comparisons (all benchmarks; the
    centred bearings-only start, context, left out) gave each equal-count word, one column per word."""
    vt = verdict_table(results)
    vt = vt[vt["benchmark"] != BOT_READINGS["centred"]]
    seen = set(vt.loc[vt["paper"].isin([p for p, _ in PAPER_METHODS]), "by count"])
    order = ["better", WORDS[CAUSE_TIE], WORDS[CAUSE_RUNS], WORDS[CAUSE_COUNT], "worse", "diverged"]
    words = [w for w in order if w in seen] + sorted(seen - set(order))
    out = pd.DataFrame([{"method (paper)": name, "at equal count": overall(vt, p),
                         **{w: int((vt.loc[vt["paper"] == p, "by count"] == w).sum()) for w in words},
                         "comparisons": int((vt["paper"] == p).sum())} for p, name in PAPER_METHODS])
    assert all(out[words].sum(axis=1) == out["comparisons"])
    return out


def plan_table(results) -> pd.DataFrame:
    """The power plan of every equal-budget claim (and Li 2012's): the runs behind it, the per-run spread of
    its paired difference (the main reading's own), the size the plan resolves (the benchmark's margin; the
    printed effect for Li 2012) and the runs 80 % power at ``|z| > 2`` needs (:func:`pfrepro.stats.plan_runs`).
    The runs are fixed before any run (``pfrepro.experiments.synthesis.RUNS``); a claim left undecided
    reports the runs its plan needs (``runs_needed``), no run is added after an outcome. ``at these runs``:
    the comparison's word (the Li claim's verdict) on the runs it has. ``claim id`` is the claim's id, ``claim``
    its method and benchmark in words (what the chapter shows)."""
    vt = claim_rows(verdict_table(results))
    rows = []
    for _, row in vt.iterrows():
        if not np.isfinite(row["se count"]):
            continue
        sd = float(row["se count"]) * math.sqrt(int(row["runs"]))
        rows.append({"claim id": _cid(row["benchmark"], row["method"]),
                     "claim": f"{row['method']} better than the baseline, {S.BENCH_NAME.get(row['benchmark'], row['benchmark'])}",
                     "runs": int(row["runs"]),
                     "sd per run": sd, "size resolved": f"margin {row['margin']:g}",
                     "runs the plan needs": plan_runs(sd, float(row["margin"]), z=Z_CRIT),
                     "at these runs": row["by count"]})
    if "ung_li" in results:
        r = results["ung_li"]
        pf = f"PF({max(PF_N['ung_li'])})"
        kw = pf_beats_ekf(np.sqrt(r.err["EKF"].to_numpy()), np.sqrt(r.err[pf].to_numpy()), which=1)
        sd = kw["diff_se"] * math.sqrt(kw["runs"])
        rows.append({"claim id": LI_CLAIM, "claim": f"Li 2012: {pf} better than the EKF", "runs": kw["runs"],
                     "sd per run": sd,
                     "size resolved": f"printed effect {kw['effect']:.4g}",
                     "runs the plan needs": plan_runs(sd, kw["effect"], z=Z_CRIT),
                     "at these runs": judge(diff=kw["diff"], diff_se=kw["diff_se"], effect=kw["effect"],
                                            runs=kw["runs"]).verdict})
    return pd.DataFrame(rows)


# ---------------------------------------------------------------------------------- the takeaway
#: how the takeaway names each benchmark's problem (the centred bearings-only reading is left out)
_PROBLEM_PHRASE = {"bot": "bearings-only tracking with the prior as printed",
                   "theta_hou": "a static parameter learnt with the state", "imm_zhou": "the manoeuvring target"}
_SCALAR = ("ung_zhang", "ung_li", "ung_ning")
_SETTING = {"ung_zhang": "GPFF", "ung_li": "Li", "ung_ning": "CMS-PF"}


def takeaway(reg: ClaimsRegistry, results) -> str:
    """What a practitioner should take away from the synthesis, generated from its claims and rankings.

    First, whether any paper's method was shown better than the plain baseline at the same number of
    model evaluations (the equal-budget claims of ``reg``: which, or how many were shown worse); then,
    per problem class, what to use: the cheapest method whose error is shown within :data:`USE_MARGIN` of the
    best (:func:`what_to_use`). Never typed: a change of result changes the sentence.

    Parameters
    ----------
    reg : ClaimsRegistry
        The synthesis's claims (:func:`record_claims`).
    results : mapping
        Benchmark key -> :class:`~pfrepro.experiments.synthesis.BenchResult`.

    Returns
    -------
    str
        Two sentences, plain text.
    """
    eq = [c for c in reg.claims if c.claim_id != LI_CLAIM]
    rows = {_cid(r["benchmark"], r["method"]): r for _, r in claim_rows(verdict_table(results)).iterrows()}
    better = [f"{rows[c.claim_id]['method']} ({S.BENCH_NAME.get(rows[c.claim_id]['benchmark'], rows[c.claim_id]['benchmark'])})" for c in eq
              if c.verdict == "reproduced" and c.claim_id in rows]
    n, worse = len(eq), sum(c.verdict == "not reproduced" for c in eq)
    base = "the plain baseline (a bootstrap PF; Liu–West for a static parameter; the IMMPF for a manoeuvring target)"
    if not eq:
        first = "No paper's method was compared with the plain baseline at equal cost"
    elif not better:
        und = [c for c in eq if c.verdict == "inconclusive"]
        ties = sum(c.cause == CAUSE_TIE for c in und)
        why = ("ties within the margin" if ties == len(und) else
               "need more runs or lie off the baseline's range of costs" if ties == 0 else
               f"{ties} tie within the margin, {len(und) - ties} need more runs or lie off the baseline's range")
        rest = ("the one comparison finds the paper's method worse" if worse == n == 1 else
                f"all {n} comparisons find the paper's method worse" if worse == n else
                "the one comparison does not decide" if n == 1 else
                f"none of the {n} comparisons decides either way ({why})" if worse == 0 else
                f"{worse} of the {n} comparisons find the paper's method worse, the other {n - worse} do not "
                f"decide ({why})")
        first = (f"No method proposed in the papers is better than {base} at the same number of model "
                 f"evaluations: {rest}")
    elif len(better) == n:
        first = f"Every method proposed in the papers is better than {base} at the same number of model evaluations"
    else:
        first = (f"Of the methods proposed in the papers, only {join_and(better)} "
                 f"{'is' if len(better) == 1 else 'are'} better than {base} at the same number of model "
                 f"evaluations ({len(better)} of {plural(n, 'comparison')})")
    keys = [k for k in results if k != BOT_READINGS["centred"]]
    if not keys:
        return first + "."
    w = what_to_use({k: results[k] for k in keys})
    use = {k: (None if p not in fam else p) for k, p, fam in
           zip(w["key"], w["use"], ({m.name for m in results[k].bench.methods} for k in w["key"]))}
    return (f"{first}. What to use, the cheapest method whose error is shown within {100 * USE_MARGIN:.0f} % of "
            f"the best method's: {use_phrase(use)}.")


# --------------------------------------------------------------------------- the chapter's prose
def _ratio_of(results, key: str, name: str) -> float:
    """MSE of ``name`` over the reference's on benchmark ``key`` (NaN if it diverged)."""
    return float(distance_table(results[key]).loc[name, "MSE / opt."])


def _count_of(results, key: str, name: str) -> float:
    """Model evaluations per step of ``name`` on benchmark ``key``."""
    return float(results[key].counts.loc[name, "model evals / step"])


def _row(vt: pd.DataFrame, bench: str, method: str) -> pd.Series:
    return vt[(vt["benchmark"] == bench) & (vt["method"] == method)].iloc[0]


def _settings_prose(results) -> dict:
    """The chapter's settings: run counts, seeds, particle numbers, the bearings-only prior."""
    st = getattr(results, "settings", {}) or {}
    seeds = st.get("seeds", S.SEEDS)
    imm = S.IMM.SCENARIO
    m = S.GPFF.BearingsOnly.zhang2016()
    out = {"syn_runs": int(st.get("runs", S.RUNS)),
           "syn_n_bench": len([k for k in results if k != BOT_READINGS["centred"]]),
           "syn_reps": S.TIMING_REPEATS, "syn_tsteps": S.TIMING_STEPS, "syn_csteps": S.COUNT_STEPS, "syn_alpha": ALPHA,
           "syn_centred_runs": len(results[BOT_READINGS["centred"]].err), "syn_bot_offset_sds": S.bot_offset_sds(),
           "syn_scheme_n": S.SCHEME_N, "syn_method_n": S.METHOD_N, "syn_zcrit": Z_CRIT,
           "syn_pcrb_runs": int(st.get("pcrb_runs", S.PCRB_RUNS)),
           "syn_seeds": Md("; ".join(f"{S.BENCH_NAME[k]}: {v}" if k in S.BENCH_NAME else f"the bound's truths: {v}"
                                     for k, v in seeds.items() if k != "imm_zhou")
                           + f"; the manoeuvring target keeps the IMM chapter's seed, {seeds['imm_zhou']}"),
           "syn_pf_n": Md(", ".join(str(n) for n in PF_N["ung_zhang"])),
           "syn_pf_n_bot": Md(", ".join(str(n) for n in PF_N["bot"])),
           "syn_bot_x0": Md("(" + ", ".join(f"{v:g}" for v in m.x0) + ")"),
           "syn_bot_m0": Md("(" + ", ".join(f"{v:g}" for v in m.m0) + ")"),
           "syn_bot_p0": Md("diag(" + ", ".join(f"{v:g}" for v in np.diag(m.P0)) + ")"),
           "syn_lw_n": Md(", ".join(str(n) for n in S.LW_N)),
           "syn_dpf_n": Md(", ".join(f"{n} + {n}" for n in S.DPF_N)),
           "syn_not_run": Md("; ".join(f"**{k}**: {v}" for k, v in S.NOT_RUN.items())),
           "syn_imm_n": imm["N"], "syn_imm_n5": imm["N_fig5"],
           "syn_today_n": S.TODAY_N, "syn_ledh_n": S.LEDH_N, "syn_jmpf_n": S.JMPF_N,
           # plain text: glued Markdown is CommonMark (no dollar math)
           "syn_smc2_size": Md(f"{S.SMC2_SIZE[0]} θ-particles × {S.SMC2_SIZE[1]} state particles"),
           "syn_ref_tol": 100 * BOT_REF_TOL, "syn_ref_n": S.BOT_REF_N, "syn_ref_ess": S.BOT_REF_ESS,
           "syn_ref_ns": Md(", ".join(str(n) for n in S.BOT_REF_CONV_N)),
           "syn_use_margin": 100 * USE_MARGIN, "syn_use_bound": 1 + USE_MARGIN}
    return out


def _results_prose(results, vt: pd.DataFrame) -> dict:
    """The numbers and result-dependent phrases of the sections on the papers' methods."""
    ratio = lambda k, n: _ratio_of(results, k, n)     # noqa: E731
    cnt = lambda k, n: _count_of(results, k, n)       # noqa: E731
    out = {}
    best_pf = {k: min(efficient_frontier(r), key=lambda n: float(r.err[n].mean())) for k, r in results.items()}
    for k in _SCALAR:
        out[f"syn_{k}_pf1000"] = ratio(k, "PF(1000)")
        out[f"syn_{k}_gpff"] = ratio(k, "GPFF eq43 unif.")
        out[f"syn_{k}_cms"] = ratio(k, "CMS-PF(100)")
        out[f"syn_{k}_espf"] = ratio(k, "ESPF(100)")
        out[f"syn_{k}_ekf"] = ratio(k, "EKF")
        out[f"syn_{k}_ukf"] = ratio(k, "UKF")
    out["syn_gpff_exp"] = ratio("ung_zhang", "GPFF eq43 exp.")
    out["syn_gpff41_div"] = results["ung_zhang"].diverged("GPFF eq41 unif.")
    out["syn_cnt_gpff43"] = cnt("ung_zhang", "GPFF eq43 unif.")
    out["syn_cnt_gpff41_bot"] = cnt("bot", "GPFF eq41 unif.")
    out["syn_cnt_cms"] = cnt("ung_zhang", "CMS-PF(100)")
    out["syn_cnt_espf"] = cnt("ung_zhang", "ESPF(100)")
    out["syn_cnt_dpf"] = cnt("theta_hou", f"DPF({S.DPF_N[-1]}+{S.DPF_N[-1]})")
    out["syn_cnt_lw"] = cnt("theta_hou", f"Liu-West({S.LW_N[1]})")
    for n in S.DPF_N:
        out[f"syn_dpf{n}"] = ratio("theta_hou", f"DPF({n}+{n})")
    for n in S.LW_N:
        out[f"syn_lw{n}"] = ratio("theta_hou", f"Liu-West({n})")
    pcrb = S.bot_pcrb(results["bot"])
    pcrb_x0 = getattr(results, "pcrb_x0_known", float("nan"))
    ref_mse = float(results["bot"].err[results["bot"].ref].mean())
    out.update(syn_pcrb=pcrb, syn_pcrb_x0=pcrb_x0, syn_bot_ref_mse=ref_mse,
               syn_s_bounds=bounds_sentence(ref_mse, pcrb_x0, pcrb))
    for k, suf in (("bot", ""), ("bot_centred", "_c")):
        es = S.bot_ess1(results[k])
        out[f"syn_ess1_pf1000{suf}"] = es.loc["PF(1000)", "mean ESS at k=1"]
        out[f"syn_ess1_pf1000_med{suf}"] = es.loc["PF(1000)", "median"]
        out[f"syn_ess1_collapsed{suf}"] = 100 * es.loc["PF(1000)", "runs with ESS < 1 % of N"]
    pfmax = f"PF({PF_N['bot'][-1]})"
    for name, key in (("EKF", "ekf"), ("UKF", "ukf"), ("GPFF eq41 unif.", "gpff"), ("PF(1000)", "pf1000"),
                      (pfmax, "pfmax")):
        out[f"syn_botc_{key}"] = ratio("bot_centred", name)
    out["syn_bot_pf1000"] = ratio("bot", "PF(1000)")
    out["syn_bot_pfmax"] = ratio("bot", pfmax)
    out["syn_bot_pfmax_name"] = Md(pfmax)
    for k, suf in (("bot", ""), ("bot_centred", "_c")):
        row = _row(vt, k, "GPFF eq41 unif.")
        out[f"syn_gpff_z{suf}"] = row["z count"]
        out[f"syn_gpff_word{suf}"] = Md(row["by count"])
    out["syn_s_starts"] = start_sentence(str(out["syn_gpff_word"]), str(out["syn_gpff_word_c"]))
    out["syn_n_family"] = int(vt["d count"].notna().sum())
    out["syn_margin"] = MARGIN["ung_zhang"]
    # the DPF chapter's sec 5.1 size: Liu-West(n) against DPF(n+n), 2n likelihoods each
    n = 500
    assert n in S.LW_N and n in S.DPF_N
    dl = dpf_vs_liu_west(results["theta_hou"], n)
    for key, (d_, se_, z_) in dl.items():
        out[f"syn_dl_{key}_z"] = z_
    out["syn_dl_dpf_chapter_d"], out["syn_dl_dpf_chapter_se"] = dl["dpf_chapter"][0], dl["dpf_chapter"][1]
    out["syn_dl_word"] = Md(_row(vt, "theta_hou", f"DPF({n}+{n})")["by count"])
    out["syn_dl_lw"], out["syn_dl_dpf"] = Md(f"Liu–West({n})"), Md(f"DPF({n}+{n})")
    out["syn_dl_lik_each"] = 2 * n
    out["syn_dl_seed_dpf"] = S.DPF.SEED_51
    out["syn_dl_seed_syn"] = int(getattr(results, "settings", {}).get("seeds", S.SEEDS)["theta_hou"])
    for name, key in (("EKF", "ekf"), ("UKF", "ukf"), ("GPFF eq41 unif.", "gpff"), ("GPFF eq41 exp.", "gpffexp")):
        out[f"syn_bot_{key}"] = ratio("bot", name)
    rb = results["bot"]
    out["syn_bot_bestpf"] = Md(best_pf["bot"])
    out["syn_bot_pf_best"] = ratio("bot", best_pf["bot"])
    out["syn_bot_pf_median"] = float(np.median(rb.err[best_pf["bot"]] / rb.err[rb.ref]))
    out["syn_bot_ekf_median"] = float(np.median(rb.err["EKF"] / rb.err[rb.ref]))
    out["syn_bot_pf_worst"] = max(ratio("bot", f"PF({n})") for n in PF_N["bot"])
    # wall time: context only (single-run time on a shared machine), never in a claim
    dz = distance_table(results["ung_zhang"])
    out["syn_time_gpff_over_pf1000"] = dz.loc["GPFF eq43 unif.", "ms/step"] / dz.loc["PF(1000)", "ms/step"]
    db = distance_table(rb)
    tf = db.loc["GPFF eq41 unif.", "ms/step"] / db.loc[[f"PF({n})" for n in PF_N["bot"]], "ms/step"].max()
    out["syn_bot_time_factor"] = tf
    out["syn_s_bot_time"] = time_range_phrase(tf)
    # sentences whose content depends on the results (so the prose cannot contradict the numbers)
    out["syn_s_below"] = below_line_sentence(vt)
    out["syn_s_bot_pf"] = frontier_improves_phrase(rb)
    out["syn_s_bot_gauss"] = gaussian_phrase(rb, best_pf["bot"])
    out["syn_s_time"] = time_agrees_phrase(vt)
    out.update(_reference_prose(results))
    return out


def _significantly_better(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether the paired per-run difference a - b is positive by more than :data:`~pfrepro.claims.Z_CRIT` SE."""
    dd = np.asarray(a, float) - np.asarray(b, float)
    return bool(dd.mean() > Z_CRIT * dd.std(ddof=1) / np.sqrt(dd.size))


def start_sentence(word_offset: str, word_centred: str) -> Md:
    """What the two bearings-only starts say together about the GPFF against the PF at its count, from the two
    words of the verdict table ("better", "worse", "undecided (...)", "tie (...)")."""
    off, cen = word_offset.startswith("better"), word_centred.startswith("better")
    if off and cen:
        return Md("So the GPFF's gain over the PF on bearings-only holds with either start")
    if off:
        return Md("So what the GPFF gains over the PF on bearings-only is a finding about the offset start the paper "
                  "chose, not about bearings-only tracking in general")
    if cen:
        return Md("So the GPFF gains over the PF on bearings-only only with the centred start, which the paper did "
                  "not choose")
    return Md("With neither start is the GPFF shown better than the PF at its count")


def bounds_sentence(ref_mse: float, pcrb_x0: float, pcrb_prior: float) -> Md:
    """The two posterior Cramér–Rao bounds of bearings-only beside the least MSE ``ref_mse`` (context): the bound
    with x0 known bounds every estimator's MSE on these truths, so it should lie below; the bound with the
    filters' prior information averages over starts drawn from that prior, which these truths do not."""
    vals = (ref_mse, pcrb_x0, pcrb_prior)
    if not all(isinstance(v, (int, float)) and math.isfinite(v) and v > 0 for v in vals):
        raise ValueError(f"bounds_sentence needs three positive finite numbers, got {vals!r}")
    x0 = (f"The posterior Cramér–Rao bound with x₀ known, {pcrb_x0:.3g}, lies below it, as a bound on "
          f"these truths must" if pcrb_x0 <= ref_mse else
          f"The posterior Cramér–Rao bound with x₀ known, {pcrb_x0:.3g}, lies above it, which a bound on "
          f"these truths cannot: the reference or the bound is off by more than its Monte Carlo error")
    prior = (f"the bound with the filters' prior information, {pcrb_prior:.3g}, lies "
             + (f"{pcrb_prior / ref_mse:.1f} times above it, so it bounds nothing here (it averages over starts "
                f"drawn from the prior, and these truths all start at x₀)" if pcrb_prior > ref_mse else
                f"below it too, but it is a bound for truths whose start is drawn from the prior, not for these"))
    return Md(f"{x0}; {prior}.")


def time_range_phrase(factor: float) -> Md:
    """Where the GPFF's time per step lies on bearings-only, given its ratio to the dearest PF's (context)."""
    return Md("so by time it lies beyond the PF's range (\"undecided (off frontier)\" if it wins)" if factor > 1 else
              "so by time it lies inside the PF's range, but close enough to its end that another load can move it out")


def below_line_sentence(vt: pd.DataFrame) -> Md:
    """Which proposed methods are better than the PF at equal count on the scalar benchmarks (the
    line of the accuracy-cost figure), from the verdict table ``vt``."""
    scalar = vt[vt["benchmark"].isin(list(_SCALAR)) & (vt["paper"] != "")]
    better = scalar[scalar["by count"].str.startswith("better")]
    return Md("No proposed method lies below that line at its cost (none is better than the PF at "
              "equal count)." if better.empty else
              "Below that line at its cost (better than the PF at equal count): "
              + ", ".join(f"{m} on the {S.BENCH_NAME.get(b, b)}" for m, b in zip(better["method"], better["benchmark"])) + ".")


def frontier_improves_phrase(r: BenchResult) -> Md:
    """Whether the baseline's error falls from its cheapest to its dearest configuration (paired, 2 SE)."""
    pf = sorted(_frontier_names(r), key=lambda n: _cost(r, n, "count"))
    if _significantly_better(r.err[pf[0]].to_numpy(), r.err[pf[-1]].to_numpy()):
        return Md(f"it improves significantly from {pf[0]} to {pf[-1]}")
    return Md(f"and it does not improve significantly from {pf[0]} to {pf[-1]} (paired difference within "
              f"{Z_CRIT:g} SE, or the wrong way)")


def gaussian_phrase(r: BenchResult, best_pf: str) -> Md:
    """Whether the EKF beats the best bootstrap PF ``best_pf`` on benchmark ``r`` (paired, 2 SE)."""
    if _significantly_better(r.err[best_pf].to_numpy(), r.err["EKF"].to_numpy()):
        return Md("here the Gaussian filters, not the PF, are the ones to beat")
    return Md("the EKF is not better than the best PF here")


def time_agrees_phrase(vt: pd.DataFrame) -> Md:
    """Whether the equal-time words agree with the equal-count ones for the proposed methods on the
    scalar benchmarks (context: the time reading moves with the machine's load)."""
    scalar = vt[vt["benchmark"].isin(list(_SCALAR)) & (vt["paper"] != "")]
    same = scalar["by count"] == scalar["by time"]
    if same.all():
        return Md("gives the same answer as the count for every proposed method on the scalar benchmarks")
    return Md("differs from the count for " + ", ".join(
        f"{m} on the {S.BENCH_NAME.get(b, b)}" for m, b in zip(scalar.loc[~same, "method"], scalar.loc[~same, "benchmark"])))


def _today_prose(results) -> dict:
    """The numbers and words of the section on today's methods (the same rule per comparison)."""
    ratio = lambda k, n: _ratio_of(results, k, n)     # noqa: E731
    cnt = lambda k, n: _count_of(results, k, n)       # noqa: E731
    vt = verdict_table(results, today=True)
    N, imm_n = S.TODAY_N, S.IMM.SCENARIO["N"]
    out = {"syn_n_family_today": int(vt["d count"].notna().sum())}
    words = vt["by count"].value_counts()
    out["syn_today_words"] = Md(", ".join(f"{w} in {plural(int(c), 'comparison')}" for w, c in words.items()))
    for k in _SCALAR + ("bot", "bot_centred"):
        for name, key in ((f"APF({N})", "apf"), (f"RPF({N})", "rpf"), (f"EKF-prop. PF({N})", "ekfp"),
                          (f"PFPF-EDH({N})", "edh")):
            out[f"syn_{k}_{key}"] = ratio(k, name)
    for k in ("ung_li", "ung_ning"):
        out[f"syn_{k}_ledh"] = ratio(k, f"PFPF-LEDH({S.LEDH_N})")
    out["syn_cnt_edh"] = cnt("ung_zhang", f"PFPF-EDH({N})")
    out["syn_cnt_ledh"] = cnt("ung_li", f"PFPF-LEDH({S.LEDH_N})")
    smc2, jm = f"SMC²({S.SMC2_SIZE[0]}×{S.SMC2_SIZE[1]})", f"JMPF({S.JMPF_N})"
    out["syn_smc2"], out["syn_cnt_smc2"] = ratio("theta_hou", smc2), cnt("theta_hou", smc2)
    out["syn_jmpf"], out["syn_cnt_jmpf"] = ratio("imm_zhou", jm), cnt("imm_zhou", jm)
    out["syn_immpf500"] = ratio("imm_zhou", f"IMMPF({imm_n})")
    out["syn_immpfor"] = ratio("imm_zhou", f"IMMPFOR({imm_n})")
    out["syn_cnt_immpf500"] = cnt("imm_zhou", f"IMMPF({imm_n})")
    out["syn_smc2_word"] = Md(_row(vt, "theta_hou", smc2)["by count"])
    out["syn_jmpf_word"] = Md(_row(vt, "imm_zhou", jm)["by count"])
    edh = _row(vt, "bot", f"PFPF-EDH({N})")
    out["syn_edh_bot_word"], out["syn_edh_bot_z"] = Md(edh["by count"]), edh["z count"]
    out["syn_edh_bot_rank"] = ranking(results["bot"]).loc[f"PFPF-EDH({N})", "rank"]
    out["syn_jmpf_rank"] = ranking(results["imm_zhou"]).loc[jm, "rank"]
    ri = results["imm_zhou"]
    dj = (ri.err[f"IMMPF({imm_n})"] - ri.err[jm]).to_numpy() / ri.err[ri.ref].mean()
    out["syn_jmpf_vs_immpf_d"] = float(dj.mean())
    out["syn_jmpf_vs_immpf_se"] = float(dj.std(ddof=1) / np.sqrt(dj.size))
    return out


def _reference_prose(results) -> dict:
    """The bearings-only reference (:func:`reference_convergence`): has it converged, and the bounds beside it."""
    conv = getattr(results, "ref_conv", None)
    if conv is None:
        return {}
    rc = reference_convergence(conv, results["bot"])
    return {"syn_ref_runs": int(rc["runs"]), "syn_ref_share_pct": 100 * rc["share"], "syn_ref_slope": rc["slope"],
            "syn_ref_verdict": reference_sentence(rc)}


def _claims_prose(reg: ClaimsRegistry) -> dict:
    """The count of the claims' verdicts, as numbers and as a sentence."""
    cl = reg.verdicts()
    n = {v: sum(x == v for x in cl.values()) for v in ("reproduced", "not reproduced", "inconclusive", "not checkable")}
    out = {f"syn_n_{v.replace(' ', '_')}": k for v, k in n.items()}
    out["syn_n_claims"] = len(cl)
    # every verdict counted (the Li claim can be qualitatively reproduced), in number agreement
    out["syn_claims_sentence"] = Md(verdict_sentence(list(cl.values())) + ".")
    return out


def use_sentence(w: pd.DataFrame) -> Md:
    """The section's closing sentence from :func:`what_to_use`'s table: the pick per problem, each method once."""
    use, context = {}, None
    for k, p in zip(w["key"], w["use"]):
        p = None if p.startswith("none ") else p
        if k == BOT_READINGS["centred"]:
            context = p
        else:
            use[k] = p
    s = use_phrase(use)
    if context is not None or BOT_READINGS["centred"] in set(w["key"]):
        s += ("; with the bearings-only prior centred on the truth (context): "
              + (context if context is not None else "no method shown close to the best"))
    return Md(s[:1].upper() + s[1:] + ".")


def _use_prose(results) -> dict:
    """What to use (:func:`what_to_use`), as one sentence."""
    return {"syn_use_sentence": use_sentence(what_to_use(results))}


def prose(reg: ClaimsRegistry, results) -> dict:
    """Every number and phrase the synthesis chapter glues (``syn_*``), from its claims and results.

    Settings (run counts, seeds, particle numbers), the distances to the reference and the counts
    the sections quote, the equal-budget words of the verdict tables, the sentences whose content
    depends on the results (so the prose cannot contradict the numbers), the convergence of the
    bearings-only reference, what to use and the count of the claims' verdicts. Wall-time ratios are context
    only (they move with the machine's load) and feed no claim.

    Parameters
    ----------
    reg : ClaimsRegistry
        The synthesis's claims (:func:`record_claims`).
    results : SynthesisResults
        :func:`pfrepro.experiments.synthesis.run_all`'s results (every benchmark).

    Returns
    -------
    dict
        Glue key -> value (numbers, strings; :class:`pfrepro.prose.Md` for Markdown phrases), for
        :func:`pfrepro.prose.glue_all`.
    """
    vt = verdict_table(results)
    out = _settings_prose(results)
    out.update(_results_prose(results, vt))
    out.update(_today_prose(results))
    out.update(_use_prose(results))
    out.update(_claims_prose(reg))
    return out
