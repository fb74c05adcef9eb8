"""Figures and tables of Zhang, Zhou, Feng (2016), Gaussian particle flow filter
(chapter ``book/20_gpff.md``).

The experiments are :mod:`pfrepro.experiments.gpff_zhang2016`; this module only draws
their results (:func:`~pfrepro.experiments.gpff_zhang2016.run_all`) and gives the command line
its tables and figures (:func:`tables`, :func:`figures`).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.ticker import NullFormatter

from ..experiments import gpff_zhang2016 as E
from ..metrics import mc_summary, mse_per_component, mse_per_component_over_time
from ..plotting import REFERENCE_COLOR, SERIES_COLORS, method_color
from . import legend_below, new_figure

__all__ = ["fig1", "fig2", "fig3", "fig4", "fig5", "tables", "figures", "TABLES", "FIGURES", "N_STEPS",
           "BOT_FIGURE_FILTERS", "COMPONENT_LABELS", "table1_shown", "table2_shown", "cwpa_table",
           "fig_convergence_dlambda", "fig_convergence_n", "fig_bot_bound"]

TABLES = ("Table 1", "Table 2")
FIGURES = ("Fig. 1", "Fig. 2", "Fig. 3", "Fig. 4", "Fig. 5")
#: calls of ``steps`` in :func:`pfrepro.experiments.gpff_zhang2016.run_all` (the command line's progress bar)
N_STEPS = 6
#: the filters drawn in Figs. 4-5
BOT_FIGURE_FILTERS = ("EKF", "UKF", "PF(500)", "GPFF(100)")
#: axis labels of the BOT state components
COMPONENT_LABELS = {"x": "x", "y": "y", "xdot": "ẋ", "ydot": "ẏ"}  # plain Unicode: no TeX in labels or docs


def _color(name: str):
    """The book's colour of a filter of this chapter ("GPFF(100) eq41" is the GPFF's, "Grid (exact)" the
    reference's)."""
    if name.lower().startswith("grid"):
        return REFERENCE_COLOR
    base = name.split("(")[0].strip().split(",")[0].strip()
    return method_color(base)


def fig1(mc_gaussian, mc_mixture):
    """Fig. 1: per-run MSE (eq 56) of KF and GPFF on CWPA, (a) Gaussian and (b) mixture noise."""
    fig, axes = new_figure(1, 2, figsize=(10.2, 4), layout="constrained")
    for ax, (label, mc) in zip(axes, (("(a) Gaussian noise", mc_gaussian), ("(b) mixture noise", mc_mixture))):
        for name, mk in (("KF", "o-"), ("GPFF", "s--")):
            v = mc.mse(name)
            ax.plot(np.arange(1, len(v) + 1), v, mk, ms=3, lw=0.8, color=_color(name), label=name)
        ax.set_xlabel("Monte Carlo run"); ax.set_ylabel("MSE (eq 56)"); ax.set_title(label)
        ax.grid(alpha=0.3)
    legend_below(fig, axes[0], ncol=3)
    return fig


def fig2(mc_mixture, run: int = 0):
    """Fig. 2: one CWPA run under mixture noise: truth, measurements, KF and GPFF positions."""
    sim = mc_mixture.sim
    fig, ax = new_figure(figsize=(6.5, 4.6), layout="constrained")
    ax.plot(sim.x[run, :, 0], sim.x[run, :, 1], "k-", lw=2, label="truth")
    ax.plot(sim.y[run, :, 0], sim.y[run, :, 1], ".", color="0.6", ms=4, label="measurements")
    ax.plot(mc_mixture.results["KF"].x[run, :, 0], mc_mixture.results["KF"].x[run, :, 1], "-",
            color=_color("KF"), label="KF")
    ax.plot(mc_mixture.results["GPFF"].x[run, :, 0], mc_mixture.results["GPFF"].x[run, :, 1], "--",
            color=_color("GPFF"), label="GPFF")
    ax.set_xlabel("x"); ax.set_ylabel("y"); ax.set_title(f"run {run + 1}, mixture noise")
    ax.grid(alpha=0.3)
    legend_below(fig, ax, ncol=4)
    return fig


def fig3(mc_ung):
    """Fig. 3: per-run RMSE of EKF, UKF, PF(100), GPFF(100) and the exact grid filter on UNG."""
    fig, ax = new_figure(figsize=(6.5, 4), layout="constrained")
    for name, mk in (("EKF", "v-"), ("UKF", "^-"), ("PF(100)", "o-"), ("GPFF(100)", "s-"), ("Grid (exact)", "-")):
        r = mc_ung.rmse(name)
        ax.plot(np.arange(1, len(r) + 1), r, mk, ms=3, lw=0.8, color=_color(name), label=name)
    ax.set_yscale("log"); ax.set_xlabel("Monte Carlo run"); ax.set_ylabel(f"RMSE over {mc_ung.sim.T} steps")
    ax.grid(alpha=0.3, which="both")
    legend_below(fig, ax, ncol=3)
    return fig


def fig4(mc_bot, names=BOT_FIGURE_FILTERS, dt: float = 0.1):
    """Fig. 4: per-component MSE at each time (eq 61) on BOT, over the runs that did not diverge."""
    fig, axes = new_figure(2, 2, figsize=(10.2, 7), layout="constrained")
    tt = np.arange(1, mc_bot.sim.T + 1) * dt
    for j, (ax, comp) in enumerate(zip(axes.ravel(), E.COMPONENTS)):
        for name in names:
            ok = np.all(np.isfinite(mc_bot.results[name].x), axis=(1, 2))
            curve = mse_per_component_over_time(mc_bot.x_true[ok], mc_bot.results[name].x[ok])[:, j]
            ax.semilogy(tt, curve, color=_color(name), label=name)
        ax.set_xlabel("time (s)"); ax.set_ylabel(f"MSE of {COMPONENT_LABELS[comp]}"); ax.grid(alpha=0.3, which="both")
        ax.set_title(f"({'abcd'[j]}) {COMPONENT_LABELS[comp]}")
        ax.yaxis.set_minor_formatter(NullFormatter())   # minor labels of a short log axis overlap
    legend_below(fig, axes[0, 0], ncol=4)
    return fig


def fig5(mc_bot, names=BOT_FIGURE_FILTERS):
    """Fig. 5: time-averaged MSE of each component in each run on BOT."""
    fig, axes = new_figure(2, 2, figsize=(10.2, 7), layout="constrained")
    for j, (ax, comp) in enumerate(zip(axes.ravel(), E.COMPONENTS)):
        for name in names:
            v = mse_per_component(mc_bot.x_true, mc_bot.results[name].x)[:, j]
            ax.semilogy(np.arange(1, len(v) + 1), v, ".-", ms=3, lw=0.6, color=_color(name), label=name)
        ax.set_xlabel("Monte Carlo run"); ax.set_ylabel(f"MSE of {COMPONENT_LABELS[comp]}")
        ax.set_title(f"({'abcd'[j]}) {COMPONENT_LABELS[comp]}"); ax.grid(alpha=0.3, which="both")
        ax.yaxis.set_minor_formatter(NullFormatter())
    legend_below(fig, axes[0, 0], ncol=4)
    return fig


def tables(results) -> dict:
    """Tables 1-2 (:attr:`~pfrepro.experiments.gpff_zhang2016.GpffResults.table1`, ``table2``) of
    :func:`pfrepro.experiments.gpff_zhang2016.run_all`'s results, ``{label: DataFrame}``."""
    return {"Table 1": results.table1, "Table 2": results.table2}


def figures(results) -> dict:
    """Figs. 1-5 of :func:`pfrepro.experiments.gpff_zhang2016.run_all`'s results, ``{label: Figure}``."""
    mc_m = results.cwpa["mixture"]
    return {"Fig. 1": fig1(results.cwpa["gaussian"], mc_m), "Fig. 2": fig2(mc_m), "Fig. 3": fig3(results.ung),
            "Fig. 4": fig4(results.bot), "Fig. 5": fig5(results.bot)}


def cwpa_table(results) -> pd.DataFrame:
    """Sec 5.1 in numbers: mean MSE (eq 56) of KF, GPFF and GPFF with the exact map, the paired
    difference GPFF - KF with its SE, and the spread of the per-run MSE, per noise."""
    rows = []
    for label, mc in (("Gaussian", results.cwpa["gaussian"]), ("mixture", results.cwpa["mixture"])):
        k, gg, ge = mc.mse("KF"), mc.mse("GPFF"), mc.mse("GPFF (exact map)")
        d = mc_summary(gg - k)
        rows.append({"noise": label, "KF MSE": k.mean(), "GPFF MSE": gg.mean(), "GPFF (exact map) MSE": ge.mean(),
                     "GPFF − KF": d.mean, "SE(GPFF − KF)": d.se, "KF MSE std": k.std(ddof=1),
                     "GPFF MSE std": gg.std(ddof=1)})
    return pd.DataFrame(rows).set_index("noise")


def fig_convergence_dlambda(conv: pd.DataFrame):
    """Relative error of a cloud moved by the affine flow against the Kalman update of its moments,
    against the step size, per integrator, on the uniform and the exponential lambda grid
    (:func:`~pfrepro.experiments.gpff_zhang2016.convergence_in_dlambda`)."""
    fig, axes = new_figure(1, 2, figsize=(10.2, 4), sharey=True, layout="constrained")
    styles = {"euler": "o-", "midpoint": "s-", "rk4": "^-"}
    for ax, sched, panel in zip(axes, ("uniform", "exponential"), "ab"):
        for meth, color in zip(("euler", "midpoint", "rk4"), SERIES_COLORS):
            c = conv[(conv.schedule == sched) & (conv.integrator == meth)]
            ax.loglog(c["dlambda"], c["mean error"], styles[meth], color=color, label=f"{meth}, mean")
            ax.loglog(c["dlambda"], c["cov error"], styles[meth], color=color, mfc="none", alpha=0.6,
                      label=f"{meth}, covariance")
        ax.axvline(1 / E.N_LAMBDA, color="grey", lw=0.8, ls=":")
        ax.set_xlabel(r"$1/n_\lambda$ (uniform grid: $\Delta\lambda$)")
        ax.set_title(f"({panel}) {sched} λ grid")
        ax.set_ylabel("relative error")
        ax.grid(True, which="both", alpha=0.3)
    legend_below(fig, axes[0], ncol=3)
    return fig


def fig_convergence_n(conv_n: pd.DataFrame):
    """Error of the flowed cloud's mean and covariance against the true Kalman posterior as N grows,
    for the exact map and 20 Euler steps (:func:`~pfrepro.experiments.gpff_zhang2016.convergence_in_n`)."""
    fig, ax = new_figure(figsize=(6.5, 4), layout="constrained")
    for (name, c), mk, color in zip(conv_n.groupby("integrator", sort=False), ("o-", "s-"), SERIES_COLORS):
        ax.loglog(c["N"], c["mean error"], mk, color=color, label=f"{name}: mean")
        ax.loglog(c["N"], c["cov error"], mk, color=color, mfc="none", alpha=0.6, label=f"{name}: covariance")
    Ns = conv_n["N"].unique()
    ax.loglog(Ns, conv_n["mean error"].iloc[0] * np.sqrt(Ns[0] / Ns), "k:", label=r"$\propto N^{-1/2}$")
    ax.set_xlabel("particles N"); ax.set_ylabel("RMS relative error")
    ax.grid(True, which="both", alpha=0.3)
    legend_below(fig, ax, ncol=2)
    return fig


def fig_bot_bound(results, components=("y", "ydot"), dt: float = 0.1):
    """MSE over time (eq 61) of the Table 2 filters and the references against the PCRB with known
    x0 (solid) and with the prior start (dotted; not a bound on these data), one panel per component;
    the vertical range spans the filters' curves after the first second."""
    from ..plotting import log_ylim_from

    mc_b, refs = results.bot, results.references
    _, _, curves = E.bot_reference_table(mc_b, refs)
    names = list(E.BOT_LABELS) + list(refs.filters)
    tt = np.arange(1, mc_b.sim.T + 1) * dt   # time (s), as in Fig. 4
    fig, axes = new_figure(1, len(components), figsize=(10.2, 4.2), layout="constrained")
    for ax, comp in zip(np.atleast_1d(axes), components):
        j = E.COMPONENTS.index(comp)
        pf_colors = iter(SERIES_COLORS)   # the PFs of several sizes apart; the others in their method's colour
        for name in names:
            ls = "--" if name.startswith("UKF, started") else "-"
            color = next(pf_colors) if name.startswith("PF(") else _color(name)
            ax.semilogy(tt, curves[name][:, j], ls, color=color, lw=1.6 if name == f"PF({refs.big_n})" else 1.0,
                        label=name)
        ax.semilogy(tt, refs.pcrb_fixed[:, j], "k-", lw=2, label="PCRB, $x_0$ known")
        ax.semilogy(tt, refs.pcrb_prior[:, j], "k:", lw=1.5, label="PCRB, $x_0\\sim$ prior")
        ax.set_xlabel("time (s)"); ax.set_ylabel(f"MSE of {COMPONENT_LABELS[comp]}")
        ax.grid(alpha=0.3, which="both")
        ax.set_title(f"{COMPONENT_LABELS[comp]} against the bound")
        # the known-start bound and the UKF told x0 start near 0 and would stretch the axis over
        # decades no filter visits later
        log_ylim_from(ax, *[curves[name][tt > 1.0, j] for name in names], pad=1.5)
    legend_below(fig, np.atleast_1d(axes)[0], ncol=3)
    return fig


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
