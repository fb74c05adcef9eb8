"""Figures and tables of Zhou, Sun, Chu, Cui (2017), IMMPF with optimal resampling
(chapter ``book/60_immpf.md``).

The experiments are :mod:`pfrepro.experiments.immpfor_zhou2017`; this module only draws their
results (Table 1, Figs. 1-5) and bundles them for the command line (:func:`reproduce`).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..experiments import immpfor_zhou2017 as E
from ..models.tracking import IDX_POS, IDX_VEL
from ..plotting import REFERENCE_COLOR, SERIES_COLORS, method_color  # noqa: F401  (the book palette)
from . import new_figure

__all__ = ["d_sweep_figure", "table1_frame", "fig1", "shade_turns", "rmse_plot", "fig2", "fig3", "fig4", "fig5", "reproduce",
           "TABLES", "FIGURES", "N_STEPS", "PF_NAMES"]

#: what :func:`reproduce` makes
TABLES = ("Table 1",)
FIGURES = ("Fig. 1", "Fig. 2", "Fig. 3", "Fig. 4", "Fig. 5")
#: experiments :func:`reproduce` runs (for a progress bar)
N_STEPS = 3
#: the two particle filters the paper compares (builders of :func:`pfrepro.experiments.immpfor_zhou2017.run`)
PF_NAMES = E.PF_BUILDERS
#: the Kalman references and the second reading of eq (15) shown in Table 1
EXTRA_ROWS = ("IMMPF (mean lik.)", "IMMPFOR (mean lik.)", "IMM-EKF", "IMM-UKF")


def table1_frame(main, lik_pair=None, pub=None) -> pd.DataFrame:
    """Table 1: peak and mean position RMSE, paper beside ours with bootstrap standard errors.

    Parameters
    ----------
    main : pfrepro.experiments.immpfor_zhou2017.Run
        The main run (IMMPF, IMMPFOR and, if present, IMM-EKF and IMM-UKF).
    lik_pair : Run, optional
        The mean-likelihood reading paired with ``main``'s first runs; its rows are added.
    pub : pandas.DataFrame, optional
        ``published.table("immpfor_zhou2017", "Table 1")`` (default: read it).

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
    se1, _ = E.bootstrap_table(main, names1)
    tab1 = pd.DataFrame({"paper peak": pub["peak"], "ours peak": t1["peak"], "se": se1["peak"],
                         "paper mean": pub["mean"], "ours mean": t1["mean"], "se ": se1["mean"]})
    for n in EXTRA_ROWS:
        src_ = lik_pair if "mean lik." in n else main
        if src_ is None or n not in src_.results:
            continue
        t_ = E.table1(src_, [n]); s_, _ = E.bootstrap_table(src_, [n])
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


def reproduce(runs: int | None = None, seed: int | None = None, executor=None, steps=None):
    """Table 1 and Figs. 1-5 (paper scale: 100 runs; the mean-likelihood rows on the first 50).

    Calls the chapter's experiment function :func:`pfrepro.experiments.immpfor_zhou2017.run`
    with the chapter's builders. ``runs`` replaces the run count (the mean-likelihood reading
    runs on at most ``runs``), ``seed`` the main seed. Returns a
    :class:`pfrepro.papers.Reproduction` whose claims are Table 1's published cells.
    """
    from ..papers import Reproduction, cell_claims

    step = steps or (lambda label: None)
    S = E.SCENARIO
    n_runs = S["runs"] if runs is None else int(runs)
    n_lik = min(S["runs_lik"], n_runs)
    sd = E.SEEDS["main"] if seed is None else int(seed)
    step(f"Table 1, Figs. 1-4 ({n_runs} runs)")
    main = E.run(E.MAIN_BUILDERS, runs=n_runs, seed=sd, executor=executor)
    step(f"Table 1, mean model likelihood ({n_lik} runs)")
    lik = E.run({"IMMPF (mean lik.)": ("immpf", {"model_likelihood": "mean"}),
                 "IMMPFOR (mean lik.)": ("immpfor", {"model_likelihood": "mean"})}, runs=n_lik, seed=sd,
                executor=executor)
    lik_pair = E.Run(lik.sim, {**lik.results, **main.head(n_lik).results}, lik.seed)
    step(f"Fig. 5, N = {S['N_fig5']} ({n_runs} runs)")
    f5 = E.run(E.fig5_builders(), runs=n_runs, seed=sd, executor=executor)
    tab1 = table1_frame(main, lik_pair)
    cells = []
    for n in PF_NAMES:
        for q, se in (("peak", "se"), ("mean", "se ")):
            cells.append({"filter": n, "quantity": q, "published": float(tab1.loc[n, f"paper {q}"]),
                          "ours": float(tab1.loc[n, f"ours {q}"]), "se": float(tab1.loc[n, se])})
    claims = cell_claims(E.PAPER, pd.DataFrame(cells), lambda r: f"cli-table1-{r['quantity']}-{r['filter'].lower()}",
                         lambda r: f"{r['filter']} {r['quantity']} position RMSE (Table 1)", "Table 1")
    tab1 = tab1.rename(index={n: f"{n}, {n_lik} runs" for n in EXTRA_ROWS[:2]})
    figures = {"Fig. 1": fig1(main), "Fig. 2": fig2(main), "Fig. 3": fig3(main), "Fig. 4": fig4(main),
               "Fig. 5": fig5(f5)}
    return Reproduction(E.PAPER, tables={"Table 1": tab1}, figures=figures, claims=claims,
                        settings={"runs": n_runs, "runs (mean likelihood)": n_lik, "seed": sd,
                                  "N": S["N"], "N (Fig. 5)": S["N_fig5"]})
