"""Figures and tables of Li, Li, Fang, Bai (2012), EKF vs PF (chapter ``book/30_ekf_pf.md``).

The experiments are :mod:`pfrepro.experiments.ekf_pf_li2012` (:func:`~pfrepro.experiments.ekf_pf_li2012.run_all`);
this module only draws their results: the chapter's figures and tables, and the paper's
(:func:`tables`, :func:`figures`) for the command line.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..bookinfo import reader_text
from ..experiments import ekf_pf_li2012 as E
from ..plotting import REFERENCE_COLOR, SERIES_COLORS, method_color  # noqa: F401  (the book palette)
from . import new_figure
from ._layout import legend_below, letter, phone, plain_log

__all__ = ["one_run_panel", "per_time_panel", "figs_1_3", "figs_2_4", "fig1", "fig2", "fig3", "fig4",
           "table1_plot", "table1_shown", "ess_plot", "sweep_plot", "statistic_readings_table", "gap_table",
           "cost_table", "count_table", "nsweep_table", "degeneracy_vs_n_table", "statements_table", "pm", "DIGITS",
           "sensitivity_shown", "seed_spread_plot", "nsweep_plot", "tables", "figures",
           "TABLES", "FIGURES", "N_STEPS"]

#: what :func:`tables` and :func:`figures` make
TABLES = ("Table 1",)
FIGURES = ("Fig. 1", "Fig. 2", "Fig. 3", "Fig. 4")
#: experiments :func:`~pfrepro.experiments.ekf_pf_li2012.run_all` runs (its ``steps`` calls, for a progress bar)
N_STEPS = 8
#: figure number -> (model, kind)
_FIG = {1: (1, "run"), 2: (1, "rmse"), 3: (2, "run"), 4: (2, "rmse")}
#: legend names where the experiments' labels are plain text (the figures use the text's symbols)
_LEGEND = {"EKF": "EKF, eq (10)", "EKF-prev": r"EKF, $B_k$ at $\hat x_{k-1|k-1}$ (code)"}


def _phone() -> bool:
    return phone()


def _letter(i: int) -> str:
    return letter(i)


def _plain_log(ax, axis: str = "y") -> None:
    plain_log(ax, axis)


def _size(w: float, h: float, phone_h: float | None = None) -> tuple:
    """``(w, h)``, or ``(w, phone_h)`` on the phone: panels whose rotated tick labels need height."""
    return (w, phone_h) if phone_h is not None and _phone() else (w, h)




def one_run_panel(ax, res, which: int, fig_no: int, run: int = 0) -> None:
    """Figs. 1/3 on ``ax``: truth, EKF, PF and exact posterior mean of one run of model ``which``."""
    k = np.arange(1, res.sim.T + 1)
    ax.plot(k, res.x_true[run, :, 0], "k-", lw=2, label="truth")
    ax.plot(k, res.results["EKF"].x[run, :, 0], "--o", color=method_color("EKF"), ms=3, label="EKF")
    ax.plot(k, res.results["PF"].x[run, :, 0], "-s", color=method_color("PF"), ms=3, label=f"PF (N = {E.N_PARTICLES})")
    if "Exact" in res.results:
        ax.plot(k, res.results["Exact"].x[run, :, 0], ":", color=REFERENCE_COLOR, lw=2, label="exact posterior mean")
    ax.set_ylabel("state $x_k$")
    ax.set_title(f"Fig. {fig_no}: {E.MODEL_LABELS[which]}, one run")


def per_time_panel(ax, res, which: int, fig_no: int) -> None:
    """Figs. 2/4 on ``ax``: RMSE over the runs at each time step (:func:`~pfrepro.experiments.ekf_pf_li2012.per_time_rmse`)."""
    names = [n for n in ("EKF", "PF", "Exact") if n in res.results]
    pt = E.per_time_rmse(res, names)
    ax.plot(pt.index, pt["EKF"], "--o", color=method_color("EKF"), ms=3, label="EKF")
    ax.plot(pt.index, pt["PF"], "-s", color=method_color("PF"), ms=3, label="PF")
    if "Exact" in pt:
        ax.plot(pt.index, pt["Exact"], ":", color=REFERENCE_COLOR, lw=2, label="exact posterior mean")
    ax.set_xlabel("time step $k$")
    ax.set_ylabel(f"RMSE over {res.sim.runs} runs")
    ax.set_title(f"Fig. {fig_no}: {E.MODEL_LABELS[which]}")


def figs_1_3(figs: dict, run: int = 0):
    """Figs. 1 and 3 stacked: one run of each model. ``figs`` maps model -> MonteCarloResult."""
    # on the phone each panel as tall as the layout allows: 60 steps in 3 inches are dense
    fig, axes = new_figure(2, 1, figsize=(9, 14) if _phone() else (9, 7), sharex=True)
    for ax, w, fno in zip(axes, (1, 2), (1, 3)):
        one_run_panel(ax, figs[w], w, fno, run)
    for ax in axes:
        ax.set_xlabel("time step $k$")
    legend_below(fig, axes, ncol=4)
    return fig


def figs_2_4(figs: dict):
    """Figs. 2 and 4 side by side: per-time RMSE over the figure runs of each model."""
    fig, axes = new_figure(1, 2, figsize=(10.2, 4))
    for ax, w, fno in zip(axes, (1, 2), (2, 4)):
        per_time_panel(ax, figs[w], w, fno)
    legend_below(fig, axes, ncol=3)
    return fig


def _single(fig_no: int, figs: dict):
    which, kind = _FIG[fig_no]
    fig, ax = new_figure(figsize=((9, 7) if _phone() else (9, 3.8)) if kind == "run" else (6, 4))
    if kind == "run":
        one_run_panel(ax, figs[which], which, fig_no)
        ax.set_xlabel("time step $k$")
    else:
        per_time_panel(ax, figs[which], which, fig_no)
    legend_below(fig, ax, ncol=4)
    return fig


def fig1(figs: dict):
    """Fig. 1 alone: one run of model 1."""
    return _single(1, figs)


def fig2(figs: dict):
    """Fig. 2 alone: per-time RMSE of model 1."""
    return _single(2, figs)


def fig3(figs: dict):
    """Fig. 3 alone: one run of model 2."""
    return _single(3, figs)


def fig4(figs: dict):
    """Fig. 4 alone: per-time RMSE of model 2."""
    return _single(4, figs)


#: digits of each model's RMSEs, in the table and in the text (one rounding for both)
DIGITS = {"Model 1": 2, "Model 2": 3}


def pm(value: float, se: float, digits: int) -> str:
    """``"19.66 ± 0.95"``: a value and its standard error at ``digits`` decimals."""
    return f"{value:.{digits}f} ± {se:.{digits}f}"


def table1_shown(t1):
    """Table 1 as the chapter shows it, eight columns: the published value as the paper prints it
    (``30.1709``, :func:`pfrepro.published.formatter`), ours and the exact posterior's RMSE as
    "mean ± se" at the digits the text uses (:data:`DIGITS`), z, the verdict of the cell under the
    main reading and how many of the exact posterior's standard errors the published value lies
    from it. ``t1`` is :func:`~pfrepro.experiments.ekf_pf_li2012.table1`'s frame (the download
    keeps its every column)."""
    from .. import published

    fmt = published.formatter(E.PAPER, "Table 1")
    d = [DIGITS.get(m, 3) for m in t1["model"]]
    return pd.DataFrame({
        "model": t1["model"], "filter": t1["filter"], "published": t1["published"].map(fmt),
        "ours (± se)": [pm(v, e, k) for v, e, k in zip(t1["ours"], t1["se"], d)],
        "z": [f"{v:.1f}" for v in t1["z"]],
        "verdict (main reading)": t1["verdict"],
        "exact posterior (± se)": [pm(v, e, k) for v, e, k in zip(t1["exact"], t1["exact_se"], d)],
        "published − exact, in se": [f"{v:.1f}" for v in t1["published_minus_exact_in_se"]],
    }).style.hide(axis="index")


def table1_plot(t1):
    """Table 1 as a plot: ours (±2 se) beside the published values and the exact posterior's RMSE.

    ``t1`` is :func:`pfrepro.experiments.ekf_pf_li2012.table1`'s frame.
    """
    fig, axes = new_figure(1, 2, figsize=(10, 3.8))
    for ax, w in zip(axes, (1, 2)):
        col = E.MODEL_LABELS[w]
        sub = t1[t1["model"] == col]
        x = np.arange(len(sub))
        ax.errorbar(x - 0.1, sub["ours"], 2 * sub["se"], fmt="o", capsize=4, label="ours (±2 se)")
        ax.plot(x + 0.1, sub["published"], "r*", ms=12, label="published (Table 1)")
        ax.axhline(sub["exact"].iloc[0], color=REFERENCE_COLOR, ls=":", lw=2, label="exact posterior mean")
        ax.set_xticks(x, sub["filter"])
        ax.set_xlim(-0.6, len(sub) - 0.4)
        ax.set_ylabel("mean per-run RMSE")
        ax.set_title(f"{_letter(w - 1)} Table 1, {col}" + (" (log scale)" if w == 1 else ""))
        if w == 1:
            ax.set_yscale("log")
            _plain_log(ax)
    legend_below(fig, axes, ncol=3)
    return fig


def ess_plot(deg: dict, n_particles: int = E.N_PARTICLES):
    """The degeneracy of sequential importance sampling (sec 1.3.2): ESS / N over time, median and
    10-90 % band over the runs, for SIS (no resampling) and the PF (ESS of the weights before each
    resampling), one panel per model. ``deg`` maps model -> :func:`~pfrepro.experiments.ekf_pf_li2012.degeneracy`."""
    fig, axes = new_figure(1, len(deg), figsize=(10.2, 3.8), sharey=True)
    axes = np.atleast_1d(axes)
    for ax, (w, d) in zip(axes, deg.items()):
        t = d["ess_over_time"]
        for n, c, lab in (("PF", method_color("PF"), "PF"), ("SIS", method_color("SIS"), "SIS")):
            ax.plot(t.index, t[(n, "median")], color=c, lw=2, label=f"{lab}: median")
            ax.fill_between(t.index, t[(n, "q10")], t[(n, "q90")], color=c, alpha=0.2, lw=0,
                            label=f"{lab}: 10–90 % of runs")
        ax.axhline(E.FEW_FRACTIONS[0], color="k", ls=":", lw=1, label=f"{E.FEW_FRACTIONS[0]:.0%} of $N$")
        ax.set_yscale("log")
        ax.set_ylim(0.5 / n_particles, 1.2)
        ax.set_xlabel("time step $k$")
        ax.set_ylabel("effective sample size / $N$")
        ax.set_title(f"{_letter(list(deg).index(w))} {E.MODEL_LABELS[w]}, $N$ = {n_particles}")
    legend_below(fig, axes, ncol=2)
    return fig


def sweep_plot(sens):
    """The swept free choices (prior variance P0, resampling scheme): the Table 1 EKF and PF means
    (±2 se) and the exact posterior's under every swept value, with the published cells, one panel
    per model. ``sens`` is :func:`~pfrepro.experiments.ekf_pf_li2012.sensitivity`'s frame."""
    pub = E.published_table1()
    fig, axes = new_figure(1, 2, figsize=_size(10.2, 3.8, 6.5))
    for ax, w in zip(axes, (1, 2)):
        col = E.MODEL_LABELS[w]
        sub = sens[(sens["model"] == col) & sens["setting"].isin(["P0", "resampling"])].reset_index(drop=True)
        x = np.arange(len(sub))
        labels = [f"$P_0$ = {v:g}" if st == "P0" else str(v) for st, v in zip(sub["setting"], sub["value"])]
        for name, c, dx in (("EKF", method_color("EKF"), -0.12), ("PF", method_color("PF"), 0.12)):
            ax.errorbar(x + dx, sub[name], 2 * sub[f"{name}_se"], fmt="o", color=c, capsize=3, label=f"{name} (±2 se)")
            ax.axhline(float(pub.loc[name, col]), color=c, ls="--", lw=1, label=f"{name}, published")
        ex = sub["exact"].to_numpy(float)
        ax.plot(x[np.isfinite(ex)], ex[np.isfinite(ex)], "s", color=REFERENCE_COLOR, ms=5, label="exact posterior")
        ax.set_xticks(x, labels, rotation=60, ha="right", rotation_mode="anchor")
        ax.set_ylabel("mean per-run RMSE")
        ax.set_title(f"{_letter(w - 1)} {col}" + (" (log scale)" if w == 1 else ""))
        if w == 1:
            ax.set_yscale("log")
            _plain_log(ax)
    legend_below(fig, axes, ncol=3)
    return fig


def statistic_readings_table(res: dict):
    """The three readings of Table 1's statistic for every filter of the Table 1 runs, one column
    block per model (:func:`~pfrepro.experiments.ekf_pf_li2012.statistic_readings`); ``res`` maps
    model -> MonteCarloResult."""
    import pandas as pd

    words = {"mean_run_rmse": "mean of per-run RMSE", "pooled": "pooled RMS",
             "mean_time_rmse": "time average of per-time RMSE"}
    out = pd.concat({E.MODEL_LABELS[w]: E.statistic_readings(res[w], list(E.FILTERS)).rename(columns=words)
                     for w in res}, axis=1)
    out.index = [E.FILTER_LABELS.get(n, n) if n == "Exact" else n for n in out.index]
    return out.style.format("{:.3f}")


def gap_table(res: dict):
    """Each filter's mean per-run RMSE and its paired gap to the exact posterior mean, per model
    (:func:`~pfrepro.experiments.ekf_pf_li2012.gap_to`), styled; ``res`` maps model -> MonteCarloResult."""
    import pandas as pd

    from ..metrics import mc_summary

    rows = []
    for w in res:
        for name in ("EKF", "UKF", "PF"):
            g, s = E.gap_to(res[w], name), mc_summary(res[w].rmse(name))
            rows.append({"model": E.MODEL_LABELS[w], "filter": name, "RMSE": s.mean, "se": s.se,
                         "exact RMSE": float(res[w].rmse("Exact").mean()), "gap to exact": g["gap"],
                         "gap se (paired)": g["se"], "gap relative (%)": 100 * g["relative"]})
    tab = pd.DataFrame(rows).set_index(["model", "filter"])
    return tab.style.format("{:.4f}").format("{:.1f}", subset=["gap relative (%)"])


def cost_table(cost: dict):
    """Single-run and amortised wall time of each filter relative to the EKF, per model
    (:func:`~pfrepro.experiments.ekf_pf_li2012.cost_ratios`; context, never a claim)."""
    import pandas as pd

    words = {"single_run_ratio": "single run", "amortised_ratio": "amortised over 100 runs"}
    out = pd.concat({E.MODEL_LABELS[w]: cost[w][list(words)].rename(columns=words) for w in cost}, axis=1)
    out.index = [E.FILTER_LABELS.get(n, n) if n == "Exact" else n for n in out.index]
    return out.style.format("{:.2f}")


def count_table(cnt: dict):
    """Model evaluations per step and their ratio to the EKF's (the cost claim's evidence), beside
    the single-run time ratio (context: median and [min, max] over interleaved repeats), per model
    (:func:`~pfrepro.experiments.ekf_pf_li2012.cost_evidence`), styled."""
    rows = []
    for w, c in cnt.items():
        for name, r in c.iterrows():
            row = {"model": E.MODEL_LABELS[w], "filter": E.FILTER_LABELS.get(name, name) if name == "Exact" else name,
                   "model evaluations per step": f"{r['model evals / step']:.0f}",
                   "count ratio to the EKF": f"{r['count ratio']:.4g}"}
            if "time ratio" in r.index:  # measured beside the count (context)
                row["time ratio (median)"] = f"{r['time ratio']:.2f}"
                row["time ratio [min, max]"] = f"[{r['time ratio min']:.2f}, {r['time ratio max']:.2f}]"
            rows.append(row)
    return pd.DataFrame(rows).style.hide(axis="index")


def nsweep_table(nsweep: dict):
    """The numbers behind :func:`nsweep_plot`: per model and N, the PF's mean per-run RMSE (± se),
    its paired gap to the exact posterior (± se) and its time relative to the EKF (single run and
    amortised); ``nsweep`` maps model -> :func:`~pfrepro.experiments.ekf_pf_li2012.rmse_and_cost_vs_n`."""
    rows = []
    for w, d in nsweep.items():
        k = DIGITS.get(E.MODEL_LABELS[w], 3)
        for n, r in d.iterrows():
            rows.append({"model": E.MODEL_LABELS[w], "N": int(n), "PF RMSE (± se)": pm(r["rmse"], r["se"], k),
                         "gap to exact (± se)": pm(r["gap"], r["gap_se"], k + 1),
                         "time ratio, single run": f"{r['single_run_ratio']:.2f}",
                         "time ratio, amortised": f"{r['amortised_ratio']:.1f}"})
    return pd.DataFrame(rows).style.hide(axis="index")


#: one-letter verdicts of the sensitivity table (the chapter gives the legend)
_LETTER = {"reproduced": "R", "qualitatively reproduced": "Q", "not reproduced": "N", "inconclusive": "I",
           "not checkable": "–"}


def sensitivity_shown(sens):
    """The sensitivity table compact for the text column: "mean (SE)" cells and one-letter
    verdicts of the EKF cell, the PF cell and the ratio claim (R, Q, N, I); ``sens`` is
    :func:`~pfrepro.experiments.ekf_pf_li2012.sensitivity`'s frame."""
    import pandas as pd

    pm = lambda m, se: [f"{a:.3g} ({b:.2g})" for a, b in zip(m, se)]  # noqa: E731
    short = {E.FILTER_LABELS["EKF"]: "B at x̂ₖ|ₖ₋₁ (eq 10)", E.FILTER_LABELS["EKF-prev"]: "B at x̂ₖ₋₁|ₖ₋₁ (code)",
             "EKF linearisation": "EKF lin. point"}
    return pd.DataFrame({
        "EKF (SE)": pm(sens["EKF"], sens["EKF_se"]), "PF (SE)": pm(sens["PF"], sens["PF_se"]),
        "exact": ["–" if np.isnan(v) else f"{v:.3g}" for v in sens["exact"]],
        "EKF/PF (SE)": pm(sens["EKF/PF"], sens["EKF/PF_se"]),
        "verdicts": [" ".join(_LETTER[v] for v in r) for r in sens[["verdict_EKF", "verdict_PF", "verdict_ratio"]].values],
    }, index=pd.MultiIndex.from_frame(sens[["model", "setting", "value"]].astype(str).replace(short)))


def seed_spread_plot(spread):
    """The Table 1 EKF means over independent seed sets: eq (10) against the circulating code's
    linearisation point (±2 se), with the published EKF value, one panel per model; ``spread`` is
    :func:`~pfrepro.experiments.ekf_pf_li2012.ekf_seed_spread`'s frame."""
    pub = E.published_table1()
    fig, axes = new_figure(1, 2, figsize=_size(10.2, 3.6, 6.0))
    for ax, w in zip(axes, (1, 2)):
        sub = spread[spread["model"] == E.MODEL_LABELS[w]]
        seeds = list(dict.fromkeys(sub["seed"]))
        for j, (n, c, mk) in enumerate((("EKF", method_color("EKF"), "o"), ("EKF-prev", "#6a3d9a", "s"))):
            q = sub[sub["filter"] == n]
            ax.errorbar(np.arange(1, len(q) + 1) + 0.15 * (j - 0.5), q["mean"], 2 * q["se"], fmt=mk, color=c,
                        capsize=2, label=_LEGEND[n])
        ax.axhline(pub.loc["EKF", E.MODEL_LABELS[w]], color=REFERENCE_COLOR, ls="--", label="published EKF (Table 1)")
        step = 1 if len(seeds) <= 6 or not _phone() else 2
        ax.set_xticks(np.arange(1, len(seeds) + 1, step))
        ax.set_xlabel("100-run set (1: Table 1's)" if seeds and int(seeds[0]) == E.SEEDS["table"]
                      else "100-run set")
        ax.set_ylabel("mean per-run RMSE")
        ax.set_title(f"{_letter(w - 1)} {E.MODEL_LABELS[w]}")
    legend_below(fig, axes, ncol=2)
    return fig


def nsweep_plot(nsweep: dict, res: dict):
    """The PF against the number of particles: mean per-run RMSE (±2 se) with the exact posterior's
    and the EKF's RMSE per model, and the PF's cost relative to the EKF (single run and amortised).
    ``nsweep`` maps model -> :func:`~pfrepro.experiments.ekf_pf_li2012.rmse_and_cost_vs_n`, ``res``
    model -> the Table 1 MonteCarloResult."""
    fig, axes = new_figure(1, 3, figsize=(10.2, 3.8))
    for w, c in zip((1, 2), SERIES_COLORS[:2]):
        d, ax = nsweep[w], axes[0 if w == 1 else 1]
        ax.errorbar(d.index, d["rmse"], 2 * d["se"], fmt="o-", color=c, capsize=3, label="PF (±2 se)")
        ax.axhline(res[w].rmse("Exact").mean(), color=REFERENCE_COLOR, ls=":", lw=2, label="exact posterior mean")
        ax.axhline(res[w].rmse("EKF").mean(), color=method_color("EKF"), ls="--", label="EKF")
        ax.set_xscale("log")
        ax.set_xlabel("particles $N$")
        ax.set_ylabel(f"mean per-run RMSE ({res[w].sim.runs} runs)")
        ax.set_title(f"{_letter(w - 1)} {E.MODEL_LABELS[w]}")
        ax.legend(loc="best")
        if w == 1:
            ax.set_yscale("log")
            _plain_log(ax)
        axes[2].loglog(d.index, d["amortised_ratio"], "o-", color=c, label=f"{E.MODEL_LABELS[w]}, amortised")
        axes[2].loglog(d.index, d["single_run_ratio"], "s--", color=c, label=f"{E.MODEL_LABELS[w]}, single run")
    for ax in axes:
        plain_log(ax, "x", subs=(1.0,))
    plain_log(axes[2], "y", subs=(1.0, 3.0))
    axes[2].set_xlabel("particles $N$")
    axes[2].set_ylabel("PF time / EKF time")
    axes[2].set_title("(c) cost relative to the EKF")
    axes[2].legend(loc="best")
    fig.tight_layout()
    return fig


def degeneracy_vs_n_table(degen_n: dict):
    """l.135 shown: SIS (no resampling) on model 1 at each N of the degeneracy check -- the per-run ESS
    averaged over ``E.ESS_WINDOW`` (mean ± se over runs), its share of N, and the bootstrap PF's model
    evaluations per step (deterministic count)."""
    rows = []
    for n in sorted(degen_n):
        d = degen_n[n]
        late = np.asarray(d["late"], float)
        rows.append({"N": n, "late ESS (particles)": f"{late.mean():.3f} ± {late.std(ddof=1) / np.sqrt(late.size):.3f}",
                     "late ESS / N": f"{late.mean() / n:.2e}", "model evals / step": f"{d['evals']:.0f}"})
    return pd.DataFrame(rows).set_index("N")


def statements_table(reg, results):
    """The statements of secs 0-2 that Table 1 does not test: paper line, what judges it, the verdict."""
    from ..verdicts.ekf_pf_li2012 import STATEMENT_CLAIMS

    by_id = {c.claim_id: c for c in reg.claims}
    rows = []
    for cid, line in STATEMENT_CLAIMS.items():
        c = by_id[cid]
        rows.append({"paper": line, "claim": reader_text(c.text), "judged by": reader_text(c.note),
                     "verdict": c.verdict_text()})
    return pd.DataFrame(rows)


def tables(results) -> dict:
    """The paper's tables from :func:`pfrepro.experiments.ekf_pf_li2012.run_all`'s results:
    ``{"Table 1": DataFrame}`` (:func:`~pfrepro.experiments.ekf_pf_li2012.table1`, ours beside the
    published cells, with the exact posterior's RMSE on the same runs)."""
    return {"Table 1": E.table1(results.res)}


def figures(results) -> dict:
    """The paper's figures from :func:`pfrepro.experiments.ekf_pf_li2012.run_all`'s results:
    Figs. 1-4 (one run and the per-time RMSE of each model, on the figure runs)."""
    return {"Fig. 1": fig1(results.figs), "Fig. 2": fig2(results.figs), "Fig. 3": fig3(results.figs),
            "Fig. 4": fig4(results.figs)}
