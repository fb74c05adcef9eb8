"""Figures and tables of the synthesis chapter (``book/70_synthesis.md``): accuracy-cost frontiers,
the rankings, the verdict tables as the chapter shows them.

The experiments are :mod:`pfrepro.experiments.synthesis`, the decisions
:mod:`pfrepro.verdicts.synthesis`; this module only draws and formats them.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.ticker import FuncFormatter, LogLocator, MaxNLocator, NullFormatter

from ..experiments import synthesis as S
from ..plotting import REFERENCE_COLOR, SERIES_COLORS, method_color  # noqa: F401  (the book palette)
from ..verdicts import synthesis as V
from . import new_figure

__all__ = ["frontier_figure", "STYLE", "benchmarks_table", "methods_table", "ess_table", "ranking_compact",
           "paper_table", "today_table", "what_to_use_table", "convergence_table", "MSE_REF", "EVALS"]

#: marker and colour per method family (baselines grey/black, the papers' methods in their colour
#: of the book's palette, :data:`pfrepro.plotting.METHOD_COLORS`)
STYLE = {
    "PF": ("o", "black"), "PF multinomial": ("v", "0.45"), "PF stratified": ("^", "0.45"),
    "PF residual": ("<", "0.45"), "EKF": ("x", "0.35"), "UKF": ("+", "0.35"), "Liu-West": ("o", "black"),
    "GPFF eq43 unif.": ("s", method_color("GPFF")), "GPFF eq43 exp.": ("D", method_color("GPFF")),
    "GPFF eq41 unif.": ("s", "#0e7c8a"), "GPFF eq41 exp.": ("D", "#0e7c8a"),  # the GPFF's cyan, darker
    "CMS-PF": ("*", method_color("CMS-PF")), "ESPF": ("P", method_color("ESPF")), "DPF": ("*", method_color("DPF")),
    "IMMPF": ("o", "black"), "IMM-EKF": ("x", "0.35"), "IMM-UKF": ("+", "0.35"), "IMMPFOR": ("*", method_color("IMMPFOR")),
    # today's methods (issue 22)
    "APF": ("h", method_color("APF")), "RPF": ("d", method_color("RPF")),
    "EKF-prop. PF": ("p", method_color("EKF-prop. PF")), "PFPF-EDH": ("X", method_color("PFPF-EDH")),
    "PFPF-LEDH": ("X", method_color("PFPF-LEDH")), "SMC²": ("H", method_color("SMC²")),
    "JMPF": ("h", method_color("JMPF")),
}


def _log_ticks(axis, lo, hi):
    """Readable plain-number ticks on a log axis: decades over a wide range, 1-3 over one to
    two decades, a few linear ticks inside one decade."""
    decades = np.log10(hi / lo)
    if decades > 2.2:
        axis.set_major_locator(LogLocator(base=10, subs=(1.0,)))
    elif decades > 0.9:
        # 1-3-10: at the book's type sizes 1-2-5 labels run into each other on a narrow panel
        axis.set_major_locator(LogLocator(base=10, subs=(1.0, 3.0)))
    else:
        axis.set_major_locator(MaxNLocator(4))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def frontier_figure(results: dict, axis: str = "count"):
    """One panel per benchmark: MSE / reference against cost per step, log-log, error bars = SE.

    ``axis`` = "count" (model evaluations per step) or "time" (ms per step, single run). The
    baseline's efficient frontier (bootstrap PF, systematic; Liu-West on the θ benchmark) is joined by a line.
    Drawn for the layout it is read in (:func:`pfrepro.plotting.responsive`): the panels reflow (two per row on
    a laptop, one on a phone), the type keeps the layout's size, and the legend sits below the panels in as
    many columns as the width holds.
    """
    import textwrap

    from ..plotting import current_layout

    if axis not in ("count", "time"):
        raise ValueError(f"axis must be 'count' or 'time', got {axis!r}")
    n = len(results)
    ncol = 2      # the laptop's panels per row: no empty row of places below the last panel
    nrow = int(np.ceil(n / ncol))
    fig, axes = new_figure(nrow, ncol, figsize=(6.5, 2.6 * nrow), squeeze=False)
    col = "evals/step" if axis == "count" else "ms/step"
    handles = {}
    flat = [ax for ax in axes.ravel() if ax is not None]
    for ax, (key, r) in zip(flat, results.items()):
        fr = S.frontier(r)
        base = fr.loc[V.efficient_frontier(r, axis)]
        ax.plot(base[col], base["MSE / opt."], "-", color="black", lw=0.9, zorder=1)
        for name, row in fr.iterrows():
            mk, c = STYLE.get(row["family"], ("o", SERIES_COLORS[5]))
            h = ax.errorbar(row[col], row["MSE / opt."], yerr=row["SE"], fmt=mk, color=c, ms=5, capsize=2,
                            lw=0.8, mfc="none" if row["paper"] == "" and mk not in "x+" else c)
            label = row["family"] if row["family"] not in ("PF",) else "bootstrap PF (systematic)"
            handles.setdefault(label, h)
        ax.set_xscale("log")
        ax.set_yscale("log")
        _log_ticks(ax.xaxis, *ax.get_xlim())
        _log_ticks(ax.yaxis, *ax.get_ylim())
        ax.axhline(1.0, color="0.6", lw=0.7, ls=":")
        ax.set_title("\n".join(textwrap.wrap(S.BENCH_NAME.get(key, key), 26, break_on_hyphens=False)))
        ax.set_xlabel("model evaluations / step" if axis == "count" else "ms / step (one run)")
        ax.set_ylabel("MSE / reference")
    for ax in flat[n:]:
        ax.remove()       # an unused place: removed, so no blank panel sits above the legend
    layout = current_layout()
    ncol_leg = 5 if layout is None else (1 if layout.max_cols == 1 else 2)
    fig.tight_layout()
    # just below the lowest panel's labels (the saved drawing, bbox "tight", takes in what hangs below the figure
    # and drops the blank left by a removed place), so no text overlaps a panel
    fig.canvas.draw()
    inv = fig.transFigure.inverted()
    renderer = fig.canvas.get_renderer()
    bottom = min(ax.get_tightbbox(renderer).transformed(inv).y0 for ax in flat[:n])
    fig.legend(list(handles.values()), list(handles.keys()), loc="upper center", ncol=ncol_leg, frameon=False,
               bbox_to_anchor=(0.5, bottom - 0.01))
    return fig


def _short(paper: str) -> str:
    """"Zhang et al. 2016" for a paper key (first author and year of :data:`pfrepro.published.PAPERS`)."""
    from ..published import PAPERS

    return PAPERS[paper].split(",")[0] + " " + PAPERS[paper].split("(")[1][:4]


#: column headers in words (the tables' shared columns)
MSE_REF = "MSE / reference (± SE)"
EVALS = "model evaluations per step"


def benchmarks_table(results) -> pd.DataFrame:
    """:func:`pfrepro.experiments.synthesis.benchmarks_table` for the reader: benchmarks by name, the paper as
    author and year, headers in words."""
    bt = S.benchmarks_table(results)
    bt["paper"] = [_short(p) for p in bt["paper"]]
    bt.index = [S.BENCH_NAME.get(k, k) for k in bt.index]
    bt.index.name = "benchmark"
    return bt.rename(columns={"T": "time steps", "methods": "methods run"})


def methods_table(results) -> pd.DataFrame:
    """Which method families ran on which benchmark, whose they are (:func:`pfrepro.experiments.synthesis.methods_table`),
    for the reader: papers as author and year, benchmarks by name."""
    mt = S.methods_table(results)
    mt["paper"] = [_short(p) if p != "(baseline)" else "baseline" for p in mt["paper"]]
    mt["benchmarks"] = ["; ".join(S.BENCH_NAME.get(k, k) for k in b.split(", ")) for b in mt["benchmarks"]]
    mt.index.name = "method"
    return mt


def ess_table(results) -> pd.DataFrame:
    """The bootstrap PF's effective sample size at the first measurement under both bearings-only
    readings (:func:`pfrepro.experiments.synthesis.bot_ess1`), formatted for the chapter."""
    ess = pd.concat({"printed (offset)": S.bot_ess1(results["bot"]),
                     "centred on the truth's start": S.bot_ess1(results["bot_centred"])}, names=["prior", "filter"])
    ess["N"] = ess["N"].astype(int)
    ess["runs with ESS < 1 % of N"] = (100 * ess["runs with ESS < 1 % of N"]).map(lambda v: f"{v:.0f} %")
    ess["mean ESS at k=1"] = ess["mean ESS at k=1"].map(lambda v: f"{v:.1f}")
    ess["median"] = ess["median"].map(lambda v: f"{v:.1f}")
    return ess.rename(columns={"N": "particles", "mean ESS at k=1": "mean ESS at the first step",
                               "median": "median ESS", "runs with ESS < 1 % of N": "runs with ESS below 1 % of N"})


def ranking_compact(r) -> pd.DataFrame:
    """:func:`pfrepro.verdicts.synthesis.ranking` with few, short columns for the text column."""
    rk = V.ranking(r)
    out = pd.DataFrame({"rank": rk["rank"].map(lambda v: "–" if not np.isfinite(v) else f"{v:.0f}"),
                        MSE_REF: [f"{m:.3g} ± {s:.2g}" if np.isfinite(m) else "–"
                                  for m, s in zip(rk["MSE / opt."], rk["SE"])],
                        EVALS: rk["evals/step"].map(lambda v: f"{v:.0f}"),
                        "not shown different from (lower mean) / note": rk["tie"]}, index=rk.index)
    out.index.name = "method"
    return out


def paper_table(results) -> pd.DataFrame:
    """The verdicts per paper's method as a table (one row per method and benchmark; the BOT
    starts side by side, the centred one context): distance to the reference, equal-count and equal-time words, z."""
    vt = V.verdict_table(results)
    sub = vt[vt["paper"] != ""]
    rows = []
    for _, row in sub.iterrows():
        fin = np.isfinite(row["MSE / opt."])
        rows.append({"paper": _short(row["paper"]), "benchmark": S.BENCH_NAME.get(row["benchmark"], row["benchmark"]),
                     "method": row["method"],
                     MSE_REF: f"{row['MSE / opt.']:.3g} ± {row['SE']:.2g}" if fin else "diverged",
                     "at equal count": row["by count"],
                     "z at equal count": f"{row['z count']:+.1f}" if fin and np.isfinite(row["z count"]) else "–",
                     "at equal time (context)": row["by time"]})
    return pd.DataFrame(rows)


def today_table(results) -> pd.DataFrame:
    """Today's methods against the baseline at equal budget (the claims' rule per comparison,
    ``verdict_table(results, today=True)``): distance to the reference, count, words, z."""
    tv = V.verdict_table(results, today=True)
    out = pd.DataFrame({
        "benchmark": [S.BENCH_NAME.get(b, b) for b in tv["benchmark"]], "method": tv["method"],
        MSE_REF: [f"{m:.3g} ± {s_:.2g}" if np.isfinite(m) else "diverged" for m, s_ in zip(tv["MSE / opt."], tv["SE"])],
        EVALS: [f"{S._cost(results[b], m, 'count'):.0f}" for b, m in zip(tv["benchmark"], tv["method"])],
        "at equal count": tv["by count"],
        "z at equal count": [f"{z:+.1f}" if np.isfinite(z) else "–" for z in tv["z count"]],
        "at equal time (context)": tv["by time"]})
    return out


def what_to_use_table(results) -> pd.DataFrame:
    """:func:`pfrepro.verdicts.synthesis.what_to_use` for the reader (the benchmark keys dropped)."""
    return V.what_to_use(results).drop(columns="key")


def convergence_table(rc: dict) -> pd.DataFrame:
    """The bearings-only reference's convergence (:func:`pfrepro.verdicts.synthesis.reference_convergence`),
    formatted: one row per particle number."""
    t = rc["table"]
    return pd.DataFrame({
        "distance² between two independent runs (± SE)": [f"{d:.3g} ± {s:.2g}" for d, s in
                                                          zip(t["distance² between replicates"], t["its standard error"])],
        "particles × distance²": t["particles × distance²"].map(lambda v: f"{v:.3g}"),
        "MSE against the truth": t["MSE against the truth"].map(lambda v: f"{v:.3g}")}, index=t.index)
