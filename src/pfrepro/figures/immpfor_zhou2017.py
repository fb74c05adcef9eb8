"""Figures and tables of Zhou, Sun, Chu, Cui (2017), IMMPF with optimal resampling
(chapter ``book/60_immpf.md``).

The experiments are :mod:`pfrepro.experiments.immpfor_zhou2017` (``run_all``); this module only draws
their results: the paper's Table 1 and Figs. 1-5 for the command line (:func:`tables`, :func:`figures`)
and the chapter's other tables and figures (readings, robustness, equal compute, model probabilities,
the d sweep).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..experiments import immpfor_zhou2017 as E
from ..models.tracking import IDX_POS, IDX_VEL
from ..plotting import REFERENCE_COLOR, SERIES_COLORS, method_color  # noqa: F401  (the book palette)
from . import new_figure

__all__ = ["plans_table", "d_sweep_figure", "table1_frame", "table1_shown", "fig1", "shade_turns", "rmse_plot", "fig2", "fig3", "fig4",
           "fig5", "tables", "figures", "readings_table", "robustness_table", "equal_compute_table", "modes_table",
           "fig_modes", "fig_dsweep", "sweep_frames", "TABLES", "FIGURES", "N_STEPS", "PF_NAMES"]

#: what :func:`tables` and :func:`figures` make
TABLES = ("Table 1",)
FIGURES = ("Fig. 1", "Fig. 2", "Fig. 3", "Fig. 4", "Fig. 5")
#: experiments :func:`pfrepro.experiments.immpfor_zhou2017.run_all` announces with ``steps`` (for a progress
#: bar) when the adaptive readings need no extra runs
N_STEPS = 23
#: the two particle filters the paper compares (builders of :func:`pfrepro.experiments.immpfor_zhou2017.run`)
PF_NAMES = E.PF_BUILDERS
#: the Kalman references and the second reading of eq (15) shown in Table 1
EXTRA_ROWS = ("IMMPF (mean lik.)", "IMMPFOR (mean lik.)", "IMM-EKF", "IMM-UKF")


def table1_frame(main, lik_pair=None, pub=None, seed=None) -> pd.DataFrame:
    """Table 1: peak and mean position RMSE, paper beside ours with bootstrap standard errors.

    Parameters
    ----------
    main : pfrepro.experiments.immpfor_zhou2017.Run
        The main run (IMMPF, IMMPFOR and, if present, IMM-EKF and IMM-UKF).
    lik_pair : Run, optional
        The mean-likelihood reading paired with ``main``'s first runs; its rows are added.
    pub : pandas.DataFrame, optional
        ``published.table("immpfor_zhou2017", "Table 1")`` (default: read it).
    seed : int, optional
        Seed of the bootstrap standard errors (default the module's ``SEEDS["checks"]``).

    Returns
    -------
    pandas.DataFrame
        Columns "paper peak", "ours peak", "se", "paper mean", "ours mean" and "se " (the second
        standard error's name ends with a space), one row per filter.
    """
    if pub is None:
        from .. import published

        pub = published.table(E.PAPER, "Table 1")
    names1 = list(PF_NAMES)
    t1 = E.table1(main, names1)
    se1, _ = E.bootstrap_table(main, names1, seed=seed)
    tab1 = pd.DataFrame({"paper peak": pub["peak"], "ours peak": t1["peak"], "se": se1["peak"],
                         "paper mean": pub["mean"], "ours mean": t1["mean"], "se ": se1["mean"]})
    for n in EXTRA_ROWS:
        src_ = lik_pair if "mean lik." in n else main
        if src_ is None or n not in src_.results:
            continue
        t_ = E.table1(src_, [n]); s_, _ = E.bootstrap_table(src_, [n], seed=seed)
        tab1.loc[n, ["ours peak", "se", "ours mean", "se "]] = [t_.loc[n, "peak"], s_.loc[n, "peak"],
                                                                t_.loc[n, "mean"], s_.loc[n, "mean"]]
    return tab1


def table1_shown(tab1: pd.DataFrame) -> pd.DataFrame:
    """Table 1 as the chapter shows it: the paper's cells as printed (``published.formatter``: the
    data file's text, never a rounded float), ours to one decimal; missing cells "–"."""
    from .. import published

    fmt = published.formatter(E.PAPER, "Table 1")
    out = tab1.astype(object).copy()
    for c in tab1.columns:
        out[c] = [fmt(v) if c.startswith("paper") else ("–" if pd.isna(v) else f"{v:.1f}") for v in tab1[c]]
    return out


def fig1(main, run: int = 0):
    """Fig. 1: the true trajectory of one run and the IMMPF and IMMPFOR estimates (km)."""
    S = E.SCENARIO
    fig, ax = new_figure(figsize=(6, 4))
    xt = main.sim.x[run]
    ax.plot(xt[:, 0] / 1000, xt[:, 3] / 1000, "k-", lw=1.5, label="truth")
    for n, st in (("IMMPF", "--"), ("IMMPFOR", ":")):
        xe = main.results[n].x[run]
        ax.plot(xe[:, 0] / 1000, xe[:, 3] / 1000, st, color=method_color(n), lw=1, label=n)
    for k0 in (S["left_turn"][0], S["right_turn"][0]):
        ax.plot(xt[k0, 0] / 1000, xt[k0, 3] / 1000, "ko", ms=3)
    ax.set_xlabel("Rx [km]"); ax.set_ylabel("Ry [km]"); ax.legend(fontsize=8); ax.set_aspect("equal")
    fig.tight_layout()
    return fig


def shade_turns(ax):
    """Grey bands over the two turns of the scenario on ``ax`` (time axis in s)."""
    for a, b in (E.SCENARIO["left_turn"], E.SCENARIO["right_turn"]):
        ax.axvspan(a, b, color="0.9", lw=0)


def rmse_plot(run_, names, idx_pos, idx_vel, title_pos, title_vel, styles=("-", ":", "--", "-.")):
    """Two panels of RMSE over the runs against time (components ``idx_pos``, ``idx_vel``); turns shaded."""
    kk = np.arange(1, E.SCENARIO["duration"] + 1)
    fig, axs = new_figure(1, 2, figsize=(9, 3.3))
    for ax, idx, lab in ((axs[0], idx_pos, title_pos), (axs[1], idx_vel, title_vel)):
        shade_turns(ax)
        for i, (n, st) in enumerate(zip(names, styles)):
            ax.plot(kk, E.rmse_curves(run_.x_true, run_.results[n].x, idx), st, lw=1, label=n,
                    color=method_color(n, SERIES_COLORS[i % len(SERIES_COLORS)]))
        ax.set_xlabel("time [s]"); ax.set_ylabel(lab)
    axs[0].legend(fontsize=8); fig.tight_layout()
    return fig


def fig2(main):
    """Fig. 2: position and velocity RMSE, N = 500."""
    return rmse_plot(main, list(PF_NAMES), IDX_POS, IDX_VEL, "position RMSE [m]", "velocity RMSE [m/s]")


def fig3(main):
    """Fig. 3: x and y position RMSE, N = 500."""
    return rmse_plot(main, list(PF_NAMES), (0,), (3,), "x position RMSE [m]", "y position RMSE [m]")


def fig4(main):
    """Fig. 4: x and y velocity RMSE, N = 500."""
    return rmse_plot(main, list(PF_NAMES), (1,), (4,), "x velocity RMSE [m/s]", "y velocity RMSE [m/s]")


def fig5(run_n2000):
    """Fig. 5: position and velocity RMSE, N = 2000."""
    return rmse_plot(run_n2000, list(PF_NAMES), IDX_POS, IDX_VEL, "position RMSE [m]", "velocity RMSE [m/s]")


def d_sweep_figure(sweep: pd.DataFrame, ablation: pd.DataFrame | None = None):
    """The step coefficient d (eqs 22-23): IMMPF - IMMPFOR per-run RMS position error (m) ± one paired
    standard error against d (log axis); positive = IMMPFOR better.

    Parameters
    ----------
    sweep : pandas.DataFrame
        Index d, columns ``diff``, ``se`` (and ``runs``): IMMPFOR as reconstructed (eq 23).
    ablation : pandas.DataFrame, optional
        The same for the own-parent ablation (no mixing across modes).
    """
    fig, ax = new_figure(figsize=(6, 3.4))
    ax.axhline(0.0, color="0.5", lw=0.8)
    series = [(sweep, method_color("IMMPFOR"), "o-", "IMMPFOR (eq 23: parents of all modes)")]
    if ablation is not None:
        series.append((ablation, SERIES_COLORS[2], "s--", "ablation: own parent only"))
    for df, col, st, lab in series:
        d = np.asarray(df.index, float)
        ax.errorbar(d, df["diff"], yerr=df["se"], fmt=st, color=col, ms=4, lw=1, capsize=3, label=lab)
    ax.set_xscale("log")
    ax.set_xlabel("step coefficient d [neighbour spacings]")
    ax.set_ylabel("IMMPF − IMMPFOR [m]")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def tables(results) -> dict:
    """The paper's tables from :func:`pfrepro.experiments.immpfor_zhou2017.run_all`'s results: Table 1
    (:func:`table1_frame`, the mean-likelihood rows named with their run count)."""
    tab1 = table1_frame(results.main, results.lik_pair, seed=results.seeds["checks"])
    n_lik = results.reading_runs["lik=mean"]
    return {"Table 1": tab1.rename(index={n: f"{n}, {n_lik} runs" for n in EXTRA_ROWS[:2]})}


def figures(results) -> dict:
    """The paper's Figs. 1-5 from :func:`pfrepro.experiments.immpfor_zhou2017.run_all`'s results."""
    return {"Fig. 1": fig1(results.main), "Fig. 2": fig2(results.main), "Fig. 3": fig3(results.main),
            "Fig. 4": fig4(results.main), "Fig. 5": fig5(results.fig5)}


def plans_table(results) -> pd.DataFrame:
    """The power plans of :func:`pfrepro.experiments.immpfor_zhou2017.run_all` (fixed on the main run before
    any reading ran): which readings, the runs that ran, the runs 80 % power needs, floor and cap, the size
    resolved (printed effect or margin, relative) and the basis."""
    rows = [{"readings": p["readings"], "runs": p["runs"], "plan": p["plan"], "floor": p["floor"], "cap": p["cap"],
             "size": f"{p['size']:.0%}", "basis": p["basis"]} for p in (results.plans or [])]
    return pd.DataFrame(rows, columns=["readings", "runs", "plan", "floor", "cap", "size", "basis"])


def readings_table(results) -> pd.DataFrame:
    """Every reading of the orderings: IMMPF - IMMPFOR per-run RMS position error with its paired se and
    ordering, the median rule (:func:`pfrepro.experiments.immpfor_zhou2017.robustness`) and lost tracks."""
    from ..claims import ordering_holds
    from ..verdicts.immpfor_zhou2017 import WORD

    ST, ROB = results.stats, results.rob
    out = pd.DataFrame({t: {"runs": ROB[t]["runs"], "RMS diff [m]": ST[t]["rms"][0], "se": ST[t]["rms"][1],
                            "ordering": WORD[ordering_holds(*ST[t]["rms"])],
                            "median [m]": ROB[t]["median"], "95 % interval": f"[{ROB[t]['lo']:.1f}, {ROB[t]['hi']:.1f}]",
                            "IMMPFOR better in": ROB[t]["b_better"],
                            "lost IMMPF": ROB[t]["lost_a"], "lost IMMPFOR": ROB[t]["lost_b"]} for t in ST}).T
    out.index.name = "reading"
    return out


def robustness_table(results) -> pd.DataFrame:
    """The scenarios (main and :data:`~pfrepro.experiments.immpfor_zhou2017.ALTERNATIVES`): Table 1 means,
    the paired gain IMMPF - IMMPFOR, the median rule and its outcome at the main d and at d = D_FAVOURABLE."""
    from ..verdicts.immpfor_zhou2017 import WORD

    rows = []
    for label, r in results.scenarios.items():
        rb, rf = r["rb"], r["fav"]
        rows.append({"scenario": label, "IMMPF mean": r["IMMPF mean"], "IMMPFOR mean": r["IMMPFOR mean"],
                     "gain (RMS)": r["gain"][0], "se": r["gain"][1], "median gain": rb["median"],
                     "95 % interval": f"[{rb['lo']:.1f}, {rb['hi']:.1f}]",
                     "IMMPFOR better in": f"{rb['b_better']} of {rb['runs']}", "lost IMMPF": rb["lost_a"],
                     "lost IMMPFOR": rb["lost_b"], "robust (d = 1)": WORD[rb["holds"]],
                     f"robust (d = {E.D_FAVOURABLE:g})": WORD[rf["holds"]]})
    return pd.DataFrame(rows).set_index("scenario")


def equal_compute_table(results) -> pd.DataFrame:
    """Model evaluations per run and Table 1 mean of the IMMPF, IMMPFOR and the IMMPF with IMMPFOR's cost."""
    names = ("IMMPF", "IMMPFOR", "IMMPF eq")
    return pd.DataFrame({"evaluations per run": [results.costs[n] for n in names],
                         "mean RMSE [m]": [results.equal_means[n] for n in names]},
                        index=[f"IMMPF, N = {E.SCENARIO['N']}", f"IMMPFOR, N = {E.SCENARIO['N']}",
                               f"IMMPF, N = {results.N_eq}"])


#: the filters whose model probabilities the chapter shows (the figure: the first three)
MODE_FILTERS = ("IMMPF", "IMMPFOR", "IMM-EKF", "IMM-UKF")


def modes_table(results) -> pd.DataFrame:
    """Mean model probabilities against the true manoeuvres (:func:`pfrepro.experiments.immpfor_zhou2017.mode_summary`)."""
    return pd.DataFrame({n: E.mode_summary(results.main, n) for n in MODE_FILTERS}).T


def fig_modes(results):
    """Mean model probabilities over the runs against time (CV, CT, CA in the first three
    :data:`~pfrepro.plotting.SERIES_COLORS`), turns shaded; the paper has no such plot."""
    import matplotlib.pyplot as plt

    kk = np.arange(1, E.SCENARIO["duration"] + 1)
    fig, axs = plt.subplots(1, 3, figsize=(10, 3), sharey=True)
    for ax, n in zip(axs, MODE_FILTERS[:3]):
        shade_turns(ax)
        mp = results.main.results[n].diagnostics["mode_probs"].mean(axis=0)
        for j, lab in enumerate(("CV", "CT", "CA")):   # model series: the book's series palette
            ax.plot(kk, mp[:, j], "-", color=SERIES_COLORS[j], lw=1, label=lab)
        ax.set_title(n, fontsize=9); ax.set_xlabel("time [s]")
    axs[0].set_ylabel("mean model probability"); axs[0].legend(fontsize=8)
    fig.tight_layout()
    return fig


def sweep_frames(results):
    """The d sweep (IMMPF - IMMPFOR(d), index d) and the own-parent ablation, columns ``diff``, ``se``, ``runs``."""
    ST, ROB = results.stats, results.rob
    sweep = pd.DataFrame({d: {"diff": ST[f"d={d:g}"]["rms"][0], "se": ST[f"d={d:g}"]["rms"][1],
                              "runs": ROB[f"d={d:g}"]["runs"]} for d in E.D_GRID}).T
    abl = pd.DataFrame({d: dict(zip(("diff", "se"), v), runs=results.counts["runs_ablation"])
                        for d, v in results.ablation.items()}).T
    return sweep, abl


def fig_dsweep(results):
    """:func:`d_sweep_figure` of :func:`sweep_frames`."""
    return d_sweep_figure(*sweep_frames(results))
