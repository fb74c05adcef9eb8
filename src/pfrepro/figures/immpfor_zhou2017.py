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
from ..bookinfo import card_table, choices_display  # noqa: F401  (their home is pfrepro.bookinfo; kept importable here)
from . import legend_below, new_figure

__all__ = ["plans_table", "d_sweep_figure", "table1_frame", "table1_shown", "fig1", "shade_turns", "rmse_plot", "fig2", "fig3", "fig4",
           "fig5", "tables", "figures", "readings_table", "robustness_table", "equal_compute_table", "modes_table",
           "fig_modes", "fig_dsweep", "sweep_frames", "chapter_figures", "CHAPTER_FIGURE_ALTS",
           "held_table", "plan_label", "TABLES", "FIGURES", "N_STEPS", "PF_NAMES"]

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
    ax.set_xlabel("$R_x$ [km]"); ax.set_ylabel("$R_y$ [km]"); ax.set_aspect("equal", adjustable="datalim")
    legend_below(fig, ax, ncol=3)
    return fig


def shade_turns(ax):
    """Grey bands over the two turns of the scenario on ``ax`` (time axis in s)."""
    for a, b in (E.SCENARIO["left_turn"], E.SCENARIO["right_turn"]):
        ax.axvspan(a, b, color="0.9", lw=0)


def rmse_plot(run_, names, idx_pos, idx_vel, title_pos, title_vel, styles=("-", ":", "--", "-.")):
    """Two panels of RMSE over the runs against time (components ``idx_pos``, ``idx_vel``); turns shaded."""
    kk = np.arange(1, E.SCENARIO["duration"] + 1)
    fig, axs = new_figure(1, 2, figsize=(9, 3.3))
    for j, (ax, idx, lab) in enumerate(((axs[0], idx_pos, title_pos), (axs[1], idx_vel, title_vel))):
        shade_turns(ax)
        ax.set_title(f"({'ab'[j]})", loc="left")
        for i, (n, st) in enumerate(zip(names, styles)):
            ax.plot(kk, E.rmse_curves(run_.x_true, run_.results[n].x, idx), st, lw=1, label=n,
                    color=method_color(n, SERIES_COLORS[i % len(SERIES_COLORS)]))
        ax.set_xlabel("time [s]"); ax.set_ylabel(lab)
    legend_below(fig, axs, ncol=len(names))
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
    series = [(sweep, method_color("IMMPFOR"), "o-", "IMMPFOR (eq 23)")]
    if ablation is not None:
        series.append((ablation, SERIES_COLORS[2], "s--", "own parent only"))
    for df, col, st, lab in series:
        d = np.asarray(df.index, float)
        ax.errorbar(d, df["diff"], yerr=df["se"], fmt=st, color=col, ms=4, lw=1, capsize=3, label=lab)
    ax.set_xscale("log")
    ax.set_xlabel("step coefficient $d$")   # in neighbour spacings (the caption)
    ax.set_ylabel("IMMPF − IMMPFOR [m]")
    legend_below(fig, ax, ncol=2)
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

    from ..verdicts.immpfor_zhou2017 import reading_words

    ST, ROB = results.stats, results.rob
    return pd.DataFrame([{"reading": reading_words(t), "runs": ROB[t]["runs"],
                          "IMMPF − IMMPFOR [m]": f"{ST[t]['rms'][0]:.1f} ± {ST[t]['rms'][1]:.1f}",
                          "ordering": WORD[ordering_holds(*ST[t]["rms"])],
                          "median [m] (95 % interval)": f"{ROB[t]['median']:.1f} [{ROB[t]['lo']:.1f}, {ROB[t]['hi']:.1f}]",
                          "IMMPFOR better in": f"{ROB[t]['b_better']} of {ROB[t]['runs']}",
                          "lost IMMPF / IMMPFOR": f"{ROB[t]['lost_a']} / {ROB[t]['lost_b']}"} for t in ST])


def robustness_table(results) -> pd.DataFrame:
    """The scenarios (main and :data:`~pfrepro.experiments.immpfor_zhou2017.ALTERNATIVES`): Table 1 means,
    the paired gain IMMPF - IMMPFOR, the median rule and its outcome at the main d and at d = D_FAVOURABLE."""
    from ..verdicts.immpfor_zhou2017 import WORD

    rows = []
    for label, r in results.scenarios.items():
        rb, rf = r["rb"], r["fav"]
        rows.append({"scenario": label,
                     "mean RMSE [m], IMMPF / IMMPFOR": f"{r['IMMPF mean']:.1f} / {r['IMMPFOR mean']:.1f}",
                     "gain (RMS) [m]": f"{r['gain'][0]:.1f} ± {r['gain'][1]:.1f}",
                     "median gain [m] (95 % interval)": f"{rb['median']:.1f} [{rb['lo']:.1f}, {rb['hi']:.1f}]",
                     "IMMPFOR better in": f"{rb['b_better']} of {rb['runs']}",
                     "lost IMMPF / IMMPFOR": f"{rb['lost_a']} / {rb['lost_b']}",
                     f"median rule, d = {E.SCENARIO['d']:g}": WORD[rb["holds"]],
                     f"median rule, d = {E.D_FAVOURABLE:g}": WORD[rf["holds"]]})
    return pd.DataFrame(rows)


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
    kk = np.arange(1, E.SCENARIO["duration"] + 1)
    fig, axs = new_figure(1, 3, figsize=(10, 3), sharey=True)
    for i, (ax, n) in enumerate(zip(axs, MODE_FILTERS[:3])):
        shade_turns(ax)
        mp = results.main.results[n].diagnostics["mode_probs"].mean(axis=0)
        for j, lab in enumerate(("CV", "CT", "CA")):   # model series: the book's series palette
            ax.plot(kk, mp[:, j], "-", color=SERIES_COLORS[j], lw=1, label=lab)
        ax.set_title(f"({'abc'[i]}) {n}"); ax.set_xlabel("time [s]"); ax.set_ylabel("mean probability")
    legend_below(fig, axs, ncol=3)
    return fig


#: the text alternative of every figure of the chapter, by its glue key
CHAPTER_FIGURE_ALTS = {
    "imm_fig1": "Map of one run in kilometres: the true trajectory with two turns and the IMMPF and IMMPFOR "
                "estimates, which follow it closely.",
    "imm_fig2": "Two panels against time: position and velocity RMSE over the runs of the IMMPF and IMMPFOR, "
                "with the two turns shaded.",
    "imm_fig3": "Two panels against time: x and y position RMSE over the runs of the IMMPF and IMMPFOR, with "
                "the two turns shaded.",
    "imm_fig4": "Two panels against time: x and y velocity RMSE over the runs of the IMMPF and IMMPFOR, with "
                "the two turns shaded.",
    "imm_fig5": "Two panels against time: position and velocity RMSE with 2000 particles per model for the "
                "IMMPF and IMMPFOR, with the two turns shaded.",
    "imm_fig_modes": "Three panels against time: the mean probabilities of the CV, CT and CA models for the "
                     "IMMPF, IMMPFOR and IMM-EKF, with the two turns shaded.",
    "imm_fig_dsweep": "IMMPF minus IMMPFOR error with error bars against the step coefficient d on a log "
                      "axis, for IMMPFOR as reconstructed and for the own-parent ablation.",
}


def chapter_figures(results) -> dict:
    """Every figure of the chapter by its glue key, as a function of no argument that draws it (the
    book draws each for the laptop and for the phone, ``pfrepro.prose.glue_figure``; text alternatives
    in :data:`CHAPTER_FIGURE_ALTS`)."""
    R = results
    return {"imm_fig1": lambda: fig1(R.main), "imm_fig2": lambda: fig2(R.main), "imm_fig3": lambda: fig3(R.main),
            "imm_fig4": lambda: fig4(R.main), "imm_fig5": lambda: fig5(R.fig5),
            "imm_fig_modes": lambda: fig_modes(R), "imm_fig_dsweep": lambda: fig_dsweep(R)}


def held_table() -> pd.DataFrame:
    """The settings held fixed (``pfrepro.experiments.immpfor_zhou2017.HELD``) as shown: a dict value
    (the seeds) written as "name value" pairs, not as Python."""
    import ast

    def value(v):
        try:
            d = ast.literal_eval(v)
        except (ValueError, SyntaxError):
            return v
        return ", ".join(f"{k} {x}" for k, x in d.items()) if isinstance(d, dict) else v

    return pd.DataFrame([(a, value(b), c, d) for a, b, c, d in E.HELD],
                        columns=["setting", "value", "reason", "in the paper"])


def plan_label(name: str) -> str:
    """A power-plan row of ``pfrepro.experiments.immpfor_zhou2017.plan_choices`` in words
    ("plan_3" -> "power plan 3", "plan_readings" -> "runs of the readings")."""
    rest = name[5:] if name.startswith("plan_") else name
    return f"power plan {rest}" if rest.isdigit() else f"runs of the {rest.replace('_', ' ')}"


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
