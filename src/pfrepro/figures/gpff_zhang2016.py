"""Figures and tables of Zhang, Zhou, Feng (2016), Gaussian particle flow filter
(chapter ``book/20_gpff.md``).

The experiments are :mod:`pfrepro.experiments.gpff_zhang2016`; this module only draws
their results and bundles them for the command line (:func:`reproduce`).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..experiments import gpff_zhang2016 as E
from ..metrics import mse_per_component, mse_per_component_over_time
from . import new_figure

__all__ = ["fig1", "fig2", "fig3", "fig4", "fig5", "reproduce", "TABLES", "FIGURES", "N_STEPS",
           "BOT_FIGURE_FILTERS", "COMPONENT_LABELS", "table1_shown", "table2_shown"]

TABLES = ("Table 1", "Table 2")
FIGURES = ("Fig. 1", "Fig. 2", "Fig. 3", "Fig. 4", "Fig. 5")
N_STEPS = 4
#: the filters drawn in Figs. 4-5
BOT_FIGURE_FILTERS = ("EKF", "UKF", "PF(500)", "GPFF(100)")
#: axis labels of the BOT state components
COMPONENT_LABELS = {"x": "x", "y": "y", "xdot": "ẋ", "ydot": "ẏ"}  # plain Unicode: no TeX in labels or docs


def fig1(mc_gaussian, mc_mixture):
    """Fig. 1: per-run MSE (eq 56) of KF and GPFF on CWPA, (a) Gaussian and (b) mixture noise."""
    fig, axes = new_figure(1, 2, figsize=(10.2, 4))
    for ax, (label, mc) in zip(axes, (("(a) Gaussian noise", mc_gaussian), ("(b) mixture noise", mc_mixture))):
        for name, mk in (("KF", "o-"), ("GPFF", "s--")):
            v = mc.mse(name)
            ax.plot(np.arange(1, len(v) + 1), v, mk, ms=3, lw=0.8, label=name)
        ax.set_xlabel("Monte Carlo run"); ax.set_ylabel("MSE (eq 56)"); ax.set_title(f"Fig. 1{label}")
        ax.grid(alpha=0.3); ax.legend()
    fig.tight_layout()
    return fig


def fig2(mc_mixture, run: int = 0):
    """Fig. 2: one CWPA run under mixture noise: truth, measurements, KF and GPFF positions."""
    sim = mc_mixture.sim
    fig, ax = new_figure(figsize=(7, 5))
    ax.plot(sim.x[run, :, 0], sim.x[run, :, 1], "k-", lw=2, label="truth")
    ax.plot(sim.y[run, :, 0], sim.y[run, :, 1], ".", color="0.6", ms=4, label="measurements")
    ax.plot(mc_mixture.results["KF"].x[run, :, 0], mc_mixture.results["KF"].x[run, :, 1], "b-", label="KF")
    ax.plot(mc_mixture.results["GPFF"].x[run, :, 0], mc_mixture.results["GPFF"].x[run, :, 1], "r--", label="GPFF")
    ax.set_xlabel("x"); ax.set_ylabel("y"); ax.set_title(f"Fig. 2: CWPA tracking under mixture noise (run {run + 1})")
    ax.legend(); ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def fig3(mc_ung):
    """Fig. 3: per-run RMSE of EKF, UKF, PF(100), GPFF(100) and the exact grid filter on UNG."""
    fig, ax = new_figure(figsize=(10.2, 4.5))
    for name, mk in (("EKF", "v-"), ("UKF", "^-"), ("PF(100)", "o-"), ("GPFF(100)", "s-"), ("Grid (exact)", "k-")):
        r = mc_ung.rmse(name)
        ax.plot(np.arange(1, len(r) + 1), r, mk, ms=3, lw=0.8, label=name)
    ax.set_yscale("log"); ax.set_xlabel("Monte Carlo run"); ax.set_ylabel(f"RMSE over the {mc_ung.sim.T} steps")
    ax.set_title("Fig. 3: per-run RMSE on UNG (PF with N = 100)"); ax.grid(alpha=0.3, which="both"); ax.legend(ncol=5)
    fig.tight_layout()
    return fig


def fig4(mc_bot, names=BOT_FIGURE_FILTERS, dt: float = 0.1):
    """Fig. 4: per-component MSE at each time (eq 61) on BOT, over the runs that did not diverge."""
    fig, axes = new_figure(2, 2, figsize=(10.2, 7))
    tt = np.arange(1, mc_bot.sim.T + 1) * dt
    for j, (ax, comp) in enumerate(zip(axes.ravel(), E.COMPONENTS)):
        for name in names:
            ok = np.all(np.isfinite(mc_bot.results[name].x), axis=(1, 2))
            curve = mse_per_component_over_time(mc_bot.x_true[ok], mc_bot.results[name].x[ok])[:, j]
            ax.semilogy(tt, curve, label=name)
        ax.set_xlabel("time (s)"); ax.set_ylabel(f"MSE of {COMPONENT_LABELS[comp]} (eq 61)"); ax.grid(alpha=0.3, which="both")
        ax.set_title(f"Fig. 4({'abcd'[j]}): {COMPONENT_LABELS[comp]}")
    axes[0, 0].legend()
    fig.tight_layout()
    return fig


def fig5(mc_bot, names=BOT_FIGURE_FILTERS):
    """Fig. 5: time-averaged MSE of each component in each run on BOT."""
    fig, axes = new_figure(2, 2, figsize=(10.2, 7))
    for j, (ax, comp) in enumerate(zip(axes.ravel(), E.COMPONENTS)):
        for name in names:
            v = mse_per_component(mc_bot.x_true, mc_bot.results[name].x)[:, j]
            ax.semilogy(np.arange(1, len(v) + 1), v, ".-", ms=3, lw=0.6, label=name)
        ax.set_xlabel("Monte Carlo run"); ax.set_ylabel(f"time-averaged MSE of {COMPONENT_LABELS[comp]}")
        ax.set_title(f"Fig. 5({'abcd'[j]}): {COMPONENT_LABELS[comp]}"); ax.grid(alpha=0.3, which="both")
    axes[0, 0].legend()
    fig.tight_layout()
    return fig


def reproduce(runs: int | None = None, seed: int | None = None, executor=None, steps=None):
    """Tables 1-2 and Figs. 1-5 (the CWPA, UNG and BOT experiments of sec 5).

    ``runs`` defaults to the paper's 100; ``seed`` replaces the experiments' fixed seeds
    (:data:`pfrepro.experiments.gpff_zhang2016.SEEDS`) by ``seed, seed + 1, ...``.
    Returns a :class:`pfrepro.papers.Reproduction`.
    """
    from ..papers import Reproduction, call_with_executor, cell_claims, override_seeds

    step = steps or (lambda label: None)
    runs = E.RUNS if runs is None else runs
    with override_seeds(E.SEEDS, seed):
        step(f"CWPA, Gaussian noise ({runs} runs)")
        mc_g = call_with_executor(E.run_cwpa, "gaussian", runs=runs, executor=executor)
        step(f"CWPA, mixture noise ({runs} runs)")
        mc_m = call_with_executor(E.run_cwpa, "mixture", runs=runs, executor=executor)
        step(f"UNG, Table 1 ({runs} runs)")
        mc_u = call_with_executor(E.run_ung, runs=runs, executor=executor)
        step(f"BOT, Table 2 ({runs} runs)")
        mc_b = call_with_executor(E.run_bot, runs=runs, executor=executor)
        seeds = dict(E.SEEDS)
    t1, t2 = E.table1(mc_u), E.table2(mc_b)
    t1_claims = t1.rename(columns={"published mean": "published", "MSE mean": "ours", "SE": "se"})
    reg = cell_claims(E.PAPER, t1_claims, lambda r: f"t1_mse_{r['filter']}",
                      lambda r: f"Table 1: mean MSE of {r['filter']} on UNG", "Table 1")
    t2_claims = t2.rename(columns={"published mean": "published", "MSE mean": "ours", "SE": "se"})
    cell_claims(E.PAPER, t2_claims, lambda r: f"t2_{r['component']}_{r['filter']}",
                lambda r: f"Table 2: time-averaged MSE of {r['component']} for {r['filter']} on BOT",
                "Table 2", registry=reg)
    figures = {"Fig. 1": fig1(mc_g, mc_m), "Fig. 2": fig2(mc_m), "Fig. 3": fig3(mc_u),
               "Fig. 4": fig4(mc_b), "Fig. 5": fig5(mc_b)}
    return Reproduction(E.PAPER, tables={"Table 1": t1, "Table 2": t2}, figures=figures, claims=reg,
                        settings={"runs": runs, "seeds": {k: seeds[k] for k in ("cwpa_gaussian", "cwpa_mixture",
                                                                                 "ung", "bot")}})


def _printed_columns(t: pd.DataFrame, table_id: str, columns=("published mean", "published std")) -> pd.DataFrame:
    from .. import published

    fmt = published.formatter(E.PAPER, table_id)
    out = t.copy()
    for c in columns:
        if c in out:
            out[c] = [fmt(v) for v in out[c]]
    return out


def table1_shown(t1: pd.DataFrame) -> pd.DataFrame:
    """Table 1 as the chapter shows it (:func:`pfrepro.experiments.gpff_zhang2016.table1`): the paper's
    MSE mean and std as printed (``published.formatter``: the data file's text, never a rounded float),
    and its printed time per run in ``published time (s)``; our numbers unchanged; "–" where the paper
    has no row."""
    from .. import published

    out = _printed_columns(t1, "Table 1")
    pub = published.printed_table(E.PAPER, "Table 1")
    out["published time (s)"] = [pub.loc[n, "time (s)"] if n in pub.index else "–" for n in t1.index]
    return out


def table2_shown(t2: pd.DataFrame) -> pd.DataFrame:
    """Table 2 as the chapter shows it (:func:`pfrepro.experiments.gpff_zhang2016.table2`, rows
    (component, filter)): the paper's mean and std as printed, and its printed time per run in
    ``published time (s)``."""
    from .. import published

    out = _printed_columns(t2, "Table 2")
    pub = published.printed_table(E.PAPER, "Table 2")
    out["published time (s)"] = [pub.loc["time (s)", f] if f in pub.columns else "–"
                                 for f in t2.index.get_level_values("filter")]
    return out
