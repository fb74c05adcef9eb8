"""Figures and tables of Ning, Chen, Zhao, He, Shi (2011), chaos map sampling PF
(chapter ``book/40_cmspf.md``).

The experiments are :mod:`pfrepro.experiments.cmspf_ning2011` (``run_all``); this module only
draws their results and sets them beside the published tables: :func:`tables` and
:func:`figures` give the command line (``pfrepro run cmspf``) the chapter's tables and figures.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from .. import published
from ..bookinfo import reader_text
from ..experiments import cmspf_ning2011 as E
from ..plotting import REFERENCE_COLOR, SERIES_COLORS, method_color  # noqa: F401  (the book palette)
from . import new_figure
from ._layout import legend_below, letter, phone, plain_log

__all__ = ["printed", "styled", "divisor_check", "fig3_times", "timing_figures", "table1_per_run_long", "table1_strip", "sensitivity_fig",
           "table1_side_by_side", "table1_summary", "table2_vs_published", "table3_vs_published",
           "table1_plot", "fig2", "fig3", "fig_one_step", "fig6", "table3_per_run", "mechanism_table", "oracle_table",
           "consistency_fig", "consistency_table", "tables", "figures", "TABLES", "FIGURES", "N_STEPS"]

TABLES = ("Table 1", "Table 1 (means)", "Table 2", "Table 3")
FIGURES = ("Fig. 2", "Fig. 3", "Fig. 4", "Fig. 5", "Fig. 6")
#: the progress steps of :func:`pfrepro.experiments.cmspf_ning2011.run_all`
N_STEPS = len(E.STEPS)
TABLE2_FILTERS = ["EKF", "UKF", "PF", "ESPF", "CMS-PF"]


def printed(table_id: str) -> pd.DataFrame:
    """A published table as the paper prints it: the value strings of the data file (no float
    round trip, so 179.3805 stays 179.3805 wherever it is shown)."""
    from importlib import resources

    path = resources.files("pfrepro") / "data" / "published" / f"{E.PAPER}.csv"
    with path.open("r", encoding="utf-8") as fh:
        df = pd.read_csv(fh, comment="#", dtype=str)
    sub = df[df["table"] == table_id]
    if sub.empty:
        raise KeyError(f"{E.PAPER} has no published table {table_id!r}")
    rows, cols = list(dict.fromkeys(sub["row"])), list(dict.fromkeys(sub["column"]))
    return sub.pivot(index="row", columns="column", values="value").loc[rows, cols]


def styled(df: pd.DataFrame, digits: int = 3, na_rep: str = "—"):
    """A table for the page: our numbers to ``digits`` decimals, the paper's printed strings as
    they are, and an empty cell (no value exists, e.g. the paper has none) shown as ``na_rep``."""
    return df.style.format(precision=digits, na_rep=na_rep)


def divisor_check(table_id: str, runs=range(1, 21), tol: float = 2e-4) -> pd.DataFrame:
    """Which divisor reproduces each column's printed variance (row 22) from its printed rows.

    For every column: the printed mean (row 21) and variance (row 22) as strings, the mean
    of the rows, their variance with divisor n - 1 and with divisor n, and which of the two
    matches the printed value (relative difference below ``tol``, the rounding of
    four printed digits; "neither" when no divisor reproduces it)."""
    pt = printed(table_id)
    rows = [str(i) for i in runs]
    out = {}
    for c in pt.columns:
        v = pt.loc[rows, c].astype(float).to_numpy()
        pv, pm = float(pt.loc["22", c]), float(pt.loc["21", c])
        v1, v0 = float(v.var(ddof=1)), float(v.var(ddof=0))
        r1, r0 = abs(v1 - pv) / pv, abs(v0 - pv) / pv
        match = "n − 1" if r1 < tol and r1 <= r0 else ("n" if r0 < tol else "neither")
        out[c] = {"printed mean (row 21)": pt.loc["21", c], "mean of the rows": v.mean(),
                  "printed variance (row 22)": pt.loc["22", c], "variance, divisor n − 1": v1,
                  "variance, divisor n": v0, "divisor that matches": match,
                  "mean matches": abs(v.mean() - pm) < 1e-4 + 1e-4 * abs(pm)}
    return pd.DataFrame(out).T.rename_axis("column")


def step_checks_shown(checks: pd.DataFrame):
    """:func:`pfrepro.experiments.cmspf_ning2011.step_checks` for the page: the paper's statements
    and the checks with symbols for the plain-text subscripts (``x_k`` -> ``xₖ``), as HTML whose rows
    become cards on a phone (:func:`pfrepro.bookinfo.labelled_table_html`, class ``pf-steps``)."""
    import html

    from IPython.display import HTML

    from ..bookinfo import labelled_table_html

    out = checks.copy()
    for col in ("paper", "check"):
        if col in out:
            out[col] = out[col].map(lambda v: reader_text(str(v)))
    if "deviation" in out:
        out["deviation"] = [f"{v:.2g}" for v in out["deviation"]]
    if "passes" in out:
        out["passes"] = ["yes" if bool(v) else "no" for v in out["passes"]]
    out = out.rename_axis("step").reset_index()
    return HTML(labelled_table_html(out.map(lambda v: html.escape(str(v))), classes="pf-claims pf-text pf-steps"))


def divisor_shown(checks: dict) -> pd.DataFrame:
    """The divisor checks of several tables for the page, at most eight columns: ``checks`` maps a
    table label to :func:`divisor_check`'s frame; the mean of the rows carries a ✓ where it matches
    the printed mean (✗ where not) instead of a column of its own."""
    out = []
    for label, d in checks.items():
        d = d.copy()
        d["mean of the rows"] = [f"{m:.4f} {'✓' if ok else '✗'}" for m, ok in zip(d["mean of the rows"], d["mean matches"])]
        out.append(d.drop(columns=["mean matches"]).assign(table=label).set_index("table", append=True)
                   .swaplevel(0, 1))
    return pd.concat(out)


def _pm(m, se, digits: int = 3) -> list:
    return ["—" if pd.isna(a) else (f"{a:.{digits}f}" if pd.isna(b) else f"{a:.{digits}f} ± {b:.{digits}f}")
            for a, b in zip(m, se)]


def table1_summary_shown(summary: pd.DataFrame) -> pd.DataFrame:
    """:func:`table1_summary` for the page, at most eight columns: ours as "mean ± se" beside the
    paper's printed mean, the noise readings in symbols."""
    out = pd.DataFrame({"PF, paper": summary["PF paper"], "PF, ours": _pm(summary["PF ours"], summary["PF se"]),
                        "CMS-PF, paper": summary["CMS-PF paper"],
                        "CMS-PF, ours": _pm(summary["CMS-PF ours"], summary["CMS-PF se"]),
                        "PF with 2N, ours": [f"{v:.3f}" for v in summary["PF with 2N ours"]]}, index=summary.index)
    for col, name in (("CMS-PF ours (sigma_w^2=10)", "CMS-PF, ours, σ_w² = 10"), ("PF ours (sigma_w^2=10)", "PF, ours, σ_w² = 10")):
        if col in summary:
            out[name] = [f"{v:.3f}" for v in summary[col]]
    return out


def table2_shown(tab2: pd.DataFrame) -> pd.DataFrame:
    """:func:`table2_vs_published` for the page, at most eight columns: our RMSE as "mean ± se",
    the noise reading in symbols, counts as whole numbers."""
    out = pd.DataFrame({"RMSE, paper": tab2["RMSE paper"], "RMSE, ours": _pm(tab2["RMSE ours"], tab2["se"])},
                       index=tab2.index)
    if "RMSE ours (sigma_w^2=10)" in tab2:
        out["RMSE, ours, σ_w² = 10"] = ["—" if pd.isna(v) else f"{v:.3f}" for v in tab2["RMSE ours (sigma_w^2=10)"]]
    out["seconds, paper (printed)"] = tab2["time/s paper (printed)"]
    for col in ("time ratio to PF, paper", "time ratio to PF, ours"):
        out[col] = ["—" if pd.isna(v) else f"{v:.2f}" for v in tab2[col]]
    out["likelihoods per step"] = ["—" if pd.isna(v) else f"{v:.0f}" for v in tab2["likelihood evaluations / step"]]
    return out.fillna("—")


def table1_per_run_long(per_run: pd.DataFrame) -> pd.DataFrame:
    """Table 1's per-run RMSEs, the paper's (printed strings) and ours, one row per run, N and filter."""
    pt = printed("Table 1")
    rows = []
    for N in E.TABLE1_N:
        for f in ("PF", "CMS-PF"):
            for i in range(1, len(per_run) + 1):
                rows.append({"N": N, "filter": f, "run": i,
                             "paper": pt.loc[str(i), f"N={N} {f}"] if i <= 20 else None,
                             "ours": float(per_run[(N, f)].iloc[i - 1])})
    return pd.DataFrame(rows)


def table1_strip(per_run: pd.DataFrame, grid_rmse=None):
    """Table 1 as two distributions per setting: the paper's 20 per-run RMSEs (rows 1-20) and our
    20, side by side for each N, one panel per filter ((a) PF, (b) CMS-PF; the runs are independent
    draws: only the distributions, not run i against run i, can be compared). Bars: the means."""
    from matplotlib.lines import Line2D

    pub = published.table(E.PAPER, "Table 1")
    fig, axs = new_figure(1, 2, figsize=(10.2, 4.4), sharey=True)
    rng = np.random.default_rng(0)  # horizontal jitter of the dots only (display)
    for i, (ax, f) in enumerate(zip(axs, ("PF", "CMS-PF"))):
        col = method_color(f)
        for j, N in enumerate(E.TABLE1_N):
            for s_, (src, vals) in enumerate((("paper", pub.loc[[str(i) for i in range(1, 21)], f"N={N} {f}"].to_numpy(float)),
                                              ("ours", per_run[(N, f)].to_numpy()))):
                x0 = j * 3 + s_
                ax.plot(x0 + rng.uniform(-0.25, 0.25, vals.size), vals, "o" if src == "ours" else "x", ms=3.5,
                        color=col, mfc="none" if src == "paper" else col, alpha=0.8)
                ax.plot([x0 - 0.35, x0 + 0.35], [vals.mean()] * 2, color="k", lw=1.5)
        if grid_rmse is not None:
            ax.axhline(np.mean(grid_rmse), color="grey", lw=1, ls=":")
        ax.set_xticks([j * 3 + 0.5 for j in range(len(E.TABLE1_N))], [str(N) for N in E.TABLE1_N])
        ax.set_xlabel("particles $N$")
        ax.set_ylabel("per-run RMSE")
        ax.set_title(f"{letter(i)} {f}")
    handles = [Line2D([], [], marker="x", ls="", color="0.3"), Line2D([], [], marker="o", ls="", color="0.3"),
               Line2D([], [], color="k"), Line2D([], [], color="grey", ls=":")]
    labels = ["paper (rows 1–20)", "ours (20 runs)", "mean", "exact posterior mean"]
    if grid_rmse is None:
        handles, labels = handles[:3], labels[:3]
    legend_below(fig, axs, ncol=2, handles=handles, labels=labels)
    return fig


SENS_LABELS = {"eta": r"adjustment factor $\eta$", "big_fraction": r"$n_\mathrm{big}/N$", "n_th": r"$N_\mathrm{th}/N$",
               "carrier": "carrier", "u": "logistic $u$", "burn_in": r"burn-in $T_0$", "init": "carrier initialisation"}


def sensitivity_fig(sens: pd.DataFrame, sens_ref: dict):
    """CMS-PF's mean RMSE against each unstated setting, one panel per setting (star: the chosen
    value), with the PF and the exact posterior mean; laid out two panels wide so that the text
    stays legible at the book's column width."""
    pars = list(dict.fromkeys(sens["parameter"]))
    nrow = (len(pars) + 2) // 2
    fig, axs = new_figure(nrow, 2, figsize=(7, 2.6 * nrow), sharey=True)
    axs = np.atleast_2d(axs)
    for ax, par in zip(axs.flat, pars):
        s = sens[sens.parameter == par]
        x = np.arange(len(s))
        ax.errorbar(x, s["RMSE"], 2 * s["se"], marker="o", capsize=3, color=method_color("CMS-PF"), label="CMS-PF (±2 se)")
        ch = s["chosen"].to_numpy(bool)
        ax.plot(x[ch], s["RMSE"].to_numpy()[ch], "r*", ms=12, label="chosen value")
        ax.set_xticks(x, [f"{v:.3g}" if not isinstance(v, str) else v for v in s["value"]],
                      rotation=45 if len(s) > 4 or any(isinstance(v, str) for v in s["value"]) else 0,
                      ha="right" if len(s) > 4 or any(isinstance(v, str) for v in s["value"]) else "center",
                      rotation_mode="anchor")
        ax.axhline(sens_ref["PF"]["mean"], color=method_color("PF"), ls="--", label="PF")
        ax.axhline(sens_ref["Grid (exact)"]["mean"], color="k", lw=1, label="exact posterior mean")
        ax.set_xlabel(SENS_LABELS.get(par, par))
    for ax in axs.flat[:len(pars)]:
        ax.set_ylabel("mean RMSE")
    for ax in list(axs.flat)[len(pars):]:
        ax.remove()
    legend_below(fig, list(axs.flat)[:len(pars)], ncol=2)
    return fig


def table1_side_by_side(per_run: pd.DataFrame) -> pd.DataFrame:
    """Table 1 as printed (rows 1-20 per-run RMSE, 21 mean, 22 variance) beside ours, plus our se.

    ``per_run`` is :func:`pfrepro.experiments.cmspf_ning2011.table1`'s first output.
    """
    pub1 = published.table(E.PAPER, "Table 1")
    runs = len(per_run)
    if runs != 20:
        raise ValueError(f"table1_side_by_side sets the paper's 20 runs beside ours; got {runs} runs "
                         "(use table1_summary for other counts)")
    cols = {}
    for N in E.TABLE1_N:
        for f in ("PF", "CMS-PF"):
            o = per_run[(N, f)].to_numpy()
            col = np.r_[o, o.mean(), o.var(ddof=1), o.std(ddof=1) / np.sqrt(len(o))]
            p = pub1[f"N={N} {f}"].to_numpy()
            cols[(f"N={N}", f, "paper")] = np.r_[p, np.nan]
            cols[(f"N={N}", f, "ours")] = col
    idx = [str(i) for i in range(1, 21)] + ["21 (mean)", "22 (variance)", "se"]
    return pd.DataFrame(cols, index=idx)


def table1_summary(per_run: pd.DataFrame, per_run_q10: pd.DataFrame | None = None) -> pd.DataFrame:
    """Table 1's mean row: published and our mean RMSE (se) of PF and CMS-PF, and PF with 2N, by N;
    with ``per_run_q10`` (the runs under sigma_w^2 = 10) also our CMS-PF and PF means there."""
    pub1 = printed("Table 1")
    m1 = per_run.mean().unstack()
    se1 = (per_run.std(ddof=1) / np.sqrt(len(per_run))).unstack()
    out = pd.DataFrame({
        "PF paper": [pub1.loc["21", f"N={N} PF"] for N in E.TABLE1_N],
        "PF ours": m1["PF"], "PF se": se1["PF"],
        "CMS-PF paper": [pub1.loc["21", f"N={N} CMS-PF"] for N in E.TABLE1_N],
        "CMS-PF ours": m1["CMS-PF"], "CMS-PF se": se1["CMS-PF"],
        "PF with 2N ours": m1["PF (2N)"],
    }, index=pd.Index(E.TABLE1_N, name="N"))
    if per_run_q10 is not None:
        m10 = per_run_q10.mean().unstack()
        out["CMS-PF ours (sigma_w^2=10)"] = m10["CMS-PF"]
        out["PF ours (sigma_w^2=10)"] = m10["PF"]
    return out


def table2_vs_published(t2: pd.DataFrame, t2_q10: pd.DataFrame | None = None) -> pd.DataFrame:
    """Table 2 beside the published one: RMSE (se), the paper's printed seconds (Matlab 7.1, 2.4 GHz) and
    the time ratio to the PF they give beside ours, likelihood evaluations."""
    pub2 = published.table(E.PAPER, "Table 2")
    p2 = printed("Table 2")
    cols = {"RMSE paper": pd.Series({n: p2.loc["RMSE", n] for n in TABLE2_FILTERS}),
            "RMSE ours": t2["mean"], "se": t2["se"]}
    if t2_q10 is not None:
        cols["RMSE ours (sigma_w^2=10)"] = t2_q10["mean"]
    cols.update({
        "time/s paper (printed)": pd.Series({n: p2.loc["time/s", n] for n in TABLE2_FILTERS}),
        "time ratio to PF, paper": pd.Series({n: pub2.loc["time/s", n] / pub2.loc["time/s", "PF"] for n in TABLE2_FILTERS}),
        "time ratio to PF, ours": t2["time ratio to PF"],
        "likelihood evaluations / step": t2["likelihood evaluations / step"]})
    return pd.DataFrame(cols).reindex(TABLE2_FILTERS + ["CMS-PF (incl. carrier)", "PF (2N)", "Grid (exact)",
                                                        "Oracle CMS-PF (uses truth)"])


def table3_vs_published(t3: pd.DataFrame, t3_q10: pd.DataFrame | None = None) -> pd.DataFrame:
    """Table 3's mean (row 21) and variance (row 22) beside ours, plus the PF and the exact posterior mean."""
    pub3 = printed("Table 3")
    cols3 = list(E.TABLE3_COLUMNS)
    mean3, se3 = t3.mean(), t3.std(ddof=1) / np.sqrt(len(t3))
    data = {"paper mean (row 21)": pub3.loc["21", cols3], "ours mean": mean3[cols3], "ours se": se3[cols3],
            "paper variance (row 22)": pub3.loc["22", cols3], "ours variance": t3.var(ddof=1)[cols3]}
    extra = ["ours mean", "ours se"]
    if t3_q10 is not None:
        data["ours mean (sigma_w^2=10)"] = t3_q10.mean()[cols3]
        extra.append("ours mean (sigma_w^2=10)")
    tab3 = pd.DataFrame(data)
    for label, col in (("PF (N=200)", "PF"), ("exact posterior mean", "Grid (exact)")):
        vals = [mean3[col], se3[col]] + ([t3_q10.mean()[col]] if t3_q10 is not None else [])
        tab3.loc[label, extra] = vals
    return tab3


def table1_plot(per_run: pd.DataFrame, grid_rmse):
    """Table 1 as a plot: mean RMSE (±2 se) of PF, CMS-PF and PF(2N) against N, beside the paper's."""
    s = table1_summary(per_run)
    m1, se1 = per_run.mean().unstack(), (per_run.std(ddof=1) / np.sqrt(len(per_run))).unstack()
    fig, ax = new_figure(figsize=(7, 7) if phone() else (7, 4))
    Ns = np.array(E.TABLE1_N)
    ax.errorbar(Ns, m1["PF"], 2 * se1["PF"], marker="o", capsize=3, color=method_color("PF"), label="PF (ours)")
    ax.errorbar(Ns * 1.04, m1["CMS-PF"], 2 * se1["CMS-PF"], marker="s", capsize=3, color=method_color("CMS-PF"), label="CMS-PF (ours)")
    ax.plot(Ns, m1["PF (2N)"], "^-", color=method_color("PF"), mfc="none", label="PF with 2N particles (ours)")
    ax.plot(Ns, s["PF paper"].astype(float), "o--", color=method_color("PF"), alpha=0.6, label="PF (paper)")
    ax.plot(Ns, s["CMS-PF paper"].astype(float), "s--", color=method_color("CMS-PF"), alpha=0.6, label="CMS-PF (paper)")
    ax.axhline(np.mean(grid_rmse), color="k", lw=1, label="exact posterior mean (grid)")
    ax.set_xscale("log"); ax.set_xlabel("number of particles $N$"); ax.set_ylabel(f"mean RMSE ({len(per_run)} runs)")
    plain_log(ax, "x", subs=(1.0,) if phone() else (1.0, 2.0, 5.0))
    ax.set_title(r"Table 1, $\sigma_v = 1$ (bars: ±2 se)")
    legend_below(fig, ax, ncol=2)
    return fig


def fig2(f2):
    """Fig. 2: one run, truth, EKF, CMS-PF and the exact posterior mean (``f2`` = ``E.fig2_run()``)."""
    k = np.arange(1, f2.sim.T + 1)
    fig, ax = new_figure(figsize=(8, 6.5) if phone() else (8, 4))
    ax.plot(k, f2.x_true[0, :, 0], "k.-", label="true state")
    ax.plot(k, f2.results["EKF"].x[0, :, 0], "o-", mfc="none", color=method_color("EKF"), label=f"EKF (RMSE {f2.rmse('EKF')[0]:.2f})")
    ax.plot(k, f2.results["CMS-PF"].x[0, :, 0], "*-", color=method_color("CMS-PF"), label=f"CMS-PF, N = 200 (RMSE {f2.rmse('CMS-PF')[0]:.2f})")
    ax.plot(k, f2.results["Grid (exact)"].x[0, :, 0], "--", color="grey",
            label=f"exact posterior mean (RMSE {f2.rmse('Grid (exact)')[0]:.2f})")
    ax.set_xlabel("time step $k$"); ax.set_ylabel("state $x_k$"); ax.set_title(r"Fig. 2: one run, $\sigma_v^2 = 1$")
    legend_below(fig, ax, ncol=2)
    return fig


def _fig3_time_lines(ax, f3: pd.DataFrame, idx) -> None:
    """Fig. 3's measured time per run of CMS-PF and PF, relative to the PF at the first N, on ``ax``."""
    ax.plot(idx, f3["CMS-PF time [s]"] / f3["PF time [s]"].iloc[0], "s--", color=method_color("CMS-PF"), mfc="none",
            label=f"CMS-PF time / PF(N={f3.index[0]}) time")
    ax.plot(idx, f3["PF time [s]"] / f3["PF time [s]"].iloc[0], "o--", color=method_color("PF"), mfc="none",
            label=f"PF time / PF(N={f3.index[0]}) time")
    ax.set_ylabel("time per run, relative")


def _fig3_n_axis(ax, f3: pd.DataFrame, idx) -> None:
    ax.set_xticks(idx, [str(n) if (i % 2 == 0 or not phone()) else "" for i, n in enumerate(f3.index)],
                  rotation=90 if phone() else 45)
    ax.set_xlabel("number of particles $N$")


def fig3(f3: pd.DataFrame, f3_grid: dict, times: bool = True):
    """Fig. 3: RMSE (±2 se) and, with ``times``, relative time per run of CMS-PF and PF against N
    (``E.fig3()``); ``times=False`` (``pfrepro run``) leaves the measured times to :func:`fig3_times`,
    so the results files do not change with the machine's load."""
    fig, ax = new_figure(figsize=(8, 8) if phone() else (8, 4))
    idx = np.arange(1, len(f3) + 1)
    ax.errorbar(idx, f3["CMS-PF RMSE"], 2 * f3["CMS-PF se"], marker="s", capsize=3, color=method_color("CMS-PF"), label="CMS-PF RMSE")
    ax.errorbar(idx, f3["PF RMSE"], 2 * f3["PF se"], marker="o", capsize=3, color=method_color("PF"), label="PF RMSE")
    ax.axhline(f3_grid["mean"], color="k", lw=1, label="exact posterior mean RMSE")
    _fig3_n_axis(ax, f3, idx)
    ax.set_ylabel("mean RMSE")
    axes, (h, lab) = [ax], ax.get_legend_handles_labels()
    if times:
        ax2 = ax.twinx()
        _fig3_time_lines(ax2, f3, idx)
        h2, l2 = ax2.get_legend_handles_labels()
        axes, h, lab = [ax, ax2], h + h2, lab + l2
    ax.set_title(r"Fig. 3, $\sigma_v = 10$ (bars ±2 se)")
    legend_below(fig, axes, ncol=2, handles=h, labels=lab)
    return fig


def fig3_times(f3: pd.DataFrame):
    """Fig. 3's measured times alone: time per run of CMS-PF and PF against N, relative to the PF at
    the first N (wall clock: differs between runs; ``pfrepro run`` writes it to its timings)."""
    fig, ax = new_figure(figsize=(8, 4))
    idx = np.arange(1, len(f3) + 1)
    _fig3_time_lines(ax, f3, idx)
    _fig3_n_axis(ax, f3, idx)
    ax.set_title("Fig. 3, measured time per run (context)")
    legend_below(fig, [ax], ncol=2)
    return fig


def fig_one_step(d: dict, title: str):
    """Figs. 4-5: one step with and without mapping (``d`` = ``E.one_step(carrier)``), six panels:
    (a)-(c) particle positions along the state axis, (d)-(f) their normalised weights."""
    import textwrap

    fig, axs = new_figure(2, 3, figsize=(10.2, 6.4))
    N = d["N"]

    def strip(ax, rows, name):
        for y, (x, mk, lab) in enumerate(rows):
            ax.plot(x, np.full(np.size(x), 0.3 * y), mk, mfc="none" if mk == "o" else None, ms=5, label=lab)
        if name != "a":
            ax.axvline(d["x_true"], color="k", lw=1, label="true state")
        ax.set_ylim(-0.3, 1.6)   # room above the particles for the legend
        ax.set_yticks([]); ax.set_xlabel("$x$")
        ax.legend(loc="upper center", ncol=1, frameon=False, handlelength=1.0, handletextpad=0.4)

    strip(axs[0, 0], [(d["x_prev"], "o", "particles at $k-1$"), (d["x_map"], "*", "map particles")], "a")
    axs[0, 0].set_title("(a) before prediction, map")
    strip(axs[0, 1], [(d["x_pred"], "o", "predicted"), (d["x_map"], "*", "map")], "b")
    axs[0, 1].set_title("(b) predicted and map particles")
    strip(axs[0, 2], [(d["x_pred"], "o", "without map"), (d["x_sel"], "*", "with map (kept)")], "c")
    axs[0, 2].set_title("(c) particle sets")
    axs[1, 0].stem(d["x_pred"], d["w_plain"], markerfmt="o"); axs[1, 0].set_title("(d) weights without mapping")
    lw = np.r_[d["ll_pred"], d["ll_map"]]; wc = np.exp(lw - lw.max()); wc /= wc.sum()
    axs[1, 1].stem(np.r_[d["x_pred"], d["x_map"]], wc, markerfmt="."); axs[1, 1].set_title("(e) predicted + map")
    axs[1, 2].stem(d["x_sel"], d["w_sel"], markerfmt="*"); axs[1, 2].set_title("(f) weights with mapping")
    for ax in axs[1]:
        ax.axvline(d["x_true"], color="k", lw=1); ax.set_xlabel("$x$"); ax.set_ylabel("normalised weight")
    fig.suptitle(textwrap.fill(title, 28) if phone() else title)
    fig.tight_layout()
    return fig


def fig6(f6_base: dict, f6_maps: dict, sens: pd.DataFrame | None = None, sens_ref: dict | None = None):
    """Fig. 6: map particles for several adjustment factors alpha; with ``sens`` (``E.sensitivity()``)
    a second panel shows CMS-PF's RMSE against alpha beside the PF and the exact posterior mean."""
    fig, axs = new_figure(1, 2 if sens is not None else 1, figsize=(10.2, 4) if sens is not None else (6, 4))
    ax0 = axs[0] if sens is not None else axs
    for i, (a, x2) in enumerate(f6_maps.items()):
        ax0.plot(x2, np.full(x2.size, i), "|", ms=10)
    ax0.plot(f6_base["x_pred"], np.full(f6_base["N"], -1), "|", ms=10, color="grey")
    ax0.axvline(f6_base["x_true"], color="k", lw=1)
    ax0.set_yticks(range(-1, len(f6_maps)), ["predicted"] + [rf"$\alpha$ = {a}" for a in f6_maps])
    ax0.set_xlabel("$x$"); ax0.set_title(f"(a) Fig. 6: map particles, $N$ = {f6_base['N']}")
    if sens is not None:
        se_eta = sens[sens.parameter == "eta"]
        axs[1].errorbar(se_eta["value"], se_eta["RMSE"], 2 * se_eta["se"], marker="o", capsize=3, color=method_color("CMS-PF"), label="CMS-PF")
        axs[1].axhline(sens_ref["PF"]["mean"], color=method_color("PF"), ls="--", label="PF")
        axs[1].axhline(sens_ref["Grid (exact)"]["mean"], color="k", lw=1, label="exact posterior mean")
        axs[1].axvspan(0.2, 0.8, color="grey", alpha=0.15, label="paper's range [0.2, 0.8]")
        axs[1].set_xscale("log")
        axs[1].set_xlabel(r"adjustment factor $\alpha$ ($\eta$)"); axs[1].set_ylabel("mean RMSE")
        plain_log(axs[1], "x", subs=(1.0,))
        axs[1].set_title(r"(b) RMSE against $\alpha$ ($\sigma_v = 1$, $N$ = 200)" if not phone()
                         else r"(b) RMSE against $\alpha$")
        legend_below(fig, axs[1], ncol=2)
    else:
        fig.tight_layout()
    return fig


def table3_per_run(t3: pd.DataFrame) -> pd.DataFrame:
    """Table 3's per-run RMSEs, the paper's (printed strings, rows 1-20) beside ours, one row per run."""
    cols3 = list(E.TABLE3_COLUMNS)
    pr3 = printed("Table 3")
    return pd.concat({"paper (printed)": pr3.loc[[str(i) for i in range(1, 21)], cols3].set_axis(range(1, 21)),
                      "ours": t3[cols3]}, axis=1).rename_axis("run")


def mechanism_table(mech: pd.DataFrame) -> pd.DataFrame:
    """The mechanism's sets (``E.mechanism()``): distinct fraction, repeated particles and KS distance
    from uniform, each averaged over the runs."""
    tab = mech.mean().unstack()[["distinct", "duplicates", "ks"]].dropna(how="all")
    tab.columns = ["distinct fraction", "repeated particles", "KS distance from uniform"]
    return tab


def oracle_table(t3: pd.DataFrame, t3_oracle: pd.DataFrame) -> pd.DataFrame:
    """Table 3's CMS columns: the paper's printed means, our CMS-PF (a filter) and the oracle that
    centres the map on the true state (``E.table3_oracle``), with the exact posterior mean."""
    cols = list(E.TABLE3_COLUMNS[2:])
    mean3 = t3.mean()
    tab = pd.DataFrame({"paper mean (printed)": printed("Table 3").loc["21", cols], "CMS-PF (filter), ours": mean3[cols],
                        "ORACLE CMS-PF (uses true state), ours": t3_oracle.mean()[cols]})
    tab.loc["exact posterior mean", "CMS-PF (filter), ours"] = mean3["Grid (exact)"]
    return tab


def consistency_fig(cons: pd.DataFrame):
    """RMS distance of the PF's and the CMS-PF's estimates to the exact posterior mean against N
    (``E.consistency()``, ±2 se, log scales)."""
    fig, ax = new_figure(figsize=(6, 5.5) if phone() else (6, 3.5))
    for f, mk in [("PF", "o"), ("CMS-PF", "s")]:
        c = cons[cons["filter"] == f]
        ax.errorbar(c["N"], c["dist to exact mean"], 2 * c["se"], marker=mk, capsize=3, label=f)
    ax.set_xscale("log"); ax.set_yscale("log"); ax.set_xlabel("particles $N$"); ax.set_ylabel("RMS distance to exact mean")
    plain_log(ax, "x", subs=(1.0,) if phone() else (1.0, 2.0, 5.0))
    plain_log(ax, "y", subs=(1.0, 2.0, 5.0))
    ax.set_title(r"Consistency ($\sigma_v = 1$)")
    legend_below(fig, ax, ncol=2)
    return fig


def consistency_table(cons: pd.DataFrame) -> pd.DataFrame:
    """The consistency check as a table: distance to the exact mean, variance ratio and RMSE by N and filter."""
    return cons.pivot(index="N", columns="filter", values=["dist to exact mean", "variance ratio", "RMSE"]).round(3)


def tables(R) -> dict:
    """The paper's tables beside ours, from :func:`pfrepro.experiments.cmspf_ning2011.run_all`'s results.

    Parameters
    ----------
    R : pfrepro.experiments.cmspf_ning2011.Ning2011Results
        The results.

    Returns
    -------
    dict
        Label (``TABLES``) -> DataFrame: Table 1 per run (the paper's printed values and
        ours), Table 1's means (with sigma_w^2 = 10), Table 2 and Table 3 beside the published ones.
    """
    return {"Table 1": table1_per_run_long(R.t1), "Table 1 (means)": table1_summary(R.t1, R.t1_q10),
            "Table 2": table2_vs_published(R.t2, R.t2_q10), "Table 3": table3_vs_published(R.t3, R.t3_q10)}


def figures(R) -> dict:
    """Figs. 2-6 of the paper, re-run, from :func:`pfrepro.experiments.cmspf_ning2011.run_all`'s results.

    Parameters
    ----------
    R : pfrepro.experiments.cmspf_ning2011.Ning2011Results
        The results.

    Returns
    -------
    dict
        Label (``FIGURES``) -> matplotlib Figure.
    """
    return {"Fig. 2": fig2(R.f2), "Fig. 3": fig3(R.f3, R.f3_grid, times=False),
            "Fig. 4": fig_one_step(R.step_randn, "Fig. 4: randn carrier, one step (k = 20, N = 200)"),
            "Fig. 5": fig_one_step(R.step_chaos, "Fig. 5: logistic-map carrier, one step (k = 20, N = 200)"),
            "Fig. 6": fig6(R.f6_base, R.f6_maps, R.sens, R.sens_ref)}


def timing_figures(R) -> dict:
    """The measured times of Figs. 2-6, which ``pfrepro run`` writes apart from the results: Fig. 3's time panel.

    Parameters
    ----------
    R : pfrepro.experiments.cmspf_ning2011.Ning2011Results
        The results.

    Returns
    -------
    dict
        Label -> matplotlib Figure.
    """
    return {"Fig. 3": fig3_times(R.f3)}


def fig1_flowchart(checks: pd.DataFrame):
    """Fig. 1 of the paper (the CMS-PF flowchart, printed as an image only), redrawn from sec 2.2's
    steps (l.64-98): one box per step with the paper's statement, coloured by the check of our filter
    against that step (:func:`pfrepro.experiments.cmspf_ning2011.step_checks`: green passes, red fails),
    an arrow from each step to the next, and the loop k → k + 1 (Step 5) back to Step 2.1 noted
    below the last box. The statements wrap to the width of the drawing (laptop or phone), at the
    layout's type size."""
    import textwrap

    import matplotlib.pyplot as plt
    from matplotlib.patches import FancyBboxPatch

    order = list(checks.index)
    fig, ax = new_figure(figsize=(6.5, 6.5))
    width_in = fig.get_size_inches()[0]
    size = plt.rcParams["font.size"]
    line = 1.35 * size / 72                       # inches per text line
    chars = max(18, int((width_in - 0.4) / (0.62 * size / 72)))   # characters per line inside a box
    boxes = []
    for s_ in order:
        mark = "✓" if bool(checks.loc[s_, "passes"]) else "✗ fails"
        head = f"{mark} {s_} ({checks.loc[s_, 'line']})"
        body = textwrap.wrap(reader_text(str(checks.loc[s_, "paper"])), chars)
        boxes.append((s_, head, body))
    gap = 0.28                                     # inches between boxes (the arrow)
    heights = [(1 + len(b)) * line + 0.12 for _, _, b in boxes]
    loop = textwrap.wrap("↻ Step 5: k ← k + 1, back to Step 2.1", chars) if "Step 2.1" in order else []
    total = sum(heights) + gap * (len(boxes) - 1) + (len(loop) * line + gap if loop else 0) + 0.1
    fig.set_size_inches(width_in, total)
    ax.set_position([0, 0, 1, 1])
    ax.set_xlim(0, width_in); ax.set_ylim(0, total)
    ax.axis("off")
    top = total - 0.05
    centres = []
    for (s_, head, body), h in zip(boxes, heights):
        ok = bool(checks.loc[s_, "passes"])
        ax.add_patch(FancyBboxPatch((0.05, top - h), width_in - 0.1, h, boxstyle="round,pad=0.0,rounding_size=0.06",
                                    fc="#e3f2e3" if ok else "#f8d7d7", ec="#2e7d32" if ok else "#c62828", lw=1))
        ax.text(0.15, top - 0.06, head, weight="bold", va="top", color="#1b5e20" if ok else "#b71c1c")
        if body:
            ax.text(0.15, top - 0.06 - line, "\n".join(body), va="top", linespacing=1.35)
        centres.append((top, top - h))
        top -= h + gap
    for (_, b0), (t1, _) in zip(centres[:-1], centres[1:]):
        ax.annotate("", xy=(width_in / 2, t1), xytext=(width_in / 2, b0), arrowprops=dict(arrowstyle="->", lw=0.9))
    if loop:
        ax.text(width_in / 2, centres[-1][1] - gap, "\n".join(loop), ha="center", va="top", linespacing=1.35)
    return fig
