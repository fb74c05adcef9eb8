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

__all__ = ["frontier_figure", "STYLE", "benchmarks_table", "ess_table", "ranking_compact", "paper_table",
           "today_table"]

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
    """Readable plain-number ticks on a log axis: decades over a wide range, 1-2-5 over one to
    two decades, a few linear ticks inside one decade."""
    decades = np.log10(hi / lo)
    if decades > 2.2:
        axis.set_major_locator(LogLocator(base=10, subs=(1.0,)))
    elif decades > 0.9:
        axis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    else:
        axis.set_major_locator(MaxNLocator(4))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def frontier_figure(results: dict, axis: str = "count"):
    """One panel per benchmark: MSE / reference against cost per step, log-log, error bars = SE.

    ``axis`` = "count" (model evaluations per step) or "time" (ms per step, single run). The
    baseline's efficient frontier (bootstrap PF, systematic; Liu-West on the θ benchmark) is joined by a line.
    """
    n = len(results)
    ncol = 3
    nrow = int(np.ceil(n / ncol))
    height = 2.45 * nrow + 1.1
    fig, axes = new_figure(nrow, ncol, figsize=(7.5, height), squeeze=False)
    col = "evals/step" if axis == "count" else "ms/step"
    handles = {}
    for ax, (key, r) in zip(axes.ravel(), results.items()):
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
        ax.set_title(f"{key}: {r.bench.title}", fontsize=8.5)
        ax.set_xlabel("model evaluations / step" if axis == "count" else "ms / step (one run)", fontsize=8)
        ax.set_ylabel("MSE / reference", fontsize=8)
        ax.tick_params(labelsize=8)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    ncol_leg = 5
    fig.legend(list(handles.values()), list(handles.keys()), loc="lower center", ncol=ncol_leg, fontsize=8,
               frameon=False, bbox_to_anchor=(0.5, 0.0))
    # room below the panels for the legend's rows (about 0.17 in each) and the x labels
    legend_rows = int(np.ceil(len(handles) / ncol_leg))
    fig.tight_layout(rect=(0, min(0.45, (0.17 * legend_rows + 0.1) / height), 1, 1))
    return fig


def _short(paper: str) -> str:
    """"Zhang et al. 2016" for a paper key (first author and year of :data:`pfrepro.published.PAPERS`)."""
    from ..published import PAPERS

    return PAPERS[paper].split(",")[0] + " " + PAPERS[paper].split("(")[1][:4]


def benchmarks_table(results) -> pd.DataFrame:
    """:func:`pfrepro.experiments.synthesis.benchmarks_table` with the paper as author and year."""
    bt = S.benchmarks_table(results)
    bt["paper"] = [_short(p) for p in bt["paper"]]
    return bt


def ess_table(results) -> pd.DataFrame:
    """The bootstrap PF's effective sample size at the first measurement under both bearings-only
    readings (:func:`pfrepro.experiments.synthesis.bot_ess1`), formatted for the chapter."""
    ess = pd.concat({"offset (as printed)": S.bot_ess1(results["bot"]),
                     "centred (m0 = x0)": S.bot_ess1(results["bot_centred"])}, names=["prior", "filter"])
    ess["N"] = ess["N"].astype(int)
    ess["runs with ESS < 1 % of N"] = (100 * ess["runs with ESS < 1 % of N"]).map(lambda v: f"{v:.0f} %")
    return ess


def ranking_compact(r) -> pd.DataFrame:
    """:func:`pfrepro.verdicts.synthesis.ranking` with few, short columns for the text column."""
    rk = V.ranking(r)
    return pd.DataFrame({"rank": rk["rank"].map(lambda v: "–" if not np.isfinite(v) else f"{v:.0f}"),
                         "MSE / ref.": [f"{m:.3g} ± {s:.2g}" if np.isfinite(m) else "–"
                                        for m, s in zip(rk["MSE / opt."], rk["SE"])],
                         "evals/step": rk["evals/step"].map(lambda v: f"{v:.0f}"),
                         "not shown different / note": rk["tie"]}, index=rk.index)


def paper_table(results) -> pd.DataFrame:
    """The verdicts per paper's method as a table (one row per method and benchmark; the BOT
    starts side by side, the centred one context): distance to the reference, equal-count and equal-time words, z."""
    vt = V.verdict_table(results)
    sub = vt[vt["paper"] != ""]
    rows = []
    for _, row in sub.iterrows():
        fin = np.isfinite(row["MSE / opt."])
        rows.append({"paper": _short(row["paper"]), "benchmark": row["benchmark"], "method": row["method"],
                     "MSE / ref.": f"{row['MSE / opt.']:.3g} ± {row['SE']:.2g}" if fin else "diverged",
                     "by count": row["by count"],
                     "z (count)": f"{row['z count']:+.1f}" if fin and np.isfinite(row["z count"]) else "–",
                     "by time": row["by time"]})
    return pd.DataFrame(rows)


def today_table(results) -> pd.DataFrame:
    """Today's methods against the baseline at equal budget (the claims' rule per comparison,
    ``verdict_table(results, today=True)``): distance to the reference, count, words, z."""
    tv = V.verdict_table(results, today=True)
    tv["MSE / ref."] = [f"{m:.3g} ± {s_:.2g}" if np.isfinite(m) else "diverged"
                        for m, s_ in zip(tv["MSE / opt."], tv["SE"])]
    tv["evals/step"] = [f"{S._cost(results[b], m, 'count'):.0f}" for b, m in zip(tv["benchmark"], tv["method"])]
    tv["z (count)"] = [f"{z:+.1f}" if np.isfinite(z) else "–" for z in tv["z count"]]
    return tv[["benchmark", "method", "MSE / ref.", "evals/step", "by count", "z (count)", "by time"]]
