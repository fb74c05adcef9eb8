"""Experiments of Li, Li, Fang, Bai (2012), "EKF and PF algorithms and their applications
to target tracking", Technical Acoustics 31(3): 296-299 (paper key ``ekf_pf_li2012``).

What the paper runs (sec 2): two scalar models with Q = 10, R = 1, x_0 = 0.1, T = 60 steps,
N = 1000 particles;

* model 1: x_k = x_{k-1}/2 + 25 x_{k-1}/(1 + x_{k-1}^2) + 8 cos(1.2(k-1)) + w_{k-1},
* model 2: x_k = x_{k-1}/2 + 18 cos(1.2(k-1)) + w_{k-1},
* both: y_k = x_k^2/20 + v_k;

Figs. 1-4 show one run and the per-time RMSE over 50 Monte Carlo runs, Table 1 the RMSE
(formula at the end of sec 2) over 100 independent runs. The EKF is eqs (8)-(11), the
bootstrap PF eqs (15)-(16) with the five-step algorithm of sec 1.3.2.

Assumptions (the paper does not state them; see the chapter): the filters start from
N(x_0, P0) with P0 = 2 and the PF resamples every step with multinomial resampling --
both as in the widely circulated MATLAB code of this benchmark (D. Simon, *Optimal State
Estimation*, 2006, ch. 15), which matches the paper's x_0 = 0.1 and cos(1.2(k-1)).

Everything here is a thin layer over the package: models from
:class:`pfrepro.models.UNGM`, filters from :mod:`pfrepro.filters`, Monte Carlo from
:func:`pfrepro.montecarlo.run_monte_carlo`. :func:`run_all` runs every experiment whose
numbers feed a claim (Table 1 and figure runs, the sweeps and readings, the SIS runs, the
seed spread, the cost counts) and returns :class:`Li2012Results`; the claims are decided by
``pfrepro.verdicts.ekf_pf_li2012``, and the chapter ``book/30_ekf_pf.md`` (through
:meth:`pfrepro.papers.Paper.run`) and ``pfrepro run li2012`` both go through them. The
wall-time measurements (:func:`cost_ratios`, :func:`rmse_and_cost_vs_n`, the times of
:func:`cost_evidence`) decide nothing and run in the chapter, after the Monte Carlo work.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .. import published
from ..choices import DESIGN, FIXED, READING, SWEEP, FreeChoice
from ..claims import verdict
from ..filters import BootstrapParticleFilter, ExtendedKalmanFilter, GridFilter, UnscentedKalmanFilter
from ..filters.ekf_variants import PreviousEstimateJacobianEKF
from ..metrics import mc_summary, rmse, rmse_over_time
from ..models import UNGM
from ..models.base import Simulation
from ..montecarlo import MonteCarloResult, run_monte_carlo, time_filters, time_single_run, truth_streams
from ..stats import ratio_of_means
from ..papers import resolve_seeds
from ..validation import check_positive_int

__all__ = [
    "PAPER", "T", "N_PARTICLES", "RUNS_TABLE", "RUNS_FIGURES", "SEEDS", "SEED_TABLE", "SEED_FIGURES",
    "P0_DEFAULT", "RESAMPLING_DEFAULT", "GRID_BOUNDS", "GRID_N", "P0_SWEEP", "RESAMPLING_SWEEP",
    "N_SWEEP", "FILTER_LABELS", "MODEL_LABELS", "make_model", "make_filters", "simulate", "run",
    "table1", "gap_to", "per_time_rmse", "statistic_readings", "sensitivity",
    "rmse_and_cost_vs_n", "cost_ratios", "jacobian_check", "literal_eq11_ekf",
    "eq9_linearisation_check", "resampling_after_estimate_effect", "published_table1",
    "cost_evidence", "cost_count_table", "CHOICES", "STATISTICS", "STATISTIC_LABELS", "statistic_reading", "ratio_reading",
    "FEW_FRACTIONS", "SIS_RUNS", "DEGEN_N", "KF_CHECK_N", "GH_NODES", "ADF_GRID", "linear_model",
    "kf_linear_check", "gaussian_adf", "truncation_check", "proposal_check", "degeneracy_vs_n", "ESS_WINDOW", "late_ess", "degeneracy", "N_SPREAD_SETS", "spread_seeds",
    "ekf_seed_spread", "published_text", "FILTERS", "GRID_CONV_RUNS", "grid_convergence", "Li2012Results", "run_all"]

PAPER = "ekf_pf_li2012"
#: horizon (60 s at 1 s sampling), particles, Monte Carlo counts (sec 2, Table 1)
T = 60
N_PARTICLES = 1000
RUNS_TABLE = 100
RUNS_FIGURES = 50
#: the book's seeds (fixed before any result was seen, never changed) of the Table 1 runs, the
#: figure runs, and the first of the further seed sets of the EKF spread (:func:`spread_seeds`).
#: Functions take their seed as an argument; :func:`run_all` resolves these (:func:`pfrepro.papers.resolve_seeds`).
SEEDS = {"table": 2012, "figures": 2013, "spread": 2101}
#: the book's Table 1 and figure seeds (``SEEDS["table"]``, ``SEEDS["figures"]``), for modules that
#: rerun the chapter's truths (:mod:`pfrepro.experiments.today`)
SEED_TABLE = SEEDS["table"]
SEED_FIGURES = SEEDS["figures"]
#: the filters of the Table 1 runs besides SIS (gap table, readings, cost)
FILTERS = ("EKF", "UKF", "PF", "Exact")
#: assumptions (not in the paper) -- filters' prior N(x0, P0) and resampling scheme
P0_DEFAULT = 2.0
RESAMPLING_DEFAULT = "multinomial"
#: exact-posterior grid, dx = 0.05 (sqrt(Q) / 63); bounds hold every trajectory with a wide margin
GRID_BOUNDS = (-70.0, 70.0)
GRID_N = 2801
#: sensitivity sweeps
P0_SWEEP = (0.1, 1.0, 2.0, 5.0, 10.0)
RESAMPLING_SWEEP = ("multinomial", "systematic", "stratified", "residual")
N_SWEEP = (50, 100, 200, 500, 1000, 2000, 5000)
#: mass allowed to leave the grid before the grid reference is refused
MAX_LOST_MASS = 1e-6
#: runs of the grid-convergence check (the first runs of the Table 1 data)
GRID_CONV_RUNS = 20
#: readings of Table 1's "RMSE over 100 independent runs" (per-run formula at the end of sec 2)
STATISTICS = ("mean_run_rmse", "pooled", "mean_time_rmse")
STATISTIC_LABELS = {"mean_run_rmse": "mean over runs of the per-run RMSE",
                    "pooled": "root of the MSE pooled over runs and times",
                    "mean_time_rmse": "time average of the per-time RMSE over runs (Figs. 2, 4)"}
#: SIS degeneracy (sec 1.3.2 — "after some iterations all but very few particles have
#: negligible weight"): "very few" read as an ESS below 1 % or 5 % of N, averaged over the
#: second half of the run (k = 31..60), fixed before running
FEW_FRACTIONS = (0.01, 0.05)
ESS_WINDOW = (31, 60)
#: runs of the SIS readings under the other priors P0 (the verdict is far from the bar)
SIS_RUNS = 20
#: the particle counts of the degeneracy-against-N check (l.135); SIS (no resampling) on model 1
DEGEN_N = (100, 1000, 10000)
#: the particle counts at which the PF is set beside the KF on the linear-Gaussian model (l.35)
KF_CHECK_N = (100, 1000)
#: Gauss-Hermite nodes of the exact predictive moments (no-truncation Gaussian filter) and of the
#: optimal proposal's weight p(y_k | x_{k-1}) (l.137, l.145)
GH_NODES = 48
#: nodes of the no-truncation Gaussian filter's update grid (m_pred +- 10 sd_pred)
ADF_GRID = 2001
#: seed sets for the spread of the Table 1 EKF means over independent 100-run sets, fixed
#: before running: the Table 1 seed and ten more (:func:`spread_seeds`)
N_SPREAD_SETS = 10

#: The assumptions table — every value the paper leaves open, with its status
#: (pfrepro.choices; CONTRIBUTING "Free choices").
CHOICES = [
    FreeChoice("model", "Q = 10, R = 1, x0 = 0.1, T = 60, N = 1000; 100 runs (Table 1), 50 (Figs.)",
               FIXED, "stated in the paper",
               "l.171 (Q = 10, R = 1, x0 = 0.1, 60 s at 1 s, N = 1000, 50 runs); l.175, l.179 (models); "
               "l.181, l.188 (Table 1: 100 runs); l.197, l.205 (Figs. 2, 4: 50 runs)"),
    FreeChoice("P0", f"prior N(x0, P0), x0 = 0.1, P0 = {P0_DEFAULT:g}", SWEEP,
               "the filters' initial distribution is not stated; the MATLAB code of this benchmark that "
               "accompanies Simon (2006, ch. 15), which has the paper's x0 = 0.1 and cos(1.2(k-1)), starts "
               "EKF and PF from N(x0, 2); swept over P0 = " + ", ".join(f"{v:g}" for v in P0_SWEEP) +
               " for EKF, PF, exact and SIS (sensitivity table and figure)",
               "not stated (l.171 gives the truth's x0 only)"),
    FreeChoice("resampling", RESAMPLING_DEFAULT + ", every step", SWEEP,
               "the paper lists four schemes and resamples every step; multinomial is the scheme of the "
               "same code and the simplest; swept over " + ", ".join(RESAMPLING_SWEEP),
               "l.147 lists multinomial, residual, stratified, systematic; l.163 resamples every step"),
    FreeChoice("statistic", "mean_run_rmse", READING,
               "Table 1 prints 'RMSE over 100 independent runs' and defines the RMSE of one run; the mean "
               "over runs of that per-run RMSE is the natural reading; the pooled root mean square and the "
               "time average of the per-time RMSE of Figs. 2, 4 are run as readings (standard errors by "
               "jackknife over runs)", "l.188 (Table 1 title); formula at the end of sec 2"),
    FreeChoice("ekf_linearisation", "B_k at x_{k|k-1}", FIXED,
               "as eq (10) states; the circulating code's B_k at x_{k-1|k-1} is shown as context only",
               "l.101, eq (10)"),
    FreeChoice("estimate", "weighted mean before resampling", FIXED,
               "step (5) writes the estimate with the particles x_k^i of steps (2)-(3), not the resampled "
               "x~_k^i of step (4), so its weights are those of step (3); averaging the resampled particles "
               "instead would add Var(x_k | y_1:k)/N to the squared error in expectation (computed in the "
               "chapter: a fraction of a percent)", "l.165-167, steps (4)-(5)"),
    FreeChoice("fig_rmse", "per-time RMSE over the runs", FIXED,
               "the figures' 'RMSE of 50 Monte Carlo runs' at each time step", "l.197, l.205 (Figs. 2, 4 captions)"),
    FreeChoice("few", "ESS < 1 % of N", READING,
               "'all but very few particles have negligible weight' (SIS) read as an ESS averaged over "
               f"k = {ESS_WINDOW[0]}..{ESS_WINDOW[1]} below 1 % or 5 % of N; both run",
               "l.133"),
    FreeChoice("sis_runs", f"at least {SIS_RUNS} runs, more if the plan asks", DESIGN,
               "the runs of the SIS readings under the other priors: the first runs of the Table 1 truths; "
               f"at least {SIS_RUNS}, and as many as the power plan of the degeneracy claims asks "
               "(row 'plan: SIS readings'), at most the Table 1 runs", "not in the paper"),
    FreeChoice("degen_N", "N = " + ", ".join(str(n) for n in DEGEN_N) + f", first {SIS_RUNS} runs of model 1",
               DESIGN, "l.135 names no N: the paper's N = 1000 with a tenth and ten times as many particles "
                       "(SIS, no resampling, its own stream per N); each tenfold step (100 to 1000, 1000 to "
                       "10000) is run as a reading of the claim", "l.135"),
    FreeChoice("degen_measure", "count", READING,
               "l.135's 'reduce the degeneracy' read on the number of effective particles (SIS's late ESS "
               "gains at least one particle when N grows tenfold) or on their share of N (ESS/N grows); "
               "both run, each in particles at the paper's N", "l.133-135"),
    FreeChoice("kf_check", "x_k = x_{k-1}/2 + w_k, y_k = x_k + v_k, Q = 10, R = 1, x0 = 0.1, P0 = 2; "
               + ", ".join(f"PF N = {n}" for n in KF_CHECK_N) + f"; {RUNS_TABLE} runs", DESIGN,
               "l.35 names no model: the paper's noise levels and start with the nonlinear terms removed; the "
               "KF is set against the exact grid posterior mean (the MMSE estimate) and the bootstrap PF",
               "l.35"),
    FreeChoice("gaussian_exact", f"Gaussian filter, exact moments ({GH_NODES} Gauss-Hermite nodes, "
               f"{ADF_GRID}-node update grid)", DESIGN,
               "the filter that keeps the EKF's Gaussian form but drops its first-order truncation "
               "(eqs 8-10): the test of l.181's 'the error comes from the truncation'", "l.181"),
    FreeChoice("proposal_runs", f"the {RUNS_TABLE} Table 1 runs of each model, N = {N_PARTICLES}, own stream", DESIGN,
               "the bootstrap PF that records, per step, the ESS of its prior-proposal weights and the ESS the "
               "optimal proposal would give on the same particles (l.137, l.145)", "l.137-145"),
]

FILTER_LABELS = {
    "EKF": "EKF (eqs 8-11)",
    "EKF-prev": "EKF, B at x_{k-1|k-1} (circulating code)",
    "UKF": "UKF",
    "PF": "bootstrap PF (eqs 15-16)",
    "SIS": "SIS (eq 16, no resampling)",
    "Exact": "exact posterior mean (grid)",
}
MODEL_LABELS = {1: "Model 1", 2: "Model 2"}


# --------------------------------------------------------------------------------------
# model and filters
# --------------------------------------------------------------------------------------
def _check_which(which) -> int:
    if which not in (1, 2) or isinstance(which, bool):
        raise ValueError(f"Li et al. (2012) have models 1 and 2; got which={which!r}")
    return int(which)


def make_model(which: int, P0: float = P0_DEFAULT) -> UNGM:
    """Model 1 or 2 of Li et al. (2012, sec 2), with the filters' prior N(0.1, P0).

    Q = 10, R = 1, truth starts at x_0 = 0.1; the transition from x_{k-1} to x_k uses
    cos(1.2(k-1)) (``time_offset=1``).
    """
    which = _check_which(which)
    P0 = float(P0)
    if not (math.isfinite(P0) and P0 > 0):
        raise ValueError(f"P0 must be a positive finite variance, got {P0}")
    return UNGM.li2012_model1(P0=P0) if which == 1 else UNGM.li2012_model2(P0=P0)


def make_filters(model, include=("EKF", "PF", "Exact"), *, n_particles: int = N_PARTICLES,
                 resampling: str = RESAMPLING_DEFAULT) -> dict:
    """The filters of the experiment, by name (see ``FILTER_LABELS``).

    ``EKF`` is eqs (8)-(11); ``EKF-prev`` linearises h at x_{k-1|k-1} as the circulating
    MATLAB code does; ``PF`` is the bootstrap filter of eqs (15)-(16), resampling every
    step; ``SIS`` is the same filter that never resamples (sequential importance sampling,
    eq 16 with w_{k-1} carried over: the degenerate method that motivates resampling in sec
    1.3.2); ``Exact`` is the point-mass grid filter (the exact posterior mean up to grid
    error, the accuracy reference); ``UKF`` is the unscented filter (alpha=1, beta=2,
    kappa=0).
    """
    builders = {
        "EKF": lambda: ExtendedKalmanFilter(model),
        "EKF-prev": lambda: PreviousEstimateJacobianEKF(model),
        "UKF": lambda: UnscentedKalmanFilter(model),
        "PF": lambda: BootstrapParticleFilter(model, n_particles, resampling=resampling, ess_threshold=None),
        # sequential importance sampling: eq (16) without ever resampling (ESS threshold 0)
        "SIS": lambda: BootstrapParticleFilter(model, n_particles, resampling=resampling, ess_threshold=0.0),
        "Exact": lambda: GridFilter(model, bounds=GRID_BOUNDS, n_grid=GRID_N),
    }
    if isinstance(include, str):
        include = (include,)
    unknown = [n for n in include if n not in builders]
    if unknown:
        raise ValueError(f"unknown filter(s) {unknown}; choose from {sorted(builders)}")
    return {name: builders[name]() for name in include}


def simulate(which: int, runs: int, seed: int) -> Simulation:
    """Truth and measurements for ``runs`` runs of model ``which`` (independent of P0)."""
    runs = check_positive_int(runs, "runs")
    return make_model(which).simulate(T, runs, truth_streams(seed, runs))


def run(which: int, runs: int, seed: int, include=("EKF", "PF", "Exact"), *, P0: float = P0_DEFAULT,
        n_particles: int = N_PARTICLES, resampling: str = RESAMPLING_DEFAULT,
        sim: Simulation | None = None, time_per_run: bool = False, executor=None) -> MonteCarloResult:
    """Run the filters ``include`` on ``runs`` runs of model ``which`` (all on the same data).

    Random streams: truth from ``truth_streams(seed, runs)``, each filter from
    ``filter_streams(seed, name, runs)`` (per run). ``executor``: see
    :func:`pfrepro.montecarlo.run_monte_carlo` (the per-run timing stays serial).
    If the exact grid filter is included, its lost probability mass is checked.
    """
    model = make_model(which, P0)
    filters = make_filters(model, include, n_particles=n_particles, resampling=resampling)
    res = run_monte_carlo(model, filters, T, runs, seed, sim=sim, time_per_run=time_per_run,
                          executor=executor)
    if "Exact" in res.results:
        lost = float(np.max(np.abs(res.results["Exact"].diagnostics["lost_mass"])))
        if lost > MAX_LOST_MASS:
            raise RuntimeError(f"grid lost probability mass {lost:.3g} > {MAX_LOST_MASS}: widen GRID_BOUNDS")
    return res


# --------------------------------------------------------------------------------------
# statistics (ratio_of_means: pfrepro.stats)
# --------------------------------------------------------------------------------------
def gap_to(res: MonteCarloResult, name: str, ref: str = "Exact") -> dict:
    """Mean per-run RMSE gap of filter ``name`` above ``ref`` (paired), with its SE."""
    d = res.rmse(name) - res.rmse(ref)
    s = mc_summary(d)
    base = float(res.rmse(ref).mean())
    return {"gap": s.mean, "se": s.se, "relative": s.mean / base}


def published_table1() -> pd.DataFrame:
    """Table 1 of the paper (RMSE over 100 runs), rows EKF/PF, columns Model 1/Model 2."""
    return published.table(PAPER, "Table 1")


def table1(results: dict, names=("EKF", "PF")) -> pd.DataFrame:
    """Table 1 regenerated: one row per (model, filter), beside the published value.

    ``results`` maps model number -> :class:`~pfrepro.montecarlo.MonteCarloResult` (with the exact grid run).
    Columns: our mean per-run RMSE and its standard error, the published value, z (in our
    SE), the verdict of the claims rule for this cell, and the exact-posterior RMSE on the
    same data.
    """
    pub = published_table1()
    rows = []
    for which, res in results.items():
        exact = mc_summary(res.rmse("Exact")) if "Exact" in res.results else None
        for name in names:
            s = mc_summary(res.rmse(name))
            p = float(pub.loc[name, MODEL_LABELS[which]]) if name in pub.index else float("nan")
            rows.append({
                "model": MODEL_LABELS[which], "filter": name, "published": p, "ours": s.mean, "se": s.se,
                "z": (s.mean - p) / s.se if s.se > 0 else float("nan"),
                "verdict": verdict(published=p, reproduced=s.mean, se=s.se) if math.isfinite(p) else "",
                "exact": exact.mean if exact else float("nan"),
                "exact_se": exact.se if exact else float("nan"),
                "published_minus_exact_in_se": (p - exact.mean) / exact.se if exact else float("nan"),
            })
    return pd.DataFrame(rows)


def per_time_rmse(res: MonteCarloResult, names) -> pd.DataFrame:
    """Per-time RMSE across runs (Figs. 2 and 4), index k = 1..T, one column per filter."""
    data = {n: rmse_over_time(res.x_true, res.results[n].x) for n in names}
    return pd.DataFrame(data, index=pd.RangeIndex(1, res.sim.T + 1, name="k"))


def statistic_readings(res: MonteCarloResult, names) -> pd.DataFrame:
    """Three readings of "RMSE over 100 runs" for each filter.

    * ``mean_run_rmse``: mean over runs of the per-run RMSE (the paper's formula, sec 2);
    * ``pooled``: sqrt of the MSE pooled over runs and times;
    * ``mean_time_rmse``: time average of the per-time RMSE across runs (the curves of Figs. 2, 4).
    """
    rows = {}
    for n in names:
        e2 = (res.results[n].x - res.x_true) ** 2
        rows[n] = {"mean_run_rmse": float(rmse(res.x_true, res.results[n].x).mean()),
                   "pooled": float(np.sqrt(e2.mean())),
                   "mean_time_rmse": float(rmse_over_time(res.x_true, res.results[n].x).mean())}
    return pd.DataFrame(rows).T


def _stat(e2: np.ndarray, statistic: str) -> float:
    """One reading of Table 1's statistic from squared errors ``e2`` (runs, T)."""
    if statistic == "mean_run_rmse":
        return float(np.sqrt(e2.mean(axis=1)).mean())
    if statistic == "pooled":
        return float(np.sqrt(e2.mean()))
    if statistic == "mean_time_rmse":
        return float(np.sqrt(e2.mean(axis=0)).mean())
    raise ValueError(f"unknown statistic {statistic!r}; choose from {STATISTICS}")


def _jackknife_se(e2_list, fn) -> float:
    """Jackknife (leave one run out) standard error of ``fn(*e2_list)``; arrays (runs, T) paired by run.
    For the mean of per-run values it equals the usual std(ddof=1)/sqrt(n)."""
    n = e2_list[0].shape[0]
    if n < 2:
        raise ValueError("jackknife needs at least 2 runs")
    idx = np.arange(n)
    loo = np.array([fn(*(e[idx != i] for e in e2_list)) for i in range(n)])
    return float(np.sqrt((n - 1) / n * ((loo - loo.mean()) ** 2).sum()))


def _e2(res: MonteCarloResult, name: str) -> np.ndarray:
    return ((res.results[name].x - res.x_true) ** 2)[..., 0]


def statistic_reading(res: MonteCarloResult, name: str, statistic: str) -> tuple[float, float]:
    """Filter ``name``'s Table 1 value under one reading of the statistic (``STATISTICS``),
    with its standard error: exact for the mean of per-run RMSEs, jackknife over runs for the
    other two (they are not means of independent per-run values)."""
    e2 = _e2(res, name)
    if statistic == "mean_run_rmse":
        s = mc_summary(np.sqrt(e2.mean(axis=1)))
        return s.mean, s.se
    return _stat(e2, statistic), _jackknife_se([e2], lambda a: _stat(a, statistic))


def ratio_reading(res: MonteCarloResult, a: str, b: str, statistic: str) -> tuple[float, float]:
    """Ratio of filter ``a``'s to filter ``b``'s Table 1 value under one reading of the statistic,
    with its standard error (delta method for the main reading, as :func:`~pfrepro.stats.ratio_of_means`;
    jackknife over runs, paired, for the others)."""
    ea, eb = _e2(res, a), _e2(res, b)
    if statistic == "mean_run_rmse":
        return ratio_of_means(np.sqrt(ea.mean(axis=1)), np.sqrt(eb.mean(axis=1)))
    fn = lambda x, y: _stat(x, statistic) / _stat(y, statistic)
    return fn(ea, eb), _jackknife_se([ea, eb], fn)


def published_text(name: str, which: int) -> str:
    """Table 1's cell for filter ``name`` and model ``which`` as the paper prints it."""
    return published.printed(PAPER, "Table 1", name, MODEL_LABELS[_check_which(which)])


# --------------------------------------------------------------------------------------
# degeneracy of plain importance sampling (sec 1.3.2)
# --------------------------------------------------------------------------------------
def late_ess(res: MonteCarloResult, name: str, window=ESS_WINDOW) -> np.ndarray:
    """Per-run effective sample size 1 / sum_i w_i^2 of filter ``name`` (before any resampling),
    averaged over the steps ``window`` (k, inclusive); shape (runs,)."""
    ess = np.asarray(res.results[name].diagnostics["ess"], float)
    lo, hi = int(window[0]), int(window[1])
    if not 1 <= lo <= hi <= ess.shape[1]:
        raise ValueError(f"ESS window {window} outside 1..{ess.shape[1]}")
    return ess[:, lo - 1:hi].mean(axis=1)


def degeneracy(res: MonteCarloResult, names=("SIS", "PF"), n_particles: int = N_PARTICLES) -> dict:
    """ESS over time of SIS (no resampling) and the PF (resampling every step; its ESS is that of
    the weights before resampling), and the per-run statistics the degeneracy claims use.

    Returns ``{"ess_over_time": DataFrame}`` (index k, columns (filter, median/q10/q90) of
    ESS / N over runs) and, per filter, ``late`` (per-run ESS averaged over ``ESS_WINDOW``),
    ``first_below`` (per run, the first k with ESS < 1 % of N, NaN if never) and the RMSE.
    """
    out, cols = {}, {}
    for n in names:
        ess = np.asarray(res.results[n].diagnostics["ess"], float) / n_particles
        cols[(n, "median")] = np.median(ess, axis=0)
        cols[(n, "q10")] = np.quantile(ess, 0.1, axis=0)
        cols[(n, "q90")] = np.quantile(ess, 0.9, axis=0)
        below = ess < FEW_FRACTIONS[0]
        first = np.where(below.any(axis=1), below.argmax(axis=1) + 1.0, np.nan)
        out[n] = {"late": late_ess(res, n), "first_below": first, "rmse": res.rmse(n)}
    out["ess_over_time"] = pd.DataFrame(cols, index=pd.RangeIndex(1, res.sim.T + 1, name="k"))
    return out


# --------------------------------------------------------------------------------------
# spread of the Table 1 EKF means over independent seed sets
# --------------------------------------------------------------------------------------
def _spread_one(args):
    which, seed, runs, names = args
    model = make_model(which)
    sim = simulate(which, runs, seed)
    rows = []
    for n, f in make_filters(model, names).items():
        s = mc_summary(rmse(sim.x[:, 1:], f.filter(sim.y).x))
        rows.append({"model": MODEL_LABELS[which], "seed": int(seed), "filter": n, "mean": s.mean, "se": s.se})
    return rows


def spread_seeds(seeds: dict | None = None) -> tuple:
    """The seed sets of the EKF spread: the Table 1 seed, then ``N_SPREAD_SETS`` consecutive seeds
    from ``seeds["spread"]`` (``seeds``: a dict like :data:`SEEDS`; ``None``: the book's)."""
    seeds = SEEDS if seeds is None else seeds
    return (int(seeds["table"]),) + tuple(range(int(seeds["spread"]), int(seeds["spread"]) + N_SPREAD_SETS))


def ekf_seed_spread(seeds=None, runs: int = RUNS_TABLE, names=("EKF", "EKF-prev"),
                    executor=None) -> pd.DataFrame:
    """Mean per-run RMSE (and SE) of the deterministic EKFs on ``runs`` runs of each model for
    every seed set in ``seeds`` (truths from ``truth_streams(seed, runs)``; ``None``: the book's,
    :func:`spread_seeds`): how far the Table 1 EKF means move between independent 100-run sets
    (the EKF's per-run RMSE on model 1 is heavy-tailed). The EKFs draw no random numbers, so this
    costs simulations and EKF runs only; ``executor`` (optional) maps over (model, seed) pairs,
    with the same numbers as serially."""
    seeds = spread_seeds() if seeds is None else seeds
    jobs = [(w, int(seed), int(runs), tuple(names)) for w in (1, 2) for seed in seeds]
    results = executor.map(_spread_one, jobs) if executor is not None else map(_spread_one, jobs)
    return pd.DataFrame([row for rows in results for row in rows])


# --------------------------------------------------------------------------------------
# sensitivity to the unstated choices
# --------------------------------------------------------------------------------------
def sensitivity(sims: dict, seed: int, *, P0_values=P0_SWEEP, schemes=RESAMPLING_SWEEP,
                ekf_variants=("EKF", "EKF-prev"), sis_runs: int = 0, executor=None) -> pd.DataFrame:
    """Table 1 cells and verdicts under every reasonable choice the paper leaves open.

    ``sims`` maps model number -> the Table 1 simulation (every setting sees the same data,
    so differences come from the setting alone). One row per (setting, model): the EKF and
    PF mean per-run RMSE with SE, the exact-posterior RMSE, the EKF/PF ratio, the paired
    per-run RMSE difference EKF - PF (``diff``, ``diff_se``), and the verdicts the claims
    rule gives for the two cells and for the model's ratio claim ("more than 7x" on model
    1, "about the same" on model 2: ``pfrepro.verdicts.ekf_pf_li2012.ratio_diff``). The baseline (P0 = 2,
    multinomial, eq-10 EKF) appears in each block.

    ``sis_runs > 0``: also the degeneracy statistics on the first ``sis_runs`` runs (common
    runs): SIS (run under each P0; it never resamples, so the scheme rows use the baseline
    SIS) and the PF's ESS averaged over ``ESS_WINDOW`` (``SIS_ess``, ``PF_ess`` with SEs)
    and their paired difference PF - SIS (``ess_gain``, ``ess_gain_se``).
    """
    from ..verdicts.ekf_pf_li2012 import ratio_diff, ratio_effect   # the ratio claims' statements live there

    pub = published_table1()
    rows = []
    sis_late = {}

    def add(kind, value, which, res, ekf_name="EKF", sis=None):
        e, p = mc_summary(res.rmse(ekf_name)), mc_summary(res.rmse("PF"))
        r, r_se = ratio_of_means(res.rmse(ekf_name), res.rmse("PF"))
        dd = mc_summary(res.rmse(ekf_name) - res.rmse("PF"))
        d, d_se = dd.mean, dd.se
        col = MODEL_LABELS[which]
        pe, pp = float(pub.loc["EKF", col]), float(pub.loc["PF", col])
        row = {"setting": kind, "value": value, "model": col,
               "EKF": e.mean, "EKF_se": e.se, "PF": p.mean, "PF_se": p.se,
               "exact": float(res.rmse("Exact").mean()) if "Exact" in res.results else float("nan"),
               "EKF/PF": r, "EKF/PF_se": r_se, "diff": d, "diff_se": d_se,
               "verdict_EKF": verdict(pe, e.mean, e.se), "verdict_PF": verdict(pp, p.mean, p.se),
               "verdict_ratio": verdict(pe / pp, r, r_se, diff=ratio_diff(which, r), diff_se=r_se,
                                          effect=ratio_effect(which), runs=res.sim.runs)}
        if sis is not None:
            pf_late = late_ess(res, "PF")[:sis_runs]
            ps, ss, g = mc_summary(pf_late), mc_summary(sis), mc_summary(pf_late - sis)
            row.update({"SIS_ess": ss.mean, "SIS_ess_se": ss.se, "PF_ess": ps.mean, "PF_ess_se": ps.se,
                        "ess_gain": g.mean, "ess_gain_se": g.se})
        rows.append(row)

    for which, sim in sims.items():
        runs = sim.runs
        sub = Simulation(sim.x[:sis_runs], sim.y[:sis_runs]) if sis_runs else None
        for P0 in P0_values:
            sis = None
            if sis_runs:
                rs = run(which, sis_runs, seed, ("SIS",), P0=P0, sim=sub, executor=executor)
                sis = late_ess(rs, "SIS")
                if P0 == P0_DEFAULT:
                    sis_late[which] = sis
            add("P0", P0, which, run(which, runs, seed, ("EKF", "PF", "Exact"), P0=P0, sim=sim,
                                   executor=executor), sis=sis)
        for scheme in schemes:
            add("resampling", scheme, which, run(which, runs, seed, ("EKF", "PF"), resampling=scheme, sim=sim,
                                           executor=executor), sis=sis_late.get(which))
        res = run(which, runs, seed, tuple(ekf_variants) + ("PF",), sim=sim, executor=executor)
        for ek in ekf_variants:
            add("EKF linearisation", FILTER_LABELS[ek], which, res, ekf_name=ek)
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------------------
# beyond the paper: RMSE and cost against N, cost ratios
# --------------------------------------------------------------------------------------
def _batch_seconds(filt, y, seed: int, min_total: float = 0.5, max_repeats: int = 15) -> float:
    """Median wall time of one batched call ``filt.filter(y)`` on all runs; a fast filter is
    repeated until ``min_total`` seconds have been spent (at most ``max_repeats`` calls), so a
    5-ms call is not one noisy sample."""
    times, total = [], 0.0
    while len(times) < max_repeats and (not times or total < min_total):
        t = time_single_run(filt, y, rng_seed=seed + len(times), repeats=1, warmup=not times)
        times.append(t)
        total += t
    return float(np.median(times))


def cost_ratios(which: int, sim: Simulation, *, include=FILTERS, repeats: int = 7,
                seed: int | None = None) -> pd.DataFrame:
    """Per-run wall time of each filter relative to the EKF, measured here in one session.

    ``single_run``: median time on the first run alone (``time_single_run``), ``repeats``
    interleaved across the filters so machine load affects all alike. ``amortised``: the
    median time of the batched call on all ``sim.runs`` runs divided by the number of runs,
    which removes the fixed per-step interpreter overhead that dominates a one-run EKF and
    so measures the arithmetic. ``seed``: the filters' streams (``None``: the book's Table 1 seed).
    """
    seed = SEEDS["table"] if seed is None else int(seed)
    check_positive_int(repeats, "repeats")
    if "EKF" not in include:
        raise ValueError("cost ratios are relative to the EKF: include must contain 'EKF'")
    filters = make_filters(make_model(which), include)
    t = time_filters(filters, sim.y[:1], seed, repeats)
    out = pd.DataFrame({"single_run_s": t})
    out["single_run_ratio"] = out["single_run_s"] / out.loc["EKF", "single_run_s"]
    out["amortised_s"] = pd.Series({n: _batch_seconds(f, sim.y, seed) / sim.runs for n, f in filters.items()})
    out["amortised_ratio"] = out["amortised_s"] / out.loc["EKF", "amortised_s"]
    return out


def rmse_and_cost_vs_n(which: int, sim: Simulation, seed: int, n_values=N_SWEEP, *,
                       exact: np.ndarray | None = None, repeats: int = 5) -> pd.DataFrame:
    """PF mean per-run RMSE against N (same data, same seed family), its gap to the exact
    posterior (if the exact per-run RMSEs are given), and its cost relative to the EKF,
    measured in this session: single-run (median of interleaved repeats) and amortised
    (time of the batched call over all runs, against the EKF's median batched time)."""
    n_values = [check_positive_int(n, "N") for n in n_values]
    check_positive_int(repeats, "repeats")
    model = make_model(which)
    ekf = ExtendedKalmanFilter(model)
    t_ekf_batch = _batch_seconds(ekf, sim.y, seed)    # the reference, timed once
    rows = []
    for N in n_values:
        name = f"PF N={N}"
        pf = BootstrapParticleFilter(model, N, resampling=RESAMPLING_DEFAULT)
        res = run_monte_carlo(model, {name: pf}, T, sim.runs, seed, sim=sim)
        t = time_filters({"EKF": ekf, name: pf}, sim.y[:1], seed, repeats)
        s = mc_summary(res.rmse(name))
        row = {"N": N, "rmse": s.mean, "se": s.se,
               "single_run_ratio": t[name] / t["EKF"],
               "amortised_ratio": res.batch_seconds[name] / t_ekf_batch}
        if exact is not None:
            exact = np.asarray(exact, float)
            if exact.shape != (sim.runs,):
                raise ValueError(f"exact must hold one RMSE per run, shape ({sim.runs},), got {exact.shape}")
            d = mc_summary(res.rmse(name) - exact)
            row.update({"gap": d.mean, "gap_se": d.se})
        rows.append(row)
    return pd.DataFrame(rows).set_index("N")


# --------------------------------------------------------------------------------------
# numerical checks of the paper's equations
# --------------------------------------------------------------------------------------
def jacobian_check(model, n_points: int = 1000, seed: int = 0, k: int = 3, step: float = 1e-6) -> dict:
    """Max relative error between the model's Jacobians (A_{k-1}, B_k of eq 10) and central
    finite differences of f and h at random points in [-30, 30]."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-30, 30, size=(check_positive_int(n_points, "n_points"), 1))
    fd_f = (model.f(x + step, k) - model.f(x - step, k)) / (2 * step)
    fd_h = (model.h(x + step) - model.h(x - step)) / (2 * step)
    A = model.jacobian_f(x, k)[..., 0]
    B = model.jacobian_h(x)[..., 0]
    rel = lambda a, b: float(np.max(np.abs(a - b) / np.maximum(1.0, np.abs(b))))
    return {"A (df/dx)": rel(A, fd_f), "B (dh/dx)": rel(B, fd_h)}


def literal_eq11_ekf(model, y, m0: float | None = None, P0: float | None = None) -> np.ndarray:
    """Eq (11) written out literally for a scalar model, batched over runs: returns x_{k|k}
    ``(runs, T, 1)``. Used to check that :class:`~pfrepro.filters.ExtendedKalmanFilter` (Joseph form) is the
    paper's EKF: x- = f(x), P- = A P A + Q, K = P- B / (B P- B + R), x = x- + K (y - h(x-)),
    P = P- - K B P-."""
    y = np.asarray(y, float)
    if y.ndim != 3 or y.shape[2] != 1 or model.dim_x != 1:
        raise ValueError("literal_eq11_ekf is for scalar models and y of shape (runs, T, 1)")
    runs, Tn, _ = y.shape
    x = np.full(runs, float(model.m0[0] if m0 is None else m0))
    P = np.full(runs, float(model.P0[0, 0] if P0 is None else P0))
    Q, R = float(model.Q[0, 0]), float(model.R[0, 0])
    out = np.empty((runs, Tn, 1))
    for k in range(1, Tn + 1):
        A = model.jacobian_f(x[:, None], k)[:, 0, 0]
        xp = model.f(x[:, None], k)[:, 0]
        Pp = A * P * A + Q
        B = model.jacobian_h(xp[:, None])[:, 0, 0]
        K = Pp * B / (B * Pp * B + R)
        x = xp + K * (y[:, k - 1, 0] - model.h(xp[:, None])[:, 0])
        P = Pp - K * B * Pp
        out[:, k - 1, 0] = x
    return out


def eq9_linearisation_check(model, deltas=(1.0, 0.1, 0.01, 0.001), seed: int = 0, n: int = 1000) -> pd.DataFrame:
    """Eq (9) as printed, y_k ≈ B_k x_{k-1} + h(x_{k|k-1}) - B_k x_{k|k-1}, against the
    corrected form with B_k x_k. At random (x_{k-1}, x_{k|k-1}) and x_k = x_{k|k-1} + delta,
    the corrected form's error in h(x_k) shrinks like delta^2 (first-order Taylor), the
    printed form's does not shrink at all."""
    rng = np.random.default_rng(seed)
    x_prev = rng.uniform(-20, 20, size=(n, 1))
    x_pred = model.f(x_prev, 3)
    B = model.jacobian_h(x_pred)[..., 0]
    rows = []
    for d in deltas:
        xk = x_pred + d * rng.choice([-1.0, 1.0], size=x_pred.shape)
        truth = model.h(xk)
        corrected = model.h(x_pred) + B * (xk - x_pred)
        printed = model.h(x_pred) + B * (x_prev - x_pred)
        rows.append({"delta": d, "corrected_max_err": float(np.max(np.abs(truth - corrected))),
                     "printed_max_err": float(np.max(np.abs(truth - printed)))})
    return pd.DataFrame(rows).set_index("delta")


def resampling_after_estimate_effect(res: MonteCarloResult, n_particles: int = N_PARTICLES) -> dict:
    """Step (5) of the algorithm averages the particles *after* resampling (weights 1/N); we
    average before. With exact multinomial resampling that adds Var(x_k | y_1:k)/N to the
    squared error in expectation. Returns that added variance relative to the exact
    posterior's MSE, per model run set (uses the grid's posterior variances)."""
    ex = res.results["Exact"]
    post_var = float(ex.P[..., 0, 0].mean())
    mse_exact = float(((ex.x - res.x_true) ** 2).mean())
    return {"added_var": post_var / n_particles, "relative_to_mse": post_var / n_particles / mse_exact}


def cost_count_table(which: int, sim: Simulation, *, include=FILTERS, seed: int | None = None) -> pd.DataFrame:
    """Deterministic cost counts of each filter on run 1 (:func:`pfrepro.cost.cost_counts`: states
    drawn, likelihoods, f/h evaluations and Jacobians), per time step and as a ratio to the EKF's:
    what the cost claim is decided on (no clock involved). ``seed``: the filters' streams
    (``None``: the book's Table 1 seed)."""
    from ..cost import cost_counts

    seed = SEEDS["table"] if seed is None else int(seed)
    if "EKF" not in include:
        raise ValueError("cost evidence is relative to the EKF: include must contain 'EKF'")
    filters = make_filters(make_model(which), include)
    y1 = sim.y[:1]
    evals = cost_counts(filters, y1, rng_seed=seed)["model_evaluations"] / y1.shape[1]
    return pd.DataFrame({"model evals / step": evals, "count ratio": evals / evals["EKF"]}).rename_axis("filter")


def cost_evidence(which: int, sim: Simulation, *, include=FILTERS, repeats: int = 7,
                  seed: int | None = None) -> pd.DataFrame:
    """:func:`cost_count_table` beside each filter's single-run wall time as a ratio to the EKF,
    median and [min, max] over ``repeats`` interleaved repeats (:func:`pfrepro.cost.time_repeats`).
    The count decides the cost claim; the time is context. ``seed``: the filters' streams
    (``None``: the book's Table 1 seed)."""
    from ..cost import time_repeats, time_summary

    seed = SEEDS["table"] if seed is None else int(seed)
    check_positive_int(repeats, "repeats")
    counts = cost_count_table(which, sim, include=include, seed=seed)
    times = time_summary(time_repeats(make_filters(make_model(which), include), sim.y[:1], seed, repeats),
                         reference="EKF")
    return counts.assign(**{"time ratio": times["ratio median"], "time ratio min": times["ratio min"],
                            "time ratio max": times["ratio max"]})


def grid_convergence(sims: dict, runs: int = GRID_CONV_RUNS) -> float:
    """Largest change of the exact (grid) posterior means when the grid spacing is halved, on the
    first ``runs`` runs of each simulation in ``sims`` (model number -> Simulation): the grid error
    of the accuracy reference."""
    conv = 0.0
    for w, sim in sims.items():
        m = make_model(w)
        a = GridFilter(m, bounds=GRID_BOUNDS, n_grid=GRID_N).filter(sim.y[:runs]).x
        b = GridFilter(m, bounds=GRID_BOUNDS, n_grid=2 * GRID_N - 1).filter(sim.y[:runs]).x
        conv = max(conv, float(np.max(np.abs(a - b))))
    return conv


# --------------------------------------------------------------------------------------
# everything the claims need, in one call
# --------------------------------------------------------------------------------------
@dataclass
class Li2012Results:
    """Every experiment of the chapter whose numbers feed a claim or the text around it.

    Attributes
    ----------
    runs : dict
        Monte Carlo run counts used: ``table`` (Table 1, sec 2), ``figures`` (Figs. 1-4), ``sis``
        (SIS under the other priors) and ``spread`` (each seed set of the EKF spread).
    seeds : dict
        The seeds used (keys of :data:`SEEDS`).
    sims : dict
        Model number -> the Table 1 :class:`~pfrepro.models.base.Simulation`.
    res : dict
        Model number -> the Table 1 :class:`~pfrepro.montecarlo.MonteCarloResult` (EKF, UKF, PF,
        exact grid filter and SIS on the same data).
    figs : dict
        Model number -> the figure runs (EKF, PF, exact).
    sens : pandas.DataFrame
        :func:`sensitivity` on the Table 1 data, with the SIS columns.
    deg : dict
        Model number -> :func:`degeneracy` of the Table 1 runs (sec 1.3.2).
    spread : pandas.DataFrame
        :func:`ekf_seed_spread` over :func:`spread_seeds`.
    cnt : dict
        Model number -> :func:`cost_count_table` (deterministic counts of model evaluations; no
        wall time is measured here).
    grid_conv : float
        :func:`grid_convergence` on the Table 1 data.
    trunc : dict
        :func:`truncation_check` on model 1's Table 1 runs (l.181).
    kf : dict
        :func:`kf_linear_check` (l.35).
    prop : dict
        Model number -> :func:`proposal_check` (l.137, l.145).
    degen_n : dict
        :func:`degeneracy_vs_n` on model 1 (l.135).
    """

    runs: dict
    seeds: dict
    sims: dict
    res: dict
    figs: dict
    sens: pd.DataFrame
    deg: dict
    spread: pd.DataFrame
    cnt: dict
    grid_conv: float
    trunc: dict | None = None
    kf: dict | None = None
    prop: dict | None = None
    degen_n: dict | None = None

    @property
    def settings(self) -> dict:
        """The runs and seeds used, as ``pfrepro run`` prints them."""
        return {"runs (Table 1)": self.runs["table"], "runs (figures)": self.runs["figures"],
                "runs (SIS readings)": self.runs["sis"], "runs (seed spread)": self.runs["spread"],
                "seed (Table 1)": self.seeds["table"], "seed (figures)": self.seeds["figures"],
                "seeds (spread)": ", ".join(str(s) for s in spread_seeds(self.seeds))}

    def today_given(self) -> dict:
        """The chapter's own per-run MSEs of the PF and the exact filter on model 1 (Table 1 runs),
        for :func:`pfrepro.experiments.today.against_today` (not rerun there)."""
        from ..metrics import mse

        r = self.res[1]
        return {f"PF({N_PARTICLES})": mse(r.x_true, r.results["PF"].x), "exact": mse(r.x_true, r.results["Exact"].x)}


def run_all(runs: int | None = None, seeds=None, executor=None, steps=None) -> Li2012Results:
    """Run every experiment of the chapter that feeds a claim: :class:`Li2012Results`.

    Parameters
    ----------
    runs : int, optional
        ``None``: the paper's counts (Table 1 ``RUNS_TABLE``, figures ``RUNS_FIGURES``), the SIS
        readings on :data:`SIS_RUNS` runs and ``RUNS_TABLE`` runs per seed set of the spread. An int (at least 2) replaces every one of these counts.
    seeds : None, int or dict
        The seeds (:func:`pfrepro.papers.resolve_seeds` over :data:`SEEDS`).
    executor : concurrent.futures.Executor, optional
        Runs the Monte Carlo work (same numbers as serially).
    steps : callable, optional
        ``steps(label)`` is called before each experiment (a progress display).

    Returns
    -------
    Li2012Results
        The Table 1 and figure runs (sec 2), the sensitivity sweeps and readings, the SIS runs
        (sec 1.3.2), the EKF seed spread, the cost counts and the grid check.
    """
    seeds = resolve_seeds(SEEDS, seeds)
    if runs is None:
        counts = {"table": RUNS_TABLE, "figures": RUNS_FIGURES, "sis": SIS_RUNS, "spread": RUNS_TABLE}
    else:
        runs = check_positive_int(runs, "runs")
        if runs < 2:
            raise ValueError(f"the claims need standard errors over at least 2 runs, got runs={runs}")
        counts = dict.fromkeys(("table", "figures", "sis", "spread"), runs)
    step = steps or (lambda label: None)
    sims, res, figs = {}, {}, {}
    for w in (1, 2):
        step(f"Table 1, {MODEL_LABELS[w].lower()} ({counts['table']} runs)")
        sims[w] = simulate(w, counts["table"], seeds["table"])
        # SIS (the PF without resampling) on the same data and its own stream: sec 1.3.2's degeneracy
        res[w] = run(w, counts["table"], seeds["table"], FILTERS + ("SIS",), sim=sims[w], executor=executor)
    for w in (1, 2):
        step(f"Figs. {2 * w - 1}-{2 * w}, {MODEL_LABELS[w].lower()} ({counts['figures']} runs)")
        figs[w] = run(w, counts["figures"], seeds["figures"], ("EKF", "PF", "Exact"), executor=executor)
    step("grid convergence")
    conv = grid_convergence(sims)
    if runs is None:
        # the SIS readings' runs: the power plan of the degeneracy claims, from the spread of their main
        # reading (the Table 1 runs, already run), fixed before any reading runs
        from ..verdicts.ekf_pf_li2012 import sis_plan

        counts["sis"] = min(counts["table"], max(SIS_RUNS, sis_plan(res)))
    step("sensitivity: priors, resampling schemes, EKF linearisation, SIS")
    sens = sensitivity(sims, seeds["table"], sis_runs=counts["sis"], executor=executor)
    step("EKF means over independent seed sets")
    spread = ekf_seed_spread(spread_seeds(seeds), runs=counts["spread"], executor=executor)
    step("cost counts")
    cnt = {w: cost_count_table(w, sims[w], include=FILTERS, seed=seeds["table"]) for w in (1, 2)}
    few = min(SIS_RUNS, counts["table"]) if runs is None else counts["sis"]
    step("statements of secs 0-2: truncation (l.181), KF (l.35), proposals (l.137, l.145), N (l.135)")
    trunc = truncation_check(res[1], 1)
    kf = kf_linear_check(counts["table"], seeds["table"] + 19, executor=executor)
    prop = {w: proposal_check(w, sims[w], seeds["table"], counts["table"]) for w in (1, 2)}
    degen_n = degeneracy_vs_n(1, sims[1], seeds["table"], few, executor=executor)
    return Li2012Results(runs={**counts, "checks": few}, seeds=seeds, sims=sims, res=res, figs=figs, sens=sens,
                         deg={w: degeneracy(res[w]) for w in (1, 2)}, spread=spread, cnt=cnt, grid_conv=conv,
                         trunc=trunc, kf=kf, prop=prop, degen_n=degen_n)


# --------------------------------------------------------------------------------------
# the statements of secs 0-2 that Table 1 does not test (issue 31: l.35, l.135, l.137, l.145, l.181)
# --------------------------------------------------------------------------------------


def linear_model(P0: float = P0_DEFAULT):
    """The linear-Gaussian counterpart of the paper's models for l.35: x_k = x_{k-1}/2 + w_k,
    y_k = x_k + v_k, Q = 10, R = 1, x_0 = 0.1, filters from N(0.1, P0) (our choice: the paper's
    noise levels and start, its models with the nonlinear terms removed)."""
    from ..models.linear import LinearGaussianModel

    return LinearGaussianModel(F=[[0.5]], H=[[1.0]], Q=[[10.0]], R=[[1.0]], x0=[0.1], m0=[0.1], P0=[[P0]])


def kf_linear_check(runs: int, seed: int, n_values=KF_CHECK_N, executor=None) -> dict:
    """l.35, "for linear-Gaussian models the Kalman filter gives the optimal solution", on
    :func:`linear_model`: the KF against the exact (grid) posterior mean and the bootstrap PF at each
    N of ``n_values``, on the same ``runs`` runs (seed ``seed``).

    Returns ``{"max_dev": max |x_KF - x_exact| / sqrt(P_exact) over runs and steps, "mse": {name:
    per-run MSE}}`` (names ``KF``, ``Exact``, ``PF N=<n>``)."""
    from ..filters import KalmanFilter

    model = linear_model()
    sim = model.simulate(T, runs, truth_streams(seed, runs))
    filters = {"KF": KalmanFilter(model), "Exact": GridFilter(model, bounds=(-40.0, 40.0), n_grid=1601)}
    filters.update({f"PF N={n}": BootstrapParticleFilter(model, n, resampling=RESAMPLING_DEFAULT) for n in n_values})
    res = run_monte_carlo(model, filters, T, runs, seed, sim=sim, executor=executor)
    ex = res.results["Exact"]
    dev = np.abs(res.results["KF"].x - ex.x)[..., 0] / np.sqrt(ex.P[..., 0, 0])
    return {"max_dev": float(dev.max()), "mse": {n: res.mse(n) for n in filters}, "runs": runs}


def _gh(n: int = GH_NODES):
    z, w = np.polynomial.hermite_e.hermegauss(n)
    return z, w / w.sum()


def gaussian_adf(model, y) -> np.ndarray:
    """The Gaussian filter *without* first-order truncation (l.181): the posterior is still carried as
    a Gaussian N(m, P), but its moments are exact -- the predictive mean and variance of f(x) + w under
    N(m, P) by Gauss-Hermite quadrature, the update's by quadrature of N(m-, P-) p(y_k | x) on a grid of
    ``ADF_GRID`` nodes over m- +- 10 sd. The EKF differs from it only by the Taylor truncation of
    eqs (8)-(10); the exact grid posterior differs from it only by the Gaussian form. Scalar models;
    ``y`` (runs, T, 1) -> estimates (runs, T)."""
    y = np.asarray(y, float)
    runs, Tn, _ = y.shape
    z, wz = _gh()
    Q, Rm = float(model.Q[0, 0]), float(model.R[0, 0])
    m = np.full(runs, float(model.m0[0]))
    P = np.full(runs, float(model.P0[0, 0]))
    u = np.linspace(-10.0, 10.0, ADF_GRID)
    out = np.empty((runs, Tn))
    for k in range(1, Tn + 1):
        xs = m[:, None] + np.sqrt(P)[:, None] * z[None, :]
        fx = model.f(xs[..., None], k)[..., 0]
        mp = fx @ wz
        Pp = ((fx - mp[:, None]) ** 2) @ wz + Q
        g = mp[:, None] + np.sqrt(Pp)[:, None] * u[None, :]
        # additive Gaussian measurement noise (both models): log p(y_k | x) up to a constant
        logp = -0.5 * u[None, :] ** 2 - 0.5 * (y[:, k - 1, :] - model.h(g[..., None])[..., 0]) ** 2 / Rm
        logp -= logp.max(axis=1, keepdims=True)
        w = np.exp(logp)
        w /= w.sum(axis=1, keepdims=True)
        m = (w * g).sum(axis=1)
        P = np.maximum((w * (g - m[:, None]) ** 2).sum(axis=1), 1e-12)
        out[:, k - 1] = m
    return out


def truncation_check(res: MonteCarloResult, which: int = 1) -> dict:
    """Per-run RMSE of the EKF, the no-truncation Gaussian filter (:func:`gaussian_adf`) and the exact
    posterior mean on the runs of ``res`` (model 1's Table 1 runs): how much of the EKF's excess error
    over the exact posterior the first-order truncation accounts for (l.181)."""
    adf = gaussian_adf(make_model(which), res.sim.y)
    r_adf = np.sqrt(((adf - res.x_true[..., 0]) ** 2).mean(axis=1))
    return {"EKF": res.rmse("EKF"), "Gaussian, exact moments": r_adf, "Exact": res.rmse("Exact"),
            "UKF": res.rmse("UKF")}


def proposal_check(which: int, sim: Simulation, seed: int, runs: int, n_particles: int = N_PARTICLES) -> dict:
    """l.137 and l.145 on the first ``runs`` runs of ``sim``: a bootstrap PF (prior proposal, eq 15,
    multinomial resampling every step, its own stream ``seed``) that records, at each step and for its
    resampled particles x_{k-1}^i,

    * the ESS of its own weights p(y_k | x_k^i) (the prior proposal, which ignores y_k) and the ESS the
      optimal proposal p(x_k | x_{k-1}^i, y_k) would give on the same particles (its weights are
      p(y_k | x_{k-1}^i), by Gauss-Hermite quadrature over w_k), both as a per-run mean over k;
    * whether the optimal proposal is bimodal: p(x | x_{k-1}, y) ∝ exp(-(x - mu)^2/2Q - (y - x^2/20)^2/2R)
      has two maxima iff the cubic g'(x) = 0 has three real roots (negative discriminant test).

    Returns per-run arrays ``ess_prior``, ``ess_opt``, ``bimodal_share`` (share of particle-steps).
    """
    model = make_model(which)
    rng = np.random.default_rng([int(seed), 31, int(which)])
    N, Q, R, a_h = n_particles, float(model.Q[0, 0]), float(model.R[0, 0]), float(model.obs_coeff)
    y = sim.y[:runs, :, 0]
    z, wz = _gh()
    x = float(model.m0[0]) + math.sqrt(float(model.P0[0, 0])) * rng.standard_normal((runs, N))
    ess_p, ess_o, bim = np.zeros(runs), np.zeros(runs), np.zeros(runs)

    def ess(logw):
        w = np.exp(logw - logw.max(axis=1, keepdims=True))
        return w.sum(axis=1) ** 2 / (w * w).sum(axis=1)

    for k in range(1, T + 1):
        mu = model.f(x[..., None], k)[..., 0]
        yk = y[:, k - 1][:, None]
        # optimal proposal's weight p(y_k | x_{k-1}) = E_w N(y_k; h(mu + w), R)
        xs = mu[..., None] + math.sqrt(Q) * z
        ll = -0.5 * (yk[..., None] - a_h * xs * xs) ** 2 / R
        lmax = ll.max(axis=-1)
        lopt = lmax + np.log(np.exp(ll - lmax[..., None]) @ wz)
        ess_o += ess(lopt)
        # bimodality: -g'(x) Q = c3 x^3 + c1 x + c0 with c3 = 2 a^2 Q / R, c1 = 1 - 2 a y Q / R, c0 = -mu
        c3, c1, c0 = 2 * a_h * a_h * Q / R, 1.0 - 2 * a_h * yk * Q / R, -mu
        bim += (-4 * c3 * c1 ** 3 - 27 * c3 * c3 * c0 ** 2 > 0).mean(axis=1)
        # the bootstrap step: propagate by the prior, weight by the likelihood, resample (multinomial)
        x = mu + math.sqrt(Q) * rng.standard_normal((runs, N))
        lw = -0.5 * (yk - a_h * x * x) ** 2 / R
        ess_p += ess(lw)
        w = np.exp(lw - lw.max(axis=1, keepdims=True))
        c = np.cumsum(w, axis=1)
        c /= c[:, -1:]
        idx = np.minimum(np.stack([np.searchsorted(c[r], rng.random(N)) for r in range(runs)]), N - 1)
        x = np.take_along_axis(x, idx, axis=1)
    return {"ess_prior": ess_p / T, "ess_opt": ess_o / T, "bimodal_share": bim / T, "runs": runs}


def degeneracy_vs_n(which: int, sim: Simulation, seed: int, runs: int, n_values=DEGEN_N, executor=None) -> dict:
    """l.135, "increasing N reduces the degeneracy, at a computational cost": SIS (eq 16 without
    resampling) at each N of ``n_values`` on the first ``runs`` runs of ``sim`` (its own stream per N),
    and the bootstrap PF's cost per step in model evaluations (deterministic count).

    Returns ``{N: {"late": per-run ESS averaged over ESS_WINDOW, "late_frac": the same / N,
    "evals": model evaluations per step}}``."""
    from ..cost import cost_counts

    model = make_model(which)
    sub = Simulation(sim.x[:runs], sim.y[:runs])
    out = {}
    for n in n_values:
        name = f"SIS N={n}"
        f = BootstrapParticleFilter(model, n, resampling=RESAMPLING_DEFAULT, ess_threshold=0.0)
        r = run_monte_carlo(model, {name: f}, T, runs, seed, sim=sub, executor=executor)
        late = late_ess(r, name)
        pf = BootstrapParticleFilter(model, n, resampling=RESAMPLING_DEFAULT)
        evals = float(cost_counts({"PF": pf}, sub.y[:1], rng_seed=seed)["model_evaluations"].iloc[0]) / T
        out[n] = {"late": late, "late_frac": late / n, "evals": evals}
    return out
