"""Figures and tables of Hou & Yin (2008), dual particle filter (chapter ``book/50_dpf.md``).

The experiments are :mod:`pfrepro.experiments.dpf_hou2008` (``run_all``) and the claims
``pfrepro.verdicts.dpf_hou2008``; this module only draws their results: the paper's figures
and table for the command line (:func:`tables`, :func:`figures`) and every figure and table the
chapter shows (:func:`chapter_figures` and the ``*_table`` functions).
"""
from __future__ import annotations

import matplotlib.ticker
import numpy as np
import pandas as pd

from ..bookinfo import card_table, cell_html, choices_display, plain_math  # noqa: F401  (their home is pfrepro.bookinfo; kept importable here)
from ..experiments import dpf_hou2008 as E
from ..plotting import REFERENCE_COLOR, SERIES_COLORS, method_color  # noqa: F401  (the book palette)
from . import legend_below, legend_columns, new_figure  # noqa: F401  (legend_columns: kept importable here)

__all__ = ["pm", "rmse_table", "fig1", "fig3", "fig2", "fig4", "fig5", "fig6", "figs_7_9", "fig_exact", "chapter_figure_alts", "CHAPTER_FIGURE_ALTS", "tables",
           "figures", "chapter_figures", "TABLES", "FIGURES", "N_STEPS", "paper_row_51", "sweeps_51",
           "integration_error", "errata_table", "readings_51_table", "sensitivity_display", "dekf_sensitivity_display",
           "law_table", "coverage_display", "table_52_display", "readings_52_table", "readings_52_tables"]

#: the tables and figures of the paper :func:`tables` and :func:`figures` make (``pfrepro run``)
TABLES = ("RMSE table",)
FIGURES = ("Fig. 4", "Fig. 5", "Figs. 7-9")
#: experiments ``run_all`` runs (its ``steps`` calls, for a progress bar)
N_STEPS = len(E.STEPS)
#: the filters of the sec 5.1 RMSE table
NAMES_51 = ("DPF", "DEKF", "Liu-West")


def pm(m, se, digits=3) -> str:
    """``"m ± se"`` with ``digits`` decimals."""
    return f"{m:.{digits}f} ± {se:.{digits}f}"


def rmse_table(r51, pub=None):
    """The sec 5.1 RMSE table as shown: mean ± se of the eq-(14) and usual RMSEs of x and θ.

    Parameters
    ----------
    r51 : pfrepro.experiments.dpf_hou2008.Run
        :func:`~pfrepro.experiments.dpf_hou2008.run_51`'s result.
    pub : pandas.DataFrame, optional
        ``published.table("dpf_hou2008", "Sec 5.1")`` (default: read it); its row is added.

    Returns
    -------
    tab : pandas.DataFrame
        The shown table (strings: mean ± standard error over runs, and the failures of
        :func:`~pfrepro.experiments.dpf_hou2008.lost_51`), all runs, then the exact
        reference's runs, then the paper.
    t_all, t_grid : pandas.DataFrame
        ``pfrepro.experiments.dpf_hou2008.rmse_table_51`` on all runs and on the runs of
        the exact reference (numbers).
    """
    if pub is None:
        from .. import published

        pub = published.table(E.PAPER, "Sec 5.1")
    names = list(NAMES_51)
    n_grid = r51.results["exact"].x.shape[0]
    t_all = E.rmse_table_51(r51, names)
    t_grid = E.rmse_table_51(r51, names + ["exact"], runs=n_grid)

    def fmt(t, digits):
        out = pd.DataFrame(index=t.index)
        out["runs"] = t["runs"].astype(object)  # the paper row holds a string
        out["failures"] = t["failures"].astype(object)
        for c in ("eq14 x", "usual x", "eq14 θ", "usual θ"):
            d = digits if "x" in c else digits + 2
            out[c] = [pm(m, s, d) for m, s in zip(t[c], t[c + " se"])]
        return out

    tab = pd.concat([fmt(t_all, 3), fmt(t_grid, 3).rename(index=lambda s: s + f" ({n_grid} runs)")])
    tab.loc["paper (1 run)"] = paper_row_51()
    return tab, t_all, t_grid


def paper_row_51() -> list:
    """The paper's row of the sec 5.1 table as shown: its four RMSEs with the printed digits
    (``published.printed``: the data file's text), "DPF / DEKF"; columns as :func:`rmse_table`."""
    from .. import published

    p = lambda row, col: published.printed(E.PAPER, "Sec 5.1", row, col)  # noqa: E731
    return ["1", "—", f"{p('RMSE x', 'DPF')} / {p('RMSE x', 'DEKF')}", "—",
            f"{p('RMSE theta', 'DPF')} / {p('RMSE theta', 'DEKF')}", "—"]


def fig4(r51, run: int = 0):
    """Fig. 4: one run of sec 5.1, state (top) and θ estimates (bottom) with the exact posterior."""
    kk = np.arange(1, r51.sim.x.shape[1])
    fig, axs = new_figure(2, 1, figsize=(6.5, 4.6), sharex=True)
    axs[0].plot(kk, r51.sim.x[run, 1:, 0], "k-", lw=1, label="truth")
    axs[0].plot(kk, r51.results["DPF"].x[run, :, 0], "-", color=method_color("DPF"), lw=0.9, label="DPF")
    axs[0].plot(kk, r51.results["DEKF"].x[run, :, 0], "--", color=method_color("DEKF"), lw=0.9, label="DEKF")
    axs[0].set_ylabel("$x_k$")
    ex = r51.results["exact"].diagnostics
    qx = E.theta_interval(r51, "exact")
    axs[1].fill_between(kk, qx[0, run], qx[2, run], color="0.85", label="exact 95 %")
    axs[1].plot(kk, ex["theta"][run], "k-", lw=1, label="exact posterior mean")
    axs[1].plot(kk, r51.results["DPF"].diagnostics["theta"][run], "-", color=method_color("DPF"), lw=0.9, label="DPF")
    axs[1].plot(kk, r51.results["DEKF"].diagnostics["theta"][run], "--", color=method_color("DEKF"), lw=0.9, label="DEKF")
    axs[1].plot(kk, r51.results["Liu-West"].diagnostics["theta"][run], ":", color=method_color("Liu-West"), lw=1.2, label="Liu–West")
    axs[1].axhline(E.S51["theta_true"], color="k", lw=0.5, ls=":")
    axs[1].set_ylim(0, 1); axs[1].set_ylabel("θ estimate"); axs[1].set_xlabel("k")
    legend_below(fig, axs, ncol=3)
    return fig


def fig5(f5: dict, run: int = 0):
    """Fig. 5: θ quantiles for the initial guesses (``f5`` is :func:`~pfrepro.experiments.dpf_hou2008.run_fig5`'s).

    Top: quantiles of the estimate over the Monte Carlo runs; bottom: each filter's own
    posterior quantiles in run ``run``.
    """
    kk = np.arange(1, next(iter(f5.values())).sim.x.shape[1])
    fig, axs = new_figure(2, 2, figsize=(7, 5), sharey=True, sharex=True)
    for col, name in enumerate(("DEKF", "DPF")):
        for c, (g0, rr) in zip(SERIES_COLORS, f5.items()):
            # top: quantiles over the Monte Carlo runs of the estimate θ̂_k (ref [18]'s reading)
            qr = np.quantile(rr.results[name].diagnostics["theta"], (0.025, 0.5, 0.975), axis=0)
            # bottom: one run, the filter's own posterior quantiles
            q = E.theta_interval(rr, name)[:, run]
            for row, qq in ((0, qr), (1, q)):
                ax = axs[row, col]
                ax.plot(kk, qq[1], color=c, lw=1, label=f"guess {g0}")
                ax.plot(kk, qq[0], color=c, lw=0.6, ls="--"); ax.plot(kk, qq[2], color=c, lw=0.6, ls="--")
        for row in (0, 1):
            axs[row, col].axhline(E.S51["theta_true"], color="k", lw=0.5, ls=":")
            axs[row, col].set_ylim(-0.05, 1.05)
        axs[0, col].set_title(f"({'ab'[col]}) {name}, over runs")
        axs[1, col].set_title(f"({'cd'[col]}) {name}, own posterior, run {run + 1}")
        axs[1, col].set_xlabel("k")
    axs[0, 0].set_ylabel("θ"); axs[1, 0].set_ylabel("θ")
    legend_below(fig, axs, ncol=3)
    return fig


def figs_7_9(r52, crb_ft=None, rm: dict | None = None):
    """Figs. 7-9: RMSE against time of altitude (ft), speed (ft/s) and θ (1/ft), with θ's Cramér-Rao bound.

    ``r52`` is :func:`~pfrepro.experiments.dpf_hou2008.run_52`'s result, ``crb_ft``
    :func:`~pfrepro.experiments.dpf_hou2008.crb_theta_52` (default: computed), ``rm`` the
    per-filter ``pfrepro.experiments.dpf_hou2008.rmse_over_time_52`` (default: computed).
    The chapter works in feet, the problem's own units (Athans et al. 1968).
    """
    if crb_ft is None:
        crb_ft = E.crb_theta_52("feet")
    if rm is None:
        rm = {n: E.rmse_over_time_52(r52, n) for n in NAMES_51}
    lab52 = ["altitude (ft)", "speed (ft/s)", "θ (1/ft)"]
    T = rm["DPF"].shape[-1]
    tt = np.arange(1, T + 1)
    fig, axs = new_figure(1, 3, figsize=(7.5, 2.6))
    for j, (ax, lab) in enumerate(zip(axs, lab52)):
        for n, c, ls in (("DEKF", method_color("DEKF"), (0, (4, 1.5))), ("DPF", method_color("DPF"), "-"),
                          ("Liu-West", method_color("Liu-West"), ":")):
            ax.plot(tt, rm[n][j], color=c, ls=ls, label=n.replace("-", "–"))
        if j == 2:
            ax.plot(tt, np.asarray(crb_ft)[:T], color="k", lw=0.7, label="CRB sd of θ")
            ax.set_ylim(1e-7, 1e-2)
        ax.set_yscale("log"); ax.set_xlabel("t (s)"); ax.set_title(f"({'abc'[j]}) RMSE of {lab}")
    legend_below(fig, axs, ncol=4)
    return fig


def fig6(tr_ft, tr_lit_m):
    """Fig. 6: the noise-free truth under the foot reading and the literal one (converted to feet)."""
    from ..models.reentry import FT

    t = np.arange(tr_ft.shape[0])
    fig, axs = new_figure(1, 2, figsize=(7, 2.6))
    axs[0].plot(t, tr_ft[:, 0] / 1e3, label="our reading")
    axs[0].plot(t, tr_lit_m[:, 0] / FT / 1e3, "--", label="literal reading")
    axs[0].set_xlabel("t (s)"); axs[0].set_ylabel("altitude (10³ ft)")
    axs[1].plot(t, tr_ft[:, 1] / 1e3); axs[1].plot(t, tr_lit_m[:, 1] / FT / 1e3, "--")
    axs[1].set_xlabel("t (s)"); axs[1].set_ylabel("speed (10³ ft/s)")
    legend_below(fig, axs, ncol=2)
    return fig


#: the (α, β) pairs of the regenerated Fig. 1 (sec 3.1, l.89: the uniform at α = β = 1, shapes moved by the
#: ratio of α to β, concentrated by their size)
FIG1_PAIRS = ((1, 1), (0.5, 0.5), (2, 2), (2, 5), (5, 2), (20, 20), (50, 150))


def fig1(pairs=FIG1_PAIRS):
    """Fig. 1 regenerated: the Beta density (eq 4) for several (α, β) (sec 3.1, l.89): α = β = 1 is the
    uniform on [0, 1], the ratio α : β moves the mass, their size α + β concentrates it."""
    from scipy.stats import beta as beta_dist

    u = np.linspace(0.0005, 0.9995, 1000)
    fig, ax = new_figure(figsize=(5.6, 3.0))
    for i, (a, b) in enumerate(pairs):
        ax.plot(u, beta_dist.pdf(u, a, b), color=SERIES_COLORS[i % len(SERIES_COLORS)],
                ls=("-", "--", ":", "-.")[i // len(SERIES_COLORS) % 4] if len(pairs) > len(SERIES_COLORS) else "-",
                lw=1.1, label=f"α = {a:g}, β = {b:g}")
    ax.set_ylim(0, 6); ax.set_xlim(0, 1)
    ax.set_xlabel("$y$"); ax.set_ylabel("$f(y;\\alpha,\\beta)$")
    legend_below(fig, ax, ncol=4)   # under the axes: the curves fill the whole panel
    return fig


def fig3():
    """Fig. 3 regenerated (the paper's block diagram of dual estimation, sec 4.1, l.143): a state filter
    that uses the current parameter estimate and a parameter filter that uses the state estimate, both fed
    by z_k, alternating at every step. As implemented (``pfrepro.filters.DualParticleFilter``), the
    parameter filter scores each θ by the one-step prediction from (x̂_{k-1}, P_{k-1}) (eq 11, second line).

    Drawn as a column (measurement, state filter, exchange, parameter filter, measurement) whose boxes
    are sized by their text, so the same drawing reads on a laptop and on a phone."""
    from ..plotting import current_layout

    layout = current_layout()
    width = layout.width_in if layout is not None else 5.0
    fig, ax = new_figure(figsize=(min(width, 5.0), 4.6))
    fig.set_size_inches(fig.get_size_inches()[0], 4.6)   # a diagram, not a panel: the column needs its height
    ax.set_xlim(0, 1); ax.set_ylim(0, 1); ax.axis("off")
    box = dict(boxstyle="round,pad=0.4", fc="0.93", ec="0.3")
    state = ax.text(0.5, 0.72, "state filter (step 2)\nbootstrap PF, $N_x$ particles\n"
                    "uses $\\hat\\theta_{k-1}$, gives $\\hat x_k, P_k$", ha="center", va="center", bbox=box)
    param = ax.text(0.5, 0.28, "parameter filter (step 3)\nBeta$(\\alpha_k, \\beta_k)$, $N_\\theta$ draws\n"
                    "uses $\\hat x_{k-1}, P_{k-1}$, gives $\\hat\\theta_k$", ha="center", va="center", bbox=box)
    z_top = ax.text(0.5, 0.985, "$z_k$", ha="center", va="top")
    z_bot = ax.text(0.5, 0.015, "$z_k$", ha="center", va="bottom")
    arrow = dict(arrowstyle="-|>", mutation_scale=14, lw=1.0, color="0.2")
    ax.annotate("", xy=(0.5, 0.0), xycoords=state, xytext=(0.5, 0.0), textcoords=z_top,
                arrowprops=dict(arrow, patchB=state.get_bbox_patch()))
    ax.annotate("", xy=(0.5, 1.0), xycoords=param, xytext=(0.5, 1.0), textcoords=z_bot,
                arrowprops=dict(arrow, patchB=param.get_bbox_patch()))
    # the exchange: the state estimate goes down (right), the parameter estimate up (left), for step k + 1
    for x, lab, down in ((0.68, "$\\hat x_k, P_k$", True), (0.32, "$\\hat\\theta_k$", False)):
        src, dst = (state, param) if down else (param, state)
        ax.annotate("", xy=(x, 0.5 - 0.08 if down else 0.5 + 0.08), xytext=(x, 0.5 + 0.08 if down else 0.5 - 0.08),
                    arrowprops=arrow)
        ax.text(x + (0.03 if down else -0.03), 0.5, lab, ha="left" if down else "right", va="center")
    fig.tight_layout()
    return fig


def fig2(outside_over_time=None, cases=((0.5, 1 / 12), (0.12, 0.01))):
    """Fig. 2 regenerated: a Beta law and the Gaussian with the same mean and variance on [0, 1].

    ``cases`` are (mean, variance) pairs on the unit interval (default: the uniform prior's moments,
    where every DPF starts, and a law near the edge); the mass the Gaussian puts outside [0, 1] is
    shaded and printed. With ``outside_over_time`` (share of Gaussian draws outside the range per
    step, averaged over runs), a last panel shows it against k.
    """
    from scipy.stats import beta as beta_dist, norm

    n = len(cases) + (outside_over_time is not None)
    fig, axs = new_figure(1, n, figsize=(2.6 * n, 2.6))
    axs = np.atleast_1d(axs)
    u = np.linspace(-0.4, 1.4, 721)
    for i, (ax, (mu, var)) in enumerate(zip(axs, cases)):
        nu = mu * (1 - mu) / var - 1
        a, b = mu * nu, (1 - mu) * nu
        inside = (u > 0) & (u < 1)
        ax.plot(u[inside], beta_dist.pdf(u[inside], a, b), color=SERIES_COLORS[0], label="Beta")
        g = norm.pdf(u, mu, np.sqrt(var))
        ax.plot(u, g, color=SERIES_COLORS[1], ls="--", label="Gaussian, same moments")
        ax.fill_between(u, 0, g, where=~inside, color=SERIES_COLORS[1], alpha=0.35, lw=0)
        out = norm.cdf(0, mu, np.sqrt(var)) + norm.sf(1, mu, np.sqrt(var))
        ax.axvline(0, color="0.5", lw=0.6); ax.axvline(1, color="0.5", lw=0.6)
        ax.set_title(f"({'abcd'[i]}) μ = {mu:g}, σ = {np.sqrt(var):.3g}\n{100 * out:.1f} % outside")
        ax.set_xlabel(r"$\phi = (\theta - r_l)/(r_u - r_l)$")
    axs[0].set_ylabel("density")
    if outside_over_time is not None:
        ax = axs[-1]
        k = np.arange(1, len(outside_over_time) + 1)
        ax.plot(k, 100 * np.asarray(outside_over_time), color=SERIES_COLORS[1], ls="--")
        ax.set_xlabel("k"); ax.set_ylabel("% of draws outside")
        ax.set_title(f"({'abcd'[n - 1]}) Gaussian-law DPF\n(mean over runs)")
    legend_below(fig, axs, ncol=2)
    return fig


def sweeps_51(st, sd, cap=None, q_rel=None):
    """The sec 5.1 sweeps of the free choices the chapter shows as tables, drawn: (a) the DPF's θ RMSE and
    (b) its 95 % interval coverage at T against the cap on α + β; (c) the DEKF's state RMSE against its
    parameter noise q_0 (and unprojected).

    ``st``: ``pfrepro.experiments.dpf_hou2008.sensitivity_table`` of the DPF sweep (rows ``"cap c"``,
    ``"no cap"`` and ``"DPF"`` = the main cap); ``sd``: the same for the DEKF sweep (rows
    ``"q0 = q P0"``, ``"unprojected"``); ``cap``, ``q_rel``: the chapter's own values (marked). Error bars
    are ± 1 standard error over the runs."""
    cap = E.S51["cap"] if cap is None else cap
    q_rel = E.S51["dekf_q_rel"] if q_rel is None else q_rel
    caps = [c for c in E.S51["caps"]]
    rows = ["DPF" if c == cap else (f"cap {c:g}" if c else "no cap") for c in caps]
    labels = [f"{c:g}" + ("\n(ours)" if c == cap else "") if c else "none" for c in caps]
    fig, axs = new_figure(1, 3, figsize=(9.0, 2.9))
    pos = np.arange(len(rows))
    axs[0].errorbar(pos, st.loc[rows, "RMSE θ"], yerr=st.loc[rows, "se θ"], fmt="o-", color=method_color("DPF"),
                    capsize=3, label="DPF")
    axs[0].set_ylabel("θ RMSE")
    axs[1].plot(pos, st.loc[rows, "coverage at T"], "o-", color=method_color("DPF"), label="DPF")
    axs[1].axhline(0.95, color=REFERENCE_COLOR, lw=0.8, ls="--", label="nominal 0.95")
    axs[1].set_ylim(-0.03, 1.03); axs[1].set_ylabel("coverage of θ at T")
    for ax, t in zip(axs[:2], ("(a) DPF: θ error", "(b) DPF: 95 % interval")):
        ax.set_xticks(pos, labels); ax.set_xlabel("cap on α + β"); ax.set_title(t)
    qrows = [r for r in sd.index if str(r).startswith("q0")] + [r for r in sd.index if r == "unprojected"]
    qlab = [str(r).replace("q0 = ", "").replace(" P0", "") for r in qrows]
    qlab = [lab + (" (ours)" if lab == f"{q_rel:g}" else "") for lab in qlab]
    qpos = np.arange(len(qrows))
    axs[2].errorbar(qpos, sd.loc[qrows, "RMSE x"], yerr=sd.loc[qrows, "se x"], fmt="s", color=method_color("DEKF"),
                    capsize=3, label="DEKF")
    axs[2].set_xticks(qpos, qlab, rotation=30, ha="right")
    axs[2].set_xlabel(r"$q_0 / P_{\theta,0}$ (or $\hat\theta$ unprojected)"); axs[2].set_ylabel("state RMSE")
    axs[2].set_title("(c) DEKF: parameter noise")
    legend_below(fig, axs, ncol=3)
    return fig


def integration_error(integ, used=None):
    """The sec 5.2 integration sweep drawn: max state error over the 60 s truth (against 1024 RK4
    substeps, ``pfrepro.experiments.dpf_hou2008.integration_error_52``) per number of RK4 substeps, log-log, with the filters' choice marked. ``integ``:
    ``pfrepro.experiments.dpf_hou2008.integration_error_52``."""
    used = E.S52["filter_substeps"] if used is None else used
    fig, ax = new_figure(figsize=(4.2, 2.9))
    n = np.asarray(integ.index, float)
    for j, col in enumerate(integ.columns):
        ax.loglog(n, integ[col].to_numpy(float), "o-", color=SERIES_COLORS[j % len(SERIES_COLORS)], label=str(col))
    ax.axvline(used, color=REFERENCE_COLOR, lw=0.8, ls="--", label=f"filters: {used} substeps")
    ax.set_xticks(n, [f"{v:g}" for v in n], minor=False)
    ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
    ax.set_xlabel("RK4 substeps per second"); ax.set_ylabel("max error over 60 s")
    legend_below(fig, ax, ncol=3)
    return fig


def fig_exact(r51, runs=None):
    """Sec 5.1 against the exact posterior: (a) RMS distance of each method's θ estimate to the exact
    posterior mean, (b) coverage of the true θ by each method's 95 % interval, over the exact
    reference's runs (``runs``, default all of them: common runs only)."""
    exd = r51.results["exact"].diagnostics
    nr = r51.results["exact"].x.shape[0] if runs is None else runs
    kk = np.arange(1, r51.sim.x.shape[1])
    fig, axs = new_figure(1, 2, figsize=(7, 2.8))
    for name, c, ls in (("DPF", method_color("DPF"), "-"), ("DEKF", method_color("DEKF"), "--"),
                        ("Liu-West", method_color("Liu-West"), ":")):
        d = r51.results[name].diagnostics["theta"][:nr] - exd["theta"][:nr]
        axs[0].plot(kk, np.sqrt(np.mean(d**2, 0)), color=c, ls=ls, label=name.replace("-", "–"))
    axs[0].set_yscale("log"); axs[0].set_xlabel("k"); axs[0].set_ylabel("RMS distance to exact mean")
    axs[0].set_title("(a)")
    for name, c, ls in (("exact", "k", "-"), ("DPF", method_color("DPF"), "-"), ("DEKF", method_color("DEKF"), "--"),
                        ("Liu-West", method_color("Liu-West"), ":")):
        q = E.theta_interval(r51, name)
        cov = E.coverage(q[0, :nr], q[2, :nr], E.S51["theta_true"]).mean(0)   # the common runs only
        axs[1].plot(kk, cov, color=c, ls=ls, label=name.replace("-", "–"))
    axs[1].axhline(0.95, color="0.5", lw=0.6); axs[1].set_ylim(0, 1.02); axs[1].set_xlabel("k")
    axs[1].set_ylabel("coverage of true θ"); axs[1].set_title("(b)")
    legend_below(fig, axs, ncol=4)
    return fig


def tables(results) -> dict:
    """The paper's table (``pfrepro run``): the sec 5.1 RMSE table (:func:`rmse_table`)."""
    return {"RMSE table": rmse_table(results.r51, results.pub)[0]}


def figures(results) -> dict:
    """The paper's figures (``pfrepro run``): Fig. 4, Fig. 5 and Figs. 7-9 from ``run_all``'s results."""
    return {"Fig. 4": fig4(results.r51), "Fig. 5": fig5(results.f5), "Figs. 7-9": figs_7_9(_fig_runs_52(results), results.crb_ft)}


def _fig_runs_52(results):
    """The sec 5.2 runs Figs. 7-9 are drawn on: the first ``fig_runs`` (the paper's 50, l.228) of the main runs."""
    n = min(results.s52.get("fig_runs", results.s52["runs"]), results.r52.sim.y.shape[0])
    return E.first_runs(results.r52, n)


#: the text alternative of every figure of the chapter, by its glue key (what the figure shows, for a
#: reader who cannot see it; the caption says what it means)
CHAPTER_FIGURE_ALTS = {
    "dpf_fig1": "Beta densities on the unit interval for seven pairs of alpha and beta: the uniform, "
                "U-shaped, bell-shaped, skewed to either side and concentrated laws.",
    "dpf_fig3": "Block diagram: the measurement feeds a state filter and a parameter filter; the state "
                "filter passes its estimate and covariance down, the parameter filter its estimate up, "
                "each used at the next step.",
    "dpf_fig4": "Two panels against the step k for one run: the true state with the DPF and DEKF "
                "estimates, and the parameter estimates of the DPF, the DEKF and Liu-West with the "
                "exact posterior mean and its 95 % band.",
    "dpf_fig5": "Four panels of parameter quantiles against k for initial guesses 0.2, 0.5 and 0.7: "
                "quantiles over runs and each filter's own posterior quantiles, for the DEKF and the DPF.",
    "dpf_sweeps51": "Three panels: the DPF's parameter error and interval coverage against the cap on "
                    "alpha plus beta, and the DEKF's state error against its parameter noise.",
    "dpf_fig2": "Beta and Gaussian densities with equal moments, with the Gaussian's mass outside the "
                "unit interval shaded, and the share of the Gaussian DPF's draws outside against k.",
    "dpf_fig_exact": "Two panels against k: each method's distance to the exact posterior mean of the "
                     "parameter (log scale), and the coverage of the true parameter by each method's "
                     "95 % interval.",
    "dpf_fig6": "Altitude and speed of the re-entering body against time under our reading and under "
                "the literal one.",
    "dpf_fig789": "Three panels of RMSE against time on log scales (altitude, speed and the ballistic "
                  "parameter with its Cramér-Rao bound) for the DEKF, the DPF and Liu-West.",
    "dpf_integration": "Largest altitude and speed error of the RK4 trajectory against the number of "
                       "substeps per second, log-log, with the filters' choice marked by a dashed line.",
}


def chapter_figure_alts() -> dict:
    """:data:`CHAPTER_FIGURE_ALTS` (a copy): the text alternative of every figure of the chapter."""
    return dict(CHAPTER_FIGURE_ALTS)


def chapter_figures(results) -> dict:
    """Every figure of the chapter by its glue key, as a function of no argument that draws it (the
    paper's Figs. 1-9, the sweeps, the exact posterior and the integration error): the book draws each
    once for the laptop and once for the phone (``pfrepro.prose.glue_figure``), with the text
    alternative of :data:`CHAPTER_FIGURE_ALTS`."""
    R = results
    st, sd = E.sensitivity_table(R.sens), E.sensitivity_table(R.dekf_sens)
    outside = R.x51.results["DPF Gaussian θ"].diagnostics["outside"].mean(0)
    r52 = _fig_runs_52(R)
    return {"dpf_fig1": fig1, "dpf_fig3": fig3,
            "dpf_fig4": lambda: fig4(R.r51, 0), "dpf_fig5": lambda: fig5(R.f5, 0),
            "dpf_sweeps51": lambda: sweeps_51(st, sd), "dpf_fig2": lambda: fig2(outside),
            "dpf_fig_exact": lambda: fig_exact(R.r51, R.s51["grid_runs"]),
            "dpf_fig6": lambda: fig6(R.tr_ft, R.tr_lit),
            "dpf_fig789": lambda: figs_7_9(r52, R.crb_ft), "dpf_integration": lambda: integration_error(R.integ)}


def errata_table(ratio_3d: float, literal_spread: float) -> pd.DataFrame:
    """The misprints of the paper and their corrections, with the evidence (``ratio_3d``: step 3(d) as
    printed over the weighted variance; ``literal_spread``: the literal weight's spread over θ, both
    from the chapter's equation checks)."""
    return pd.DataFrame([
        ("step 2(b)", "p(z_{1:k} | x̃_k, θ)", "p(z_k | x̃_k, θ)", "bootstrap weight; the past is already in w_{k-1}"),
        ("step 3(d)", "σ² = Σ w θ (θ̂ − θ)²", "σ² = Σ w (θ̂ − θ)²",
         f"checks above: the printed form is {ratio_3d:.2f} × the variance"),
        ("step 3(e)", "r_i", "r_l", "the lower end of the range"),
        ("eq (11), last line", "p(z_k | θ, x̂_k)", "p(z_k | θ, E[x_k | θ, z_1:k-1])",
         f"checks above: the literal weight's spread over θ is {literal_spread:.1f}"),
        ("eq (16)", "−θ x₂ e^{−γ x₁}", "−θ x₂² e^{−γ x₁}", "Athans et al. (1968); drag ∝ speed²"),
        ("sec 5.2 units", "91.5 km, 6.1 km/s, 30.5 km", "3·10⁵ ft, 2·10⁴ ft/s, 10⁵ ft", "γ, var v and θ are foot values"),
        ("sec 3.2 (l.117) vs step 3 (l.172-174)", "l.117: θ = (ϕ − r_l)/(r_u − r_l) is the Beta variable, ϕ the "
         "parameter; l.172: θ^i = ϕ^i (r_u − r_l) + r_l, ϕ the Beta variable, θ the parameter; l.174: f(θ^i; α, β)",
         "one naming (step 3's, which the chapter and eqs (8)-(13) use): ϕ ~ Beta(α, β) on [0, 1], θ = r_l + ϕ (r_u − r_l) "
         "the model's parameter; l.174's density is f(ϕ^i; α, β)",
         "θ is the model's parameter in eqs (8)-(13) and sec 5.2's θ ∈ [0, 2·10⁻³] (l.226) is not in [0, 1], so sec 3.2's "
         "naming is the swapped one; with π_θ = f(·; α_{k-1}, β_{k-1}) (draws from the Beta) the ratio in l.174 is 1 "
         "and the weight is the likelihood alone (as implemented)"),
        ("l.101", "by Neyman-Fisher, T = {α, β} is a sufficient statistic of the Beta law",
         "loose: α, β are the Beta's parameters; a Beta sample's sufficient statistic is (Σ log y, Σ log(1 − y)); "
         "{α_k, β_k} summarise p(θ | z_1:k) exactly only if it is a Beta",
         "checks above: two samples with the same two sums have the same likelihood over (α, β); the moment-matched "
         "Beta is close to the exact posterior at T (total variation in the checks) but an approximation"),
        ("eqs (15)-(16)", "w ~ N(0, 10⁶), N(0, 4·10⁶)", "a reading, not a proven misprint: P₀ = diag(10⁶, 4·10⁶), Q = 0 (main)",
         "the classic problem's initial covariance; the printed values as the filters' Q, and a small Q, are run as readings "
         "(sec 5.2): the conclusions that change with it are marked there"),
    ], columns=["where", "printed", "corrected", "evidence"])


def readings_51_table(results) -> pd.DataFrame:
    """Sec 5.1 under every reading (``pfrepro.verdicts.dpf_hou2008.readings_51``): medians of single-run
    eq-(14) RMSEs ("in": the published value inside our central 95 %), failures, the paired relative
    difference 1 − DPF/DEKF (± se) beside the paper's printed one, and whether the reading is counted
    (the paper's text excludes some: shown, not counted)."""
    from ..verdicts import dpf_hou2008 as V

    R51, pub = V.readings_51(results), V.published_51(results)

    def cell(st, who, lab):
        med, half, (lo_q, hi_q) = st[(who, lab)]
        inside = lo_q <= pub[(who, lab)] <= hi_q
        return f"{med:.{3 if lab == 'x' else 4}f}{' in' if inside else ''}"

    def label(ch, val):
        name = "main (T = 100, θ = 0.5)" if ch == "main" else V.reading_label_51(ch, val)
        if (ch, val) in V.EXCLUDED:
            name += " (context, not counted: " + V.EXCLUDED[(ch, val)].split(":")[0] + ")"
        return name

    tab = pd.DataFrame([{
        "reading": label(ch, val), "runs": st["runs"],
        "failures DPF / DEKF": f"{st['fail'][0]} / {st['fail'][1]}",
        "x: DPF / DEKF": f"{cell(st, 'DPF', 'x')} / {cell(st, 'DEKF', 'x')}",
        "θ: DPF / DEKF": f"{cell(st, 'DPF', 'theta')} / {cell(st, 'DEKF', 'theta')}",
        "1 − DPF/DEKF in x": pm(*st[("rel", "x")], 2), "1 − DPF/DEKF in θ": pm(*st[("rel", "theta")], 2)}
        for (ch, val), st in R51.items()])
    eff = V.effects_51(results)
    tab.loc[len(tab)] = ["paper (1 run)", 1, "—", f"{pub[('DPF', 'x')]:.3f} / {pub[('DEKF', 'x')]:.3f}",
                         f"{pub[('DPF', 'theta')]:.5f} / {pub[('DEKF', 'theta')]:.5f}", f"{eff['x']:.2f}",
                         f"{eff['theta']:.2f}"]
    return tab



def sensitivity_display(st) -> pd.DataFrame:
    """The DPF sweep as shown (``st``: ``sensitivity_table`` of the sweep): RMSEs ± se, coverage, α+β, cap and guards."""
    return pd.DataFrame({"runs": st["runs"], "failures": st["failures"],
                         "RMSE x": [pm(a, b, 2) for a, b in zip(st["RMSE x"], st["se x"])],
                         "RMSE θ": [pm(a, b, 3) for a, b in zip(st["RMSE θ"], st["se θ"])],
                         "cover. at T": st["coverage at T"].map("{:.2f}".format),
                         "α+β at T": st["median α+β at T"].map("{:.0f}".format),
                         "steps capped / guarded (%)": [f"{a:.1f} / {b:.1f}" for a, b in
                                                        zip(st["capped steps %"], st["guard steps %"])]},
                        index=pd.Index(st.index, name="DPF setting"))


def dekf_sensitivity_display(sd) -> pd.DataFrame:
    """The DEKF sweep as shown (``sd``: ``sensitivity_table`` of the sweep): RMSEs ± se and coverage."""
    return pd.DataFrame({"runs": sd["runs"], "failures": sd["failures"],
                         "RMSE x": [pm(a, b, 2) for a, b in zip(sd["RMSE x"], sd["se x"])],
                         "RMSE θ": [pm(a, b, 3) for a, b in zip(sd["RMSE θ"], sd["se θ"])],
                         "cover. at T": sd["coverage at T"].map("{:.2f}".format)},
                        index=pd.Index(sd.index, name="DEKF setting"))


def law_table(results) -> pd.DataFrame:
    """Beta against Gaussian parameter draws (sec 3.2, Fig. 2), one row per law: RMSEs, convergence step,
    draws outside the range and ESS (``pfrepro.verdicts.dpf_hou2008.beta_vs_gaussian``)."""
    from ..verdicts import dpf_hou2008 as V

    R = results
    ct = V.beta_vs_gaussian(R)["ct"]
    return pd.DataFrame([{
        "law": lab, "runs": rr.results[n].x.shape[0], "failures": int(E.lost_51(rr, n).sum()),
        "RMSE x": pm(*E.mean_se(E.rmse_51(rr, n, 0)), 2), "RMSE θ": pm(*E.mean_se(E.rmse_51(rr, n, 1)), 4),
        "convergence step": pm(*E.mean_se(ct[n]), 1),
        "draws outside, %: all steps / k = 1": (f"{100 * rr.results[n].diagnostics['outside'].mean():.2f} / "
                                                f"{100 * rr.results[n].diagnostics['outside'][:, 0].mean():.1f}"),
        "mean ESS of θ draws": f"{rr.results[n].diagnostics['ess_theta'].mean():.0f}"}
        for lab, n, rr in (("Beta (paper)", "DPF", R.r51), ("Gaussian, same moments", V.GA, R.x51))])


def coverage_display(results) -> pd.DataFrame:
    """Coverage of the true θ at T (± se), averaged over k > 10, and interval width, per method, on the exact
    reference's runs and on all runs, with the failures (``pfrepro.verdicts.dpf_hou2008.coverage_frame``)."""
    from ..verdicts import dpf_hou2008 as V

    cov_tab = V.coverage_frame(results)
    out = cov_tab.copy()
    out["coverage at T"] = [pm(a, b, 2) for a, b in zip(cov_tab["coverage at T"], cov_tab["se"])]
    out = out.drop(columns="se")
    out["coverage k>10"] = out["coverage k>10"].map("{:.2f}".format)
    out["mean width at T"] = out["mean width at T"].map("{:.3f}".format)
    out.insert(1, "failures", [int(E.lost_51(results.r51, n.replace(" (all runs)", ""), int(cov_tab.loc[n, "runs"])).sum())
                               for n in cov_tab.index])
    return out


def table_52_display(results) -> pd.DataFrame:
    """The sec 5.2 table at T (main reading; ``pfrepro.experiments.dpf_hou2008.table_52``) as shown."""
    out = E.table_52(results.r52)
    out["θ (10⁻³/ft)"] = out["θ (10⁻³/ft)"].map("{:.3f}".format)
    # altitudes to the foot, as the prose and the readings table give them (one number, one rounding)
    for c, fmt in (("altitude (ft)", "{:.0f}"), ("speed (ft/s)", "{:.1f}"), ("altitude, runs not lost (ft)", "{:.0f}")):
        out[c] = out[c].map(fmt.format)
    return out.rename(columns=lambda c: c if c in ("runs", "failures") else c + " at T")


def readings_52_tables(results) -> tuple:
    """:func:`readings_52_table` as the chapter shows it, in two tables of at most six columns, both by
    reading: the errors (runs, failures, altitude and θ at T, runs lost) and the paired z of the orderings."""
    t = readings_52_table(results)
    z_cols = [c for c in t.columns if c.startswith("z ")]
    return t.drop(columns=z_cols), t[["reading", *z_cols]]


def readings_52_table(results) -> pd.DataFrame:
    """Sec 5.2 under every reading (``pfrepro.verdicts.dpf_hou2008.readings_52``): failures, errors at T
    and the paired z of every ordering."""
    from ..verdicts import dpf_hou2008 as V

    def trio(st, col, fmt):
        return " / ".join(fmt(st["table"].loc[n, col]) for n in V.N52)

    return pd.DataFrame([{
        "reading": V.reading_label_52(ch, val), "runs": st["runs"],
        "failures DPF / DEKF / LW": trio(st, "failures", lambda v: f"{int(v)}"),
        "altitude at T (ft)": trio(st, "altitude (ft)", lambda v: f"{v:.0f}"),
        "θ at T (% of θ)": trio(st, "θ (10⁻³/ft)", lambda v: f"{100 * v:.1f}"),
        "z of DEKF − DPF (altitude, speed, θ)": ", ".join(f"{V.z_of(st[(k, 'all')]):.1f}" for k in ("alt", "vel", "th")),
        "z of DEKF − DPF, 10–20 s": ", ".join(f"{V.z_of(st[(k, '10_20')]):.1f}" for k in ("alt", "vel", "th")),
        "z of LW − DPF in θ": f"{V.z_of(st['lw']):.1f}",
        "lost LW − DPF": pm(*st["stab"], 2)} for (ch, val), st in V.readings_52(results).items()])
