"""Hou & Yin (2008), dual particle filter: models, filters and settings of every experiment.

Every unstated setting is fixed here, before any run, with its reason and its status (``CHOICES``:
fixed by the paper, swept, or a reading run beside the main one);
the chapter ``book/50_dpf.md`` calls :func:`run_all` (through :meth:`pfrepro.papers.Paper.run`)
and plots. Seeds are picked once (:data:`SEEDS`) and travel as arguments: every function that
draws takes ``seed=None`` (the book's seed, looked up when it is called) and ``runs=None``.
The claims are decided in ``pfrepro.verdicts.dpf_hou2008``.

Randomness: the truth of run i comes from ``truth_streams(seed, runs)`` and filter ``name``'s
draws from ``filter_streams(seed, name, runs)`` (per-run streams keyed by name), so run i's
numbers do not depend on how many runs an experiment has, and every filter sees the same
truths (paired comparisons).
"""
from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..filters.dual_ekf import DualExtendedKalmanFilter
from ..filters.dual_pf import DualParticleFilter
from ..filters.liu_west import LiuWestFilter
from ..filters.theta_grid import ThetaGridReference
from ..models.reentry import FT, Reentry
from ..models.ungm_theta import UNGMTheta
from ..models.base import Simulation
from ..choices import DESIGN, FIXED, READING, SWEEP, FreeChoice, choices_table
from ..stats import CommonRunsError, paired_difference, plan_runs
from ..montecarlo import run_monte_carlo, truth_streams

__all__ = ["PAPER", "SEEDS", "SEED_51", "SEED_52", "Run", "Hou2008Results", "run_all", "scaled_settings", "STEPS",
           "RUN_COUNTS", "S51", "S52", "Q52", "CHOICES", "PILOT", "PLANS", "plan_rows", "assumptions_table", "model_51",
           "model_52", "simulate_51", "simulate_52", "dpf_51", "dekf_51", "liu_west_51", "grid_51",
           "run_51", "run_51_range", "dekf_start_52", "run_fig5", "run_dpf_sensitivity", "run_dekf_sensitivity",
           "run_52", "run_52_readings", "run_51_theta", "run_51_extra", "rmse_eq14", "rmse_usual", "mean_se",
           "coverage", "crb_theta_52", "per_run", "paired", "rmse_51", "rmse_52", "lost_51", "lost_52",
           "errors_52", "table_52", "convergence_time", "first_runs", "merge"]

PAPER = "dpf_hou2008"
#: the book's seeds, picked once (the paper's year + section); never changed (``run_all(seeds=...)``
#: runs others without touching this dict)
SEEDS = {"sec51": 200851, "sec52": 200852}
#: the same seeds by name, for other modules (the "today" comparison, the synthesis)
SEED_51 = SEEDS["sec51"]
SEED_52 = SEEDS["sec52"]

#: The power plans -- the per-run spread of each claim's paired difference under its main reading,
#: measured in an earlier build of this chapter (100 runs in 5.1, 50 in 5.2, 30 in the 5.1 sweep; the
#: same seeds), and the size each plan resolves: the printed effect where the paper
#: printed both sides, else the larger of the claim's stated margin (``pfrepro.verdicts.dpf_hou2008.MARGINS``)
#: and the pilot's own ``|difference|``. Fixed here before any reading runs; never updated from a later build.
#: ``claim: (sd per run, size, what the size is)``.
PILOT = {
    "s51_dpf_beats_dekf_x": (0.1104, 0.4489, "the printed relative effect 1 − 0.345/0.626"),
    "s51_dpf_beats_dekf_theta": (0.2992, 0.4632, "the printed relative effect 1 − 0.00314/0.00585"),
    "fig5_dpf_robust_to_guess": (0.1085, 0.1236, "the pilot's difference (> the margin 0.01)"),
    "no_parameter_impoverishment": (0.0706, 0.2231, "the pilot's difference (> the margin log 1.25)"),
    "cap_keeps_flexible": (0.5561, 0.10, "the margin 0.1 (pilot 0.033)"),
    "dpf_beats_liu_west_theta": (0.0410, 0.0127, "the pilot's |difference| (> the margin 0.01)"),
    "beta_sampling_efficiency": (3.473, 5.0, "the margin 5 draws (pilot 0.62)"),
    "beta_speeds_convergence": (25.75, 5.0, "the margin 5 steps (pilot 2.3)"),
    "s52_dpf_beats_dekf_alt": (4284.0, 1039.0, "the pilot's difference (> the margin 100 ft)"),
    "s52_dpf_beats_dekf_vel": (361.1, 218.3, "the pilot's difference (> the margin 100 ft/s)"),
    "s52_dpf_beats_dekf_th": (1.497e-4, 1e-4, "the margin 10⁻⁴ ft⁻¹ (pilot 0.99·10⁻⁴)"),
    "s52_dpf_beats_dekf_th_10_20": (2.562e-4, 1e-4, "the margin 10⁻⁴ ft⁻¹ (pilot 0.25·10⁻⁴)"),
    "s52_dpf_beats_dekf_alt_10_20": (2641.0, 1604.0, "the pilot's difference (> the margin 100 ft)"),
    "s52_dpf_beats_dekf_vel_10_20": (815.2, 551.8, "the pilot's difference (> the margin 100 ft/s)"),
    "dual_more_stable_than_joint": (0.4046, 0.86, "the pilot's |difference| (> the margin 0.1)"),
    "dpf_beats_liu_west_theta_reentry": (1.457e-4, 2.298e-4, "the pilot's |difference| (> the margin 10⁻⁴)"),
}
#: The runs each plan asks for (:func:`pfrepro.stats.plan_runs`, 80 % power at ``|z| > 2``)
PLANS = {k: plan_runs(sd, size) for k, (sd, size, _) in PILOT.items()}
#: what the budget pays: sec 5.1 main runs and its sweep/readings (the largest 5.1 plan, the cap's, capped by
#: nothing: 250), sec 5.2 main runs and every 5.2 reading (the largest 5.2 plan, the altitude's)
RUNS_51 = max(PLANS[k] for k in ("cap_keeps_flexible", "beta_speeds_convergence", "dpf_beats_liu_west_theta",
                                 "s51_dpf_beats_dekf_x", "s51_dpf_beats_dekf_theta", "fig5_dpf_robust_to_guess"))
RUNS_52 = max(PLANS[k] for k in PLANS if k.startswith(("s52", "dpf_beats_liu_west_theta_reentry", "dual_")))

#: Sec 5.1 settings
S51 = dict(
    T=100,              # horizon: not given; the classic UNGM horizon of Kitagawa (ref [17]) and most PF studies
    runs=RUNS_51,       # paper: one run; our power plan (PLANS): the largest sec 5.1 plan
    bounds=(0.0, 1.0),  # [r_l, r_u]: not given; the unit interval of sec 3.2 (eq 6)
    theta_true=0.5,
    n_x=500, n_theta=500,
    cap=500.0,          # = n_theta: the Beta's pseudo-count may not exceed the draws it is fitted from
    theta0=0.5,         # the uniform prior's mean: DPF's θ̂_0 and DEKF's start (same prior information)
    sens_runs=RUNS_51,  # runs of the sweep and readings (weight, caps, resampling, range, Liu-West δ): the plan
    theta_runs=30,      # the true-θ rows (context: the paper excludes them, l.200, l.211)
    fig5_runs=100,      # Fig. 5's guesses: plan PLANS["fig5_dpf_robust_to_guess"] (a few runs); 100 for the figure
    caps=(50.0, 500.0, 5000.0, None),
    guesses=(0.2, 0.5, 0.7),
    lw_delta=0.99,      # Liu & West's discount factor, the upper end of their 0.95-0.99
    lw_n=500,           # 2 likelihoods per particle and step: 2 x 500 = 1000 = N_x + N_theta of the DPF
    grid_runs=40, grid_n_theta=81, grid_x_bounds=(-30.0, 30.0), grid_n_x=241,
    dekf_q_rel=1e-3, dekf_anneal=0.995, dekf_floor_rel=1e-6,
    dekf_q_rels=(0.0, 1e-4, 1e-3, 1e-2),
)

#: Sec 5.2 settings (feet internally)
S52 = dict(
    T=60,                 # 60 s of 1 s range samples, as in the classic problem (KalmTool)
    runs=RUNS_52,         # the paper's 50 (l.228) raised to the power plan (PLANS); Figs. 7-9 drawn on the first 50
    fig_runs=50,
    n_x=2000, n_theta=2000,
    cap=2000.0,           # = n_theta, the same rule as in 5.1
    theta0=3e-5,          # the classic filter start, far from θ = 1e-3
    P_theta0=1e-4,        # the classic initial variance of θ (DEKF)
    truth_substeps=64,    # truth: RK4 with 64 substeps per second
    filter_substeps=4,    # filters: 4 substeps (integration error ~0.01 ft over 60 s, 1e-4 of the noise sd; see the chapter)
    roughening=0.2,       # Gordon et al. (1993) roughening of the state PF: Q = 0 would collapse it
    literal_runs=10,
)

#: the two extra readings of the filters' process noise in 5.2 (ft², (ft/s)² per 1 s sample); the
#: truth is the classic noise-free trajectory under every reading (the printed variances on the
#: truth would move the body by ~5·10⁵ ft in 60 s: no re-entry left)
Q52 = {"0": None, "small": np.diag([1e2**2, 1e2**2]), "printed": np.diag([1e6, 4e6])}
S52.update(q_runs=RUNS_52,       # runs of each extra 5.2 reading (Q, weight, δ, K, resampling, DEKF start): the plan
           lw_deltas=(0.99, 0.95), roughenings=(0.2, 0.1),
           horizons=(60, 30),    # 30 s: the readings' horizon by truncating the 60 s runs (causal filters)
           lost_ft=1e3)          # lost: final altitude error > 10 measurement sd (100 ft)
S51.update(horizons=(100, 50),   # 50: Arulampalam et al.'s UNGM horizon (ref [11], whose eq (14) the paper cites)
           thetas=(0.5, 0.2, 0.7),  # true θ rows (0.2, 0.7: the paper's own guesses; context, excluded l.200, l.211)
           ranges=((0.0, 1.0), (-1.0, 1.0)),  # [r_l, r_u] of sec 5.1: main, and the reading [-1, 1]
           resamplings=("systematic", "multinomial"),
           lost_theta=0.1,       # lost: |θ̂_T − θ| > 0.1 (7 exact posterior sd at T)
           conv_band=0.05)       # convergence: |θ̂_k − θ| ≤ 0.05 from k on (Beta vs Gaussian)

CHOICES = [
    FreeChoice("T51", "100", READING,
               "Sec 5.1 gives no horizon. 100 (Kitagawa, ref [17]) is the main reading; 50 (Arulampalam et al., "
               "ref [11], whose eq (14) the paper cites) is run by truncating the 100-step runs (the filters are "
               "causal: bit-identical to 50-step runs). Every sec 5.1 claim is decided under both.",
               "Sec 5.1 (l.190-211): not stated"),
    FreeChoice("theta51", "0.5", FIXED,
               "The true θ of every sec 5.1 run: l.200 says the one simulation's results are Figs. 4 and 5, and l.211 "
               "gives Fig. 5's θ = 0.5. The rows θ = 0.2 and 0.7 (the paper's initial guesses, l.211, not true values) "
               "are run on 30 runs and shown as context, not counted (under θ = 0.2 the printed DPF θ RMSE 0.00314 also "
               "lies outside our single runs).", "l.200, l.211"),
    FreeChoice("range51", "[0, 1]", DESIGN,
               "[r_l, r_u] of sec 5.1 is not printed (sec 3.2, l.103 and l.117, only says a range is mapped onto "
               "[0, 1]). [0, 1] (stable, positive AR coefficient, holding the classic 0.5) is our choice; [-1, 1] (every "
               "stable AR coefficient) is run as a reading for the DPF and the DEKF (each starts at its prior's mean and "
               "variance) and the four sec 5.1 numbers and the two Fig. 4 orderings are decided under both.",
               "Sec 5.1: not stated (l.103, l.117)"),
    FreeChoice("ungm", "v, w ~ N(0, 1); x_0 ~ N(0, 5) (5 a variance); forcing 8 cos(1.2k)", FIXED,
               "as printed (the text defines N(μ, σ²))", "Eqs (12)-(13), l.194-198"),
    FreeChoice("particles", "N_x = N_θ = 500 (5.1), 2000 (5.2)", FIXED, "as printed", "l.200 (5.1), l.226 (5.2)"),
    FreeChoice("runs51", f"{RUNS_51} runs (sweep and readings too); exact reference on 40", DESIGN,
               "The paper prints one run (l.205-209, '单次实验'); our runs give the distribution of single runs its "
               "numbers are compared with, and the count is the largest sec 5.1 power plan (rows plan_*).",
               "l.205-209 (one run)"),
    FreeChoice("runs52", f"{RUNS_52} runs (every reading too); Figs. 7-9 drawn on the first 50", DESIGN,
               "The paper's 50 runs (l.228) raised to the largest sec 5.2 power plan (rows plan_*); the figures keep the "
               "paper's 50.", "l.228 (50 runs)"),
    FreeChoice("prior", "α_0 = β_0 = 1 (uniform on [r_l, r_u])", FIXED, "as printed", "l.152, l.184"),
    FreeChoice("weight", "predictive: N(z_k; h(f(x̂_{k-1}, θ)), H P⁻ Hᵀ + R)", READING,
               "Eq (11) is read three ways: the predictive density of its second line (main), the plug-in of its "
               "third line (variance R only; run in both sections on every run) and the literal p(z_k | θ, x̂_k) of its "
               "last line and step 3(b), which is the same for every θ (the filter learns nothing, contradicting "
               "Figs. 4, 5 and 9; shown in the sweep table, not a reading).",
               "Eq (11), l.139; step 3(b), l.174"),
    FreeChoice("theta0", "prior mean 0.5 (5.1); 3·10⁻⁵ (5.2)", SWEEP,
               "The Beta starts uniform whatever the guess; the guess enters only as θ̂_0 of the state filter at "
               "k = 1. Swept over the paper's guesses 0.2 / 0.5 / 0.7 in Fig. 5 (l.211); 5.2 uses the classic start.",
               "l.211 (Fig. 5)"),
    FreeChoice("cap", "max(α, β) ≤ N_θ, mean kept", SWEEP,
               "The paper caps α, β without a value (l.244). N_θ: a pseudo-count above the number of draws claims more "
               "precision than they carry. Swept over 50, 500, 5000 (sec 5.1, every run): the sec 5.1 DPF claims are "
               "decided at every finite cap; no cap contradicts the paper's own capping (l.244): shown, not counted. "
               "Not varied in 5.2 (cap 2000 = N_θ).", "l.244"),
    FreeChoice("guards", "ν = α + β floored at 2 when σ² ≥ μ(1 − μ); capped when σ² = 0", DESIGN,
               "Eq (7) has no solution there, so any value is ours; the floor is the uniform prior's ν. It binds in "
               "under 1 % of the steps (the sweep table's 'guards' column); no claim is declared on it (there is no "
               "paper's value to read).", "Eq (7), l.111: no guard"),
    FreeChoice("step3d", "σ² = Σ w (θ − θ̂)²", FIXED,
               "l.109 and l.113 call σ_θ² the variance that eq (7) inverts; the printed extra factor θ^i (l.178) is a "
               "misprint (errata)", "l.109, l.113, l.178"),
    FreeChoice("resampling", "systematic", DESIGN,
               "Step 2(e) (l.168) resamples at every step (as printed) but names no scheme: systematic is our choice "
               "(the book's default); multinomial is run as a reading for the DPF in both sections, and every DPF "
               "ordering is decided under both.", "l.168: scheme not named"),
    FreeChoice("dekf", "Q^θ_k = max(10⁻³ P_θ0 · 0.995^k, 10⁻⁶ P_θ0), θ̂ projected on [r_l, r_u]", SWEEP,
               "DEKF tuning is not given (ReBEL-style annealing, fixed before any run). Swept: q_0 = 0, 10⁻⁴, 10⁻³, "
               "10⁻² P_θ0 and unprojected, every run; the sec 5.1 DPF-vs-DEKF claims are decided at every value. "
               "5.1 start θ̂_0 = 0.5, P_θ0 = 1/12 (the uniform prior's moments); the parameter 'measurement' noise "
               "is the innovation covariance S (prediction-error form).", "l.188 (DEKF, ref [10]): no tuning"),
    FreeChoice("liu_west", "δ = 0.99, auxiliary form; N = 500 (5.1), 2000 (5.2); θ_0 ~ U[r_l, r_u]", READING,
               "Not the paper's filter (our baseline): 2N likelihoods per step = the DPF's N_x + N_θ. δ = 0.99 (main), "
               "the upper end of Liu & West's 0.95-0.99; δ = 0.95, the lower end, is run on every run of both "
               "sections and the Liu-West claims are decided under both.", "l.39 (ref [8])"),
    FreeChoice("exact", "81 θ nodes × 241 x nodes on [-30, 30], first 40 runs", DESIGN,
               "Our reference, not the paper's: grid error is checked against a fine grid in the tests (lost mass "
               "shown); its cost limits it to 40 runs, and every comparison with it uses those 40 runs.", ""),
    FreeChoice("units52", "feet; drag −θ x2² exp(−γ x1) (Athans et al. 1968)", READING,
               "The paper prints a metric state with foot constants and drag ∝ x₂ (l.218-226); its own text says the "
               "body decelerates sharply in 10-20 s (l.242). Under the literal reading it hits the ground at 6 km/s "
               "(Fig. 6 below), so the literal reading (run on 10 runs) is shown as context, not counted, in every "
               "sec 5.2 claim.", "l.218-226, l.242"),
    FreeChoice("Q52", "0: the printed 10⁶, 4·10⁶ are the initial covariance P_0", READING,
               "Eqs (15)-(16) print 10⁶, 4·10⁶ as process noise (l.226); the classic problem has them as P_0 and no "
               "process noise (main). Readings run (filters only, every run): Q = diag(10⁴, 10⁴) ('small': 100 ft and "
               "100 ft/s per s) and Q = diag(10⁶, 4·10⁶) ('printed'). Every sec 5.2 claim is decided under all three.",
               "l.226"),
    FreeChoice("horizon52", "60 s, 1 s sampling", READING,
               "The horizon is not printed (Figs. 7-9 are missing; l.218 gives the 1 s sampling): 60 s is the classic "
               "problem's (main); 30 s is run by truncating the 60 s runs.", "l.218"),
    FreeChoice("start52", "truth x_0 = (3·10⁵ ft, 2·10⁴ ft/s)", FIXED,
               "l.226 prints 91.5 km and 6.1 km/s, the classic problem's 3·10⁵ ft and 2·10⁴ ft/s (units: row units52)",
               "l.226"),
    FreeChoice("truth52", "true θ = 10⁻³ ft⁻¹, noise-free trajectory", DESIGN,
               "Not printed (l.226 gives only the range [0, 2·10⁻³]); the classic problem's value (ref [19], l.218), the "
               "middle of the printed range. Not varied: a second truth is another experiment, and no reading of the "
               "text offers one.", "l.226: range only"),
    FreeChoice("dekf52", "θ̂_0 = 3·10⁻⁵, P_θ0 = 10⁻⁴, Q^θ = 0 (the classic filter start)", DESIGN,
               "Not printed (the paper gives no DEKF settings, l.226-228). The classic start is our main choice; the "
               "DEKF started from the DPF's own prior (θ̂_0 = 10⁻³, P_θ0 = (2·10⁻³)²/12, the uniform's moments) is run "
               "as a reading on every run, and every sec 5.2 DPF-vs-DEKF claim is decided under both.",
               "l.226-228: not stated"),
    FreeChoice("integration", "RK4, 64 substeps (truth), 4 (filters)", SWEEP,
               "Swept in the integration-error table (2 ... 64 substeps): 4 substeps err by ~0.01 ft, 10⁻⁴ of the "
               "measurement sd; no claim can move.", ""),
    FreeChoice("roughening", "K = 0.2 (Gordon et al. 1993), 5.2 state PF", READING,
               "The paper is silent; with Q = 0 a bootstrap PF collapses to one particle. K = 0.2 (main); K = 0.1 is "
               "run for the DPF (every run) and the sec 5.2 DPF claims are decided under both.", "l.226: not stated"),
]


def plan_rows() -> list:
    """The power plans as assumptions-table rows (status design choice): one per claim of :data:`PILOT`."""
    return [FreeChoice(f"plan_{k}", f"{PLANS[k]} runs per reading; run: {RUNS_52 if k.startswith(('s52', 'dpf_beats_liu_west_theta_', 'dual_')) else RUNS_51}",
                       DESIGN, f"80 % power at |z| > 2 for {why}, at the main reading's per-run sd {sd:.4g} (pilot: an "
                               f"earlier build of this chapter, same seeds)", "")
            for k, (sd, size, why) in PILOT.items()]


CHOICES = CHOICES + plan_rows()


def assumptions_table() -> pd.DataFrame:
    """The chapter's assumptions table (:func:`pfrepro.choices.choices_table` of ``CHOICES``)."""
    return choices_table(CHOICES)


# --------------------------------------------------------------------------- metrics
def rmse_eq14(err):
    """Eq (14) per run: (1/N) sqrt(Σ_k e_k²) over the time axis (axis 1)."""
    err = np.asarray(err, float)
    return np.sqrt(np.sum(err**2, axis=1)) / err.shape[1]


def rmse_usual(err):
    """Usual RMSE per run: sqrt(mean_k e_k²)."""
    err = np.asarray(err, float)
    return np.sqrt(np.mean(err**2, axis=1))


def mean_se(v):
    """Mean and its standard error (NaN for a single run, which has no spread to estimate)."""
    v = np.asarray(v, float)
    se = float(v.std(ddof=1) / np.sqrt(v.size)) if v.size > 1 else float("nan")
    return float(v.mean()), se


def coverage(lo, hi, truth):
    """Indicator per run (and time) that [lo, hi] contains ``truth``."""
    return (np.asarray(lo) <= truth) & (truth <= np.asarray(hi))


# --------------------------------------------------------------------------- 5.1
def model_51(theta_true=None, bounds=None) -> UNGMTheta:
    """The sec 5.1 model (eqs 12-13) with true θ ``theta_true`` (default 0.5) and prior range ``bounds``
    (default [0, 1], the main reading; the range does not change the simulated truth)."""
    return UNGMTheta(theta_true=S51["theta_true"] if theta_true is None else theta_true,
                     bounds=S51["bounds"] if bounds is None else tuple(bounds))


def _seed(section: str, seed=None) -> int:
    """``seed``, or the book's seed of ``section`` ("sec51", "sec52"), looked up when called."""
    return SEEDS[section] if seed is None else int(seed)


def simulate_51(runs=None, theta_true=None, seed=None):
    """Run i's truth of sec 5.1 from ``truth_streams(seed)``'s stream i (first ``runs`` runs; the
    book's seed ``SEEDS["sec51"]`` by default)."""
    runs = S51["runs"] if runs is None else runs
    return model_51(theta_true).simulate(S51["T"], runs, truth_streams(_seed("sec51", seed), runs))


def dpf_51(model=None, **over):
    """The sec 5.1 DPF (N_x = N_θ = 500, cap N_θ, θ̂_0 = 0.5); ``over`` replaces any setting."""
    kw = dict(n_x=S51["n_x"], n_theta=S51["n_theta"], cap=S51["cap"], theta0=S51["theta0"])
    kw.update(over)
    return DualParticleFilter(model or model_51(), **kw)


def dekf_51(model=None, theta0=None, q_rel=None, clip=True):
    """The sec 5.1 DEKF: P_θ0 = the uniform prior's variance on the model's range, annealed parameter noise
    q_rel·P_θ0; start ``theta0`` (default 0.5 on the main range, the range's midpoint on another)."""
    lo, hi = (model.bounds if model is not None else S51["bounds"])
    P0 = (hi - lo) ** 2 / 12.0
    if theta0 is None and (lo, hi) != tuple(S51["bounds"]):
        theta0 = 0.5 * (lo + hi)
    q_rel = S51["dekf_q_rel"] if q_rel is None else q_rel
    return DualExtendedKalmanFilter(model or model_51(), S51["theta0"] if theta0 is None else theta0, P0,
                                    q0=q_rel * P0, anneal=S51["dekf_anneal"],
                                    q_min=S51["dekf_floor_rel"] * P0 * (q_rel > 0), clip_to_bounds=clip)


def liu_west_51(model=None, delta=None):
    """Liu & West's joint filter at the DPF's likelihood count (2 × 500 = 500 + 500)."""
    return LiuWestFilter(model or model_51(), S51["lw_n"], delta=S51["lw_delta"] if delta is None else delta)


def grid_51(model=None):
    """The exact θ posterior of sec 5.1 (θ grid × point-mass filter over x)."""
    return ThetaGridReference(model or model_51(), n_theta=S51["grid_n_theta"], x_bounds=S51["grid_x_bounds"],
                              n_grid=S51["grid_n_x"])


@dataclass
class Run:
    """Truth plus each filter's result and wall time (context only)."""

    sim: object
    results: dict
    seconds: dict = field(default_factory=dict)
    filters: dict = field(default_factory=dict)


def _run(filters: dict, sim, seed, executor=None, runs_of: dict | None = None) -> Run:
    """Run every filter on the same truths through :func:`pfrepro.montecarlo.run_monte_carlo`.

    Filter ``name``'s run i draws from ``filter_streams(seed, name)``'s stream i, so the numbers
    do not depend on ``executor`` (None: one batched call per filter; or any
    ``concurrent.futures.Executor``, the runs then split into chunks). ``runs_of[name]`` restricts
    a filter to the first runs (the exact reference). ``seconds`` is wall time, context only.
    """
    runs_of = runs_of or {}
    res, sec = {}, {}
    groups = {}
    for name, f in filters.items():
        groups.setdefault(runs_of.get(name, sim.y.shape[0]), {})[name] = f
    for n, group in groups.items():
        sub = sim if n == sim.y.shape[0] else Simulation(sim.x[:n], sim.y[:n])
        mc = run_monte_carlo(None, group, sub.T, n, seed, executor=executor, progress=False, sim=sub)
        res.update(mc.results)
        sec.update(mc.batch_seconds)
    return Run(sim=sim, results={k: res[k] for k in filters}, seconds=sec, filters=filters)


def run_51(executor=None, runs=None, grid_runs=None, seed=None) -> Run:
    """Sec 5.1 at paper scale: DPF, DEKF, Liu-West (equal likelihood count) and the exact θ posterior
    (on the first ``grid_runs`` runs, at most ``runs``)."""
    runs = S51["runs"] if runs is None else runs
    grid_runs = min(S51["grid_runs"] if grid_runs is None else grid_runs, runs)
    m = model_51()
    sim = simulate_51(runs, seed=seed)
    filters = {"DPF": dpf_51(m), "DEKF": dekf_51(m), "Liu-West": liu_west_51(m), "exact": grid_51(m)}
    return _run(filters, sim, _seed("sec51", seed), executor, runs_of={"exact": grid_runs})


def run_fig5(main: Run | None = None, executor=None, runs=None, seed=None) -> dict:
    """Fig. 5: DPF and DEKF with initial guesses 0.2 / 0.5 / 0.7 on all runs, with the same truths and
    the same filter streams for every guess (common random numbers). ``main`` (a :func:`run_51`
    result, whose guess is 0.5, run with the same ``seed``) is reused for 0.5 and gives the truths:
    it is the same computation. Returns {guess: Run}."""
    m = model_51()
    if main is not None:
        n = min(S51["fig5_runs"] if runs is None else runs, main.sim.y.shape[0])
        main = first_runs(main, n, ("DPF", "DEKF"))
    sim = simulate_51(S51["fig5_runs"] if runs is None else runs, seed=seed) if main is None else main.sim
    out = {}
    for g0 in S51["guesses"]:
        if main is not None and g0 == S51["theta0"]:
            out[g0] = main
        else:
            out[g0] = _run({"DPF": dpf_51(m, theta0=g0), "DEKF": dekf_51(m, theta0=g0)}, sim,
                           _seed("sec51", seed), executor)
    return out


def run_dpf_sensitivity(executor=None, runs=None, seed=None, main: Run | None = None) -> Run:
    """One sweep on the first ``runs`` (default ``sens_runs``) runs: the three readings of the parameter
    weight (cap N_θ), the Beta caps (predictive weight) and multinomial resampling (the reading
    ``resampling``). "DPF" is the working setting: taken from ``main`` (a :func:`run_51` result with the
    same seed: the same stream, the same numbers) when given, else run; every variant uses its own
    named stream."""
    m = model_51()
    n = S51["sens_runs"] if runs is None else runs
    sim = simulate_51(n, seed=seed)
    filters = {"plugin weight": dpf_51(m, weight="plugin"), "literal weight": dpf_51(m, weight="literal")}
    for c in S51["caps"]:
        if c != S51["cap"]:
            filters[f"cap {c:g}" if c else "no cap"] = dpf_51(m, cap=c)
    filters["multinomial resampling"] = dpf_51(m, resampling="multinomial")
    if main is None:
        filters = {"DPF": dpf_51(m), **filters}
        return _run(filters, sim, _seed("sec51", seed), executor)
    return merge(first_runs(main, n, ("DPF",)), _run(filters, sim, _seed("sec51", seed), executor))


def run_dekf_sensitivity(executor=None, runs=None, seed=None) -> Run:
    """The DEKF's parameter noise q_0 (0, 10⁻⁴, 10⁻³, 10⁻² P_θ0) and the unprojected DEKF, on all runs."""
    m = model_51()
    sim = simulate_51(runs, seed=seed)
    filters = {f"q0 = {q:g} P0": dekf_51(m, q_rel=q) for q in S51["dekf_q_rels"]}
    filters["unprojected"] = dekf_51(m, clip=False)
    return _run(filters, sim, _seed("sec51", seed), executor)


def run_51_theta(theta_true, executor=None, runs=None, seed=None) -> Run:
    """The true-θ rows (context: the paper fixes θ = 0.5, l.200, l.211): DPF and DEKF on the first ``runs``
    (default ``theta_runs``) runs with true θ = ``theta_true`` (same seeds and stream names as the main runs)."""
    m = model_51(theta_true)
    sim = simulate_51(S51["theta_runs"] if runs is None else runs, theta_true, seed=seed)
    return _run({"DPF": dpf_51(m), "DEKF": dekf_51(m)}, sim, _seed("sec51", seed), executor)


def run_51_range(bounds, executor=None, runs=None, seed=None) -> Run:
    """The reading ``range51``: DPF and DEKF with the prior range ``bounds`` (each started from that
    uniform prior's mean and variance) on the first ``runs`` (default ``sens_runs``) main truths, under
    the main runs' stream names (common random numbers)."""
    m = model_51(bounds=bounds)
    sim = simulate_51(S51["sens_runs"] if runs is None else runs, seed=seed)
    return _run({"DPF": dpf_51(m, theta0=0.5 * (bounds[0] + bounds[1])), "DEKF": dekf_51(m)}, sim,
                _seed("sec51", seed), executor)


def run_51_extra(executor=None, runs=None, lw_runs=None, seed=None) -> Run:
    """Sec 5.1 comparisons beyond the main set, on the main truths: the DPF with a Gaussian parameter law
    (sec 3.2, Fig. 2; all ``runs`` runs, equal N) and Liu-West at δ = 0.95 (the reading ``liu_west``,
    first ``lw_runs`` runs, default ``sens_runs``, at most ``runs``). Own stream names."""
    m = model_51()
    sim = simulate_51(runs, seed=seed)
    lw_runs = min(S51["sens_runs"] if lw_runs is None else lw_runs, sim.y.shape[0])
    return _run({"DPF Gaussian θ": dpf_51(m, theta_law="gaussian"),
                 "Liu-West δ=0.95": liu_west_51(m, delta=S52["lw_deltas"][1])},
                sim, _seed("sec51", seed), executor, runs_of={"Liu-West δ=0.95": lw_runs})


# --------------------------------------------------------------------------- 5.2
def model_52(reading="feet", substeps=None, Q=None) -> Reentry:
    """The re-entry model in ``reading``; ``Q``: the filters' process noise (a key of :data:`Q52` or a matrix)."""
    if isinstance(Q, str):
        Q = Q52[Q]
    return Reentry(reading=reading, n_substeps=S52["filter_substeps"] if substeps is None else substeps, Q=Q)


def simulate_52(runs=None, reading="feet", seed=None):
    """Run i's noise-free re-entry truth (64 RK4 substeps) and its range measurements, from
    ``truth_streams(seed)`` (the book's ``SEEDS["sec52"]`` by default)."""
    runs = S52["runs"] if runs is None else runs
    return model_52(reading, S52["truth_substeps"]).simulate(S52["T"], runs,
                                                            truth_streams(_seed("sec52", seed), runs))


def run_52(reading="feet", runs=None, executor=None, Q=None, names=("DPF", "DEKF", "Liu-West"),
           weight="predictive", delta=None, roughening=None, seed=None, resampling="systematic",
           dekf_start="classic") -> Run:
    """Sec 5.2: DPF (2000 + 2000 particles), DEKF and Liu-West (2000 joint particles) on the re-entry problem.

    The truth is always the classic noise-free trajectory (``simulate_52``); ``Q`` (a key of
    :data:`Q52` or a matrix) is the filters' process noise (the reading ``Q52``); ``weight``,
    ``delta`` (Liu-West) and ``roughening`` (DPF) give the other readings. ``names`` picks the
    filters (stream names are the same under every reading: common random numbers).
    """
    runs = (S52["runs"] if reading == "feet" else S52["literal_runs"]) if runs is None else runs
    m = model_52(reading, Q=Q)
    sim = simulate_52(runs, reading, seed=seed)
    make = {
        "DPF": lambda: DualParticleFilter(m, S52["n_x"], S52["n_theta"], cap=S52["cap"], theta0=S52["theta0"],
                                          roughening=S52["roughening"] if roughening is None else roughening,
                                          weight=weight, resampling=resampling),
        "DEKF": lambda: DualExtendedKalmanFilter(m, *dekf_start_52(m, dekf_start), clip_to_bounds=True),
        # joint (not dual) reference at the DPF's likelihood count: 2 x 2000 = 2000 + 2000
        "Liu-West": lambda: LiuWestFilter(m, S52["n_x"], delta=S51["lw_delta"] if delta is None else delta),
    }
    return _run({n: make[n]() for n in names}, sim, _seed("sec52", seed), executor)


def dekf_start_52(model, start="classic"):
    """``(θ̂_0, P_θ0)`` of the sec 5.2 DEKF: "classic" (3·10⁻⁵, 10⁻⁴; row ``dekf52``) or "prior" (the
    uniform prior's mean and variance on the model's range)."""
    if start == "classic":
        return S52["theta0"], S52["P_theta0"]
    if start == "prior":
        lo, hi = model.bounds
        return 0.5 * (lo + hi), (hi - lo) ** 2 / 12.0
    raise ValueError(f"dekf_start must be 'classic' or 'prior', got {start!r}")


def run_52_readings(executor=None, runs=None, seed=None) -> dict:
    """Every extra reading of sec 5.2 on the first ``runs`` (default ``q_runs``) runs:
    ``{(choice, value): Run}`` for the filters' process noise (``Q52``: small, printed; all three
    filters), the plug-in weight and roughening K = 0.1 (DPF), Liu-West at δ = 0.95."""
    n = S52["q_runs"] if runs is None else runs
    out = {("Q52", q): run_52(runs=n, executor=executor, Q=q, seed=seed) for q in ("small", "printed")}
    out[("weight", "plugin")] = run_52(runs=n, executor=executor, names=("DPF",), weight="plugin", seed=seed)
    out[("roughening", S52["roughenings"][1])] = run_52(runs=n, executor=executor, names=("DPF",),
                                                        roughening=S52["roughenings"][1], seed=seed)
    out[("liu_west", S52["lw_deltas"][1])] = run_52(runs=n, executor=executor, names=("Liu-West",),
                                                    delta=S52["lw_deltas"][1], seed=seed)
    out[("resampling", "multinomial")] = run_52(runs=n, executor=executor, names=("DPF",), resampling="multinomial",
                                                seed=seed)
    out[("dekf52", "prior")] = run_52(runs=n, executor=executor, names=("DEKF",), dekf_start="prior", seed=seed)
    return out


def crb_theta_52(reading="feet", T=None):
    """Cramér–Rao bound sd of θ over time for the noise-free truth (θ, x_0 unknown; Fisher information
    from the sensitivities of the range to (x_0, θ), by the variational equations). Deterministic:
    computed once per process for the same settings (a copy is returned)."""
    T = S52["T"] if T is None else T
    return _crb_theta_52(reading, int(T), S52["truth_substeps"]).copy()


@functools.lru_cache(maxsize=8)
def _crb_theta_52(reading, T, substeps):
    m = model_52(reading, substeps)
    x = m.x0[None].copy()
    th = m.theta_true[None].copy()
    J = np.zeros((1, 2, 3))
    J[0, :, :2] = np.eye(2)
    Info = np.zeros((3, 3))
    # prior information on x_0 (P_0); none on θ
    Info[:2, :2] = np.linalg.inv(m.P0)
    sd = np.empty(T)
    for k in range(1, T + 1):
        x, Fx, Fth = m.f_and_jacobians(x, k, th)
        J = np.concatenate([Fx @ J[..., :2], Fx @ J[..., 2:] + Fth], axis=-1)
        Hs = m.jacobian_h(x) @ J                   # (1, 1, 3)
        Info += (Hs[0].T @ Hs[0]) / m.R[0, 0]
        sd[k - 1] = np.sqrt(np.linalg.pinv(Info)[2, 2])
    return sd


def to_metres(v, component):  # kept for callers outside the chapter (the chapter works in feet)
    """Feet -> metres for altitude (0) and velocity (1); θ (2) in 1/ft -> 1/m."""
    return v * FT if component in (0, 1) else v / FT



# --------------------------------------------------------------------------- summaries (tables of the chapter)
def theta_interval(run: Run, name: str):
    """(lo, median, hi) of each filter's own 95 % interval of θ: (3, runs, T)."""
    return run.filters[name].theta_quantiles(run.results[name], (0.025, 0.5, 0.975))


def errors_51(run: Run, name: str, runs=None):
    """State and θ errors (runs, T) of filter ``name`` (first ``runs`` runs)."""
    res = run.results[name]
    n = res.x.shape[0] if runs is None else runs
    ex = res.x[:n, :, 0] - run.sim.x[:n, 1:, 0]
    et = res.diagnostics["theta"][:n] - run.filters[name].model.theta_true[0]   # the run's own true θ
    return ex, et


def rmse_table_51(run: Run, names, runs=None) -> pd.DataFrame:
    """Per-run eq-(14) and usual RMSEs of x and θ, mean ± SE over runs, and the failures (:func:`lost_51`)."""
    rows = []
    for n in names:
        ex, et = errors_51(run, n, runs)
        row = {"filter": n, "runs": ex.shape[0], "failures": int(lost_51(run, n, ex.shape[0]).sum())}
        for lab, e in (("x", ex), ("θ", et)):
            for kind, fn in (("eq14", rmse_eq14), ("usual", rmse_usual)):
                m, se = mean_se(fn(e))
                row[f"{kind} {lab}"], row[f"{kind} {lab} se"] = m, se
        rows.append(row)
    return pd.DataFrame(rows).set_index("filter")


def coverage_table_51(run: Run, names, runs=None) -> pd.DataFrame:
    """Coverage of the true θ by each method's 95 % interval: at T, and averaged over k = 11..T."""
    rows = []
    for n in names:
        q = theta_interval(run, n)
        k = q.shape[-1] if runs is None else None
        nr = q.shape[1] if runs is None else runs
        c = coverage(q[0, :nr], q[2, :nr], S51["theta_true"])
        cT, cT_se = mean_se(c[:, -1].astype(float))
        cavg = c[:, 10:].mean()
        width = float(np.mean(q[2, :nr, -1] - q[0, :nr, -1]))
        rows.append({"method": n, "runs": nr, "coverage at T": cT, "se": cT_se,
                     "coverage k>10": cavg, "mean width at T": width})
    return pd.DataFrame(rows).set_index("method")


def sensitivity_table(run: Run, runs=None) -> pd.DataFrame:
    """x and θ RMSE (usual, mean ± SE), failures (:func:`lost_51`), coverage at T, and refit-guard counts,
    per filter of a sweep."""
    rows = []
    for n, res in run.results.items():
        ex, et = errors_51(run, n, runs)
        mx, sx = mean_se(rmse_usual(ex))
        mt, st = mean_se(rmse_usual(et))
        row = {"variant": n, "runs": ex.shape[0], "failures": int(lost_51(run, n, ex.shape[0]).sum()),
               "RMSE x": mx, "se x": sx, "RMSE θ": mt, "se θ": st}
        try:
            q = theta_interval(run, n)
            row["coverage at T"] = float(coverage(q[0, :, -1], q[2, :, -1], S51["theta_true"]).mean())
        except Exception:  # noqa: BLE001 - a filter without intervals
            row["coverage at T"] = np.nan
        d = res.diagnostics
        if "alpha" in d:
            row["median α+β at T"] = float(np.median(d["alpha"][:, -1] + d["beta"][:, -1]))
            row["capped steps %"] = 100.0 * d["n_capped"].sum() / d["alpha"].size
            row["guard steps %"] = 100.0 * (d["n_too_wide"] + d["n_zero_var"]).sum() / d["alpha"].size
        rows.append(row)
    return pd.DataFrame(rows).set_index("variant")


def rmse_over_time_52(run: Run, name: str):
    """RMSE over runs at each time of altitude, velocity (ft, ft/s) and θ (1/ft): (3, T)."""
    res = run.results[name]
    e = res.x - run.sim.x[:, 1:]
    et = res.diagnostics["theta"] - run.filters[name].model.theta_true[0]
    return np.stack([np.sqrt(np.mean(e[..., 0] ** 2, 0)), np.sqrt(np.mean(e[..., 1] ** 2, 0)),
                     np.sqrt(np.mean(et**2, 0))])


def per_run_rmse_52(run: Run, name: str, window=None):
    """Per-run RMSE over time (or over ``window`` = (k0, k1), 1-based inclusive) of the three quantities."""
    res = run.results[name]
    sl = slice(None) if window is None else slice(window[0] - 1, window[1])
    e = (res.x - run.sim.x[:, 1:])[:, sl]
    et = (res.diagnostics["theta"] - run.filters[name].model.theta_true[0])[:, sl]
    return [rmse_usual(e[..., 0]), rmse_usual(e[..., 1]), rmse_usual(et)]


def integration_error_52(substeps=(2, 4, 8, 16, 64)):
    """Max |x_k(n substeps) − x_k(1024 substeps)| over the 60 s truth trajectory, per substep count.
    Deterministic: computed once per process for the same settings (a copy is returned)."""
    return _integration_error_52(tuple(substeps), S52["T"]).copy()


@functools.lru_cache(maxsize=4)
def _integration_error_52(substeps, T):
    ref_m = model_52("feet", 1024)
    x_ref = [ref_m.x0[None]]
    for k in range(1, T + 1):
        x_ref.append(ref_m.f(x_ref[-1], k, ref_m.theta_true[None]))
    x_ref = np.concatenate(x_ref)
    out = {}
    for n in substeps:
        m = model_52("feet", n)
        x = [m.x0[None]]
        for k in range(1, T + 1):
            x.append(m.f(x[-1], k, m.theta_true[None]))
        d = np.abs(np.concatenate(x) - x_ref)
        out[n] = (float(d[:, 0].max()), float(d[:, 1].max()))
    return pd.DataFrame(out, index=["max |Δ altitude| (ft)", "max |Δ velocity| (ft/s)"]).T.rename_axis("substeps")


def truth_trajectory_52(reading="feet"):
    """Noise-free truth x_0..x_T of the re-entry problem (64 substeps)."""
    m = model_52(reading, S52["truth_substeps"])
    x = [m.x0[None]]
    for k in range(1, S52["T"] + 1):
        x.append(m.f(x[-1], k, m.theta_true[None]))
    return np.concatenate(x)


# --------------------------------------------------------------------------- per-run values, failures, pairs
def per_run(values, runs=None, name=None) -> pd.Series:
    """Per-run values as a Series indexed by run number (0-based, the truth stream's index)."""
    v = np.asarray(values, dtype=float)
    idx = pd.RangeIndex(v.shape[0]) if runs is None else pd.Index(runs, name="run")
    return pd.Series(v, index=idx, name=name)


def paired(a: pd.Series, b: pd.Series):
    """Mean and SE of the per-run differences ``a - b`` over the *same* runs.

    ``a`` and ``b`` are :func:`per_run` Series; a comparison over different run sets (e.g. 100
    runs against the exact reference's 40) is refused with ``ValueError``: select the common
    runs first (``a.loc[b.index]``).
    """
    if not (isinstance(a, pd.Series) and isinstance(b, pd.Series)):
        raise TypeError("paired() takes per-run Series (per_run), which carry their run numbers")
    if not a.index.equals(b.index):   # the book-wide check (claims.common_runs), with the run spans named
        raise CommonRunsError(f"paired comparison over unequal run sets ({a.size} runs {_span(a.index)} against "
                              f"{b.size} runs {_span(b.index)}): compare on common runs only")
    return paired_difference(a, b)


def _span(idx):
    return f"[{idx.min()}..{idx.max()}]" if len(idx) else "[]"


def rmse_51(run: Run, name: str, which: int, kind="usual", runs=None, T=None) -> pd.Series:
    """Per-run RMSE of x (``which=0``) or θ (1), ``kind`` "usual" or "eq14", over the first ``T`` steps."""
    e = errors_51(run, name, runs)[which]
    if T is not None:
        e = e[:, :T]
    return per_run((rmse_usual if kind == "usual" else rmse_eq14)(e), name=name)


def lost_51(run: Run, name: str, runs=None, T=None) -> pd.Series:
    """Failures of sec 5.1, per run (defined before looking at which filter fails):

    *diverged*: a non-finite estimate; *lost*: a state RMSE above that of the trivial estimate
    x̂_k = 0 (the truth's own RMS in the run: the filter does no better than ignoring the data), or a
    final θ further than ``lost_theta`` = 0.1 from the truth (seven exact posterior sd at T = 100).
    """
    res = run.results[name]
    n = res.x.shape[0] if runs is None else runs
    T = res.x.shape[1] if T is None else T
    ex, et = errors_51(run, name, n)
    ex, et = ex[:, :T], et[:, :T]
    truth_rms = np.sqrt(np.mean(run.sim.x[:n, 1:T + 1, 0] ** 2, axis=1))
    bad = ~np.all(np.isfinite(ex), 1) | ~np.all(np.isfinite(et), 1)
    with np.errstate(invalid="ignore"):
        lost = (rmse_usual(ex) > truth_rms) | (np.abs(et[:, -1]) > S51["lost_theta"])
    return pd.Series(bad | lost, index=pd.RangeIndex(n), name=name)


def first_runs(run: Run, n: int, names=None) -> Run:
    """The first ``n`` runs of ``run`` (truths and the results of ``names``, default all), to pair a
    reading run on fewer runs with the main one on common runs."""
    from ..results import FilterResult

    R = run.sim.y.shape[0]

    def cut(v):
        return v[:n] if isinstance(v, np.ndarray) and v.ndim >= 1 and v.shape[0] == R else v

    names = list(run.results) if names is None else list(names)
    res = {k: FilterResult(cut(run.results[k].x), None if run.results[k].P is None else cut(run.results[k].P),
                           {kk: cut(vv) for kk, vv in run.results[k].diagnostics.items()}) for k in names}
    return Run(sim=Simulation(run.sim.x[:n], run.sim.y[:n]), results=res,
               seconds={k: run.seconds.get(k) for k in names}, filters={k: run.filters[k] for k in names})


def merge(*runs: Run) -> Run:
    """One Run from several on the same truths (later runs' filters win); refuses different truths."""
    base = runs[0]
    for r in runs[1:]:
        if r.sim.y.shape != base.sim.y.shape or not np.array_equal(r.sim.y, base.sim.y):
            raise ValueError("merge: the runs do not share their truths (different run sets)")
    out = Run(sim=base.sim, results={}, seconds={}, filters={})
    for r in runs:
        out.results.update(r.results); out.seconds.update(r.seconds); out.filters.update(r.filters)
    return out


def errors_52(run: Run, name: str, T=None):
    """Errors (runs, T, 3) of altitude (ft), speed (ft/s) and θ (1/ft), first ``T`` steps."""
    res = run.results[name]
    e = res.x - run.sim.x[:, 1:]
    et = res.diagnostics["theta"] - run.filters[name].model.theta_true[0]
    out = np.concatenate([e, et[..., None]], axis=-1)
    return out if T is None else out[:, :T]


def lost_52(run: Run, name: str, T=None) -> pd.Series:
    """Failures of sec 5.2, per run: *diverged* (a non-finite estimate) or *lost* (final altitude error
    above ``lost_ft`` = 1000 ft, ten measurement standard deviations: the filter no longer follows the
    range measurements)."""
    e = errors_52(run, name, T)
    bad = ~np.all(np.isfinite(e.reshape(e.shape[0], -1)), axis=1)
    with np.errstate(invalid="ignore"):
        lost = np.abs(e[:, -1, 0]) > S52["lost_ft"]
    return pd.Series(bad | lost, index=pd.RangeIndex(e.shape[0]), name=name)


def rmse_52(run: Run, name: str, which: int, window=None, T=None) -> pd.Series:
    """Per-run RMSE of altitude (0, ft), speed (1, ft/s) or θ (2, 1/ft) over ``window`` = (k0, k1)
    (1-based, inclusive) or the first ``T`` steps."""
    e = errors_52(run, name, T)[..., which]
    if window is not None:
        e = e[:, window[0] - 1:window[1]]
    return per_run(rmse_usual(e), name=name)


def table_52(run: Run, names=("DPF", "DEKF", "Liu-West"), T=None) -> pd.DataFrame:
    """Per filter: RMSE over runs at the last step of altitude (ft), speed (ft/s), θ (10⁻³/ft), the
    failures (:func:`lost_52`) and the altitude RMSE at T over the runs not lost."""
    rows = []
    for n in names:
        e = errors_52(run, n, T)
        lost = lost_52(run, n, T).to_numpy()
        rm = np.sqrt(np.mean(e[:, -1] ** 2, axis=0))
        ok = e[~lost, -1, 0]
        rows.append({"filter": n, "runs": e.shape[0], "failures": int(lost.sum()),
                     "altitude (ft)": rm[0], "speed (ft/s)": rm[1], "θ (10⁻³/ft)": rm[2] / 1e-3,
                     "altitude, runs not lost (ft)": float(np.sqrt(np.mean(ok**2))) if ok.size else np.nan})
    return pd.DataFrame(rows).set_index("filter")


def convergence_time(theta_hat, truth, band):
    """Per run: the first step k after which abs(θ̂_j − θ) ≤ ``band`` for every j ≥ k (T + 1 if never)."""
    ok = np.abs(np.asarray(theta_hat) - truth) <= band                    # (runs, T)
    T = ok.shape[1]
    # last step that is outside the band; converged from the step after it
    out_idx = np.where(~ok, np.arange(1, T + 1), 0).max(axis=1)
    return out_idx + 1.0


# --------------------------------------------------------------------------- everything the chapter runs
#: the run counts of the chapter (settings dict, key), the ones :func:`scaled_settings` replaces
RUN_COUNTS = (("S51", "runs"), ("S51", "grid_runs"), ("S51", "sens_runs"), ("S51", "theta_runs"), ("S51", "fig5_runs"),
              ("S52", "runs"), ("S52", "q_runs"), ("S52", "literal_runs"), ("S52", "fig_runs"))


def scaled_settings(runs=None) -> tuple[dict, dict]:
    """Copies of :data:`S51` and :data:`S52` with every Monte Carlo run count replaced by ``runs``.

    ``runs=None`` keeps the chapter's counts (the power plans of :data:`PLANS`: ``RUNS_51`` runs in
    sec 5.1, its sweep and readings too, the exact reference on 40, Fig. 5 on 100, the true-θ context rows
    on 30; ``RUNS_52`` in sec 5.2, every reading too, the literal reading on 10, Figs. 7-9 on 50). An
    int replaces every count of :data:`RUN_COUNTS` (main runs, exact reference, sweeps and readings),
    so that ``runs=2`` is a quick run of every experiment; at least 2 (the paired comparisons need
    two runs). The module's own dicts are never changed.
    """
    s51, s52 = dict(S51), dict(S52)
    if runs is not None:
        if isinstance(runs, bool) or int(runs) != runs or runs < 2:
            raise ValueError(f"runs must be an integer >= 2 (paired comparisons need two runs), got {runs!r}")
        for which, key in RUN_COUNTS:
            (s51 if which == "S51" else s52)[key] = int(runs)
    return s51, s52


@dataclass
class Hou2008Results:
    """Everything the chapter's claims, prose, tables and figures need, from :func:`run_all`.

    Attributes
    ----------
    s51 : dict
        The sec 5.1 settings used (:data:`S51` with the run counts of :func:`scaled_settings`).
    s52 : dict
        The same for sec 5.2 (:data:`S52`).
    seeds : dict
        The seeds used, ``{"sec51": ..., "sec52": ...}``.
    r51
        Sec 5.1 main runs (:func:`run_51`): DPF, DEKF, Liu-West and the exact reference.
    f5 : dict
        Fig. 5, one run set per initial guess (:func:`run_fig5`).
    sens
        The DPF sweep: weight readings and caps (:func:`run_dpf_sensitivity`).
    dekf_sens
        The DEKF sweep: parameter noise (:func:`run_dekf_sensitivity`).
    r52
        Sec 5.2 main runs, in feet (:func:`run_52`).
    r52_lit
        Sec 5.2 under the literal (metric) reading.
    th51 : dict
        The true-θ rows of sec 5.1 by θ (:func:`run_51_theta`; context).
    x51
        The Gaussian-law DPF and Liu-West at δ = 0.95 on the sec 5.1 truths (:func:`run_51_extra`).
    rd52 : dict
        The sec 5.2 readings, by (choice, value) (:func:`run_52_readings`).
    tr_ft : numpy.ndarray
        Noise-free re-entry truth in feet.
    tr_lit : numpy.ndarray
        The same under the literal reading (metres).
    crb_ft : numpy.ndarray
        Cramér-Rao bound sd of θ over time, feet (:func:`crb_theta_52`).
    crb_lit : numpy.ndarray
        The same under the literal reading.
    integ : pandas.DataFrame
        The integration-error sweep (``integration_error_52``).
    pub : pandas.DataFrame
        The paper's sec 5.1 numbers (``published.table``).
    seconds : dict
        Wall time of the main 5.1 and 5.2 runs and of the readings (context only, never in a claim).
    rg51 : dict
        The range reading of sec 5.1 by its bounds tuple (:func:`run_51_range`).
    """

    s51: dict
    s52: dict
    seeds: dict
    r51: Run
    f5: dict
    sens: Run
    dekf_sens: Run
    r52: Run
    r52_lit: Run
    th51: dict
    x51: Run
    rd52: dict
    tr_ft: np.ndarray
    tr_lit: np.ndarray
    crb_ft: np.ndarray
    crb_lit: np.ndarray
    integ: pd.DataFrame
    pub: pd.DataFrame
    seconds: dict = field(default_factory=dict)
    rg51: dict = field(default_factory=dict)

    @property
    def settings(self) -> dict:
        """The run counts and seeds used (printed by ``pfrepro run``)."""
        return {"runs (5.1)": self.s51["runs"], "runs (exact reference)": self.r51.results["exact"].x.shape[0],
                "runs (5.1 sweeps and readings)": self.s51["sens_runs"], "runs (5.1 true-θ rows)": self.s51["theta_runs"],
                "runs (Fig. 5)": self.s51["fig5_runs"], "runs (5.2)": self.s52["runs"],
                "runs (5.2 readings)": self.s52["q_runs"], "runs (5.2 literal)": self.s52["literal_runs"],
                "seed (5.1)": self.seeds["sec51"], "seed (5.2)": self.seeds["sec52"]}


#: the labels :func:`run_all` passes to ``steps`` (one per experiment, in order)
STEPS = ("Sec 5.1, main runs", "Fig. 5, initial guesses", "Sec 5.1, DPF sweep", "Sec 5.1, DEKF sweep",
         "Sec 5.2, main runs", "Sec 5.2, literal reading", "Sec 5.1, true-θ readings",
         "Sec 5.1, Gaussian law and Liu-West δ", "Sec 5.2, readings", "Sec 5.2, truth, bound, integration")


def run_all(runs=None, seeds=None, executor=None, steps=None) -> Hou2008Results:
    """Every experiment, reading and sweep of the chapter (secs 5.1 and 5.2 and beyond).

    Parameters
    ----------
    runs : int, optional
        ``None``: the chapter's run counts; an int (>= 2) replaces every Monte Carlo run count
        (:func:`scaled_settings`).
    seeds : None, int or dict, optional
        ``None``: the book's :data:`SEEDS`; an int: ``seeds`` for sec 5.1 and ``seeds + 1`` for
        sec 5.2; a dict: some entries (:func:`pfrepro.papers.resolve_seeds`).
    executor : concurrent.futures.Executor, optional
        Passed to every Monte Carlo call (same numbers as the serial call).
    steps : callable, optional
        ``steps(label)`` is called before each experiment (:data:`STEPS`).

    Returns
    -------
    Hou2008Results
        The runs, the deterministic re-entry computations and the wall times.
    """
    from .. import published
    from ..papers import resolve_seeds

    seeds = resolve_seeds(SEEDS, seeds)
    s51, s52 = scaled_settings(runs)
    a, b = seeds["sec51"], seeds["sec52"]
    labels = iter(STEPS)

    def say():
        if steps is not None:
            steps(next(labels))

    say()
    t0 = time.perf_counter()
    r51 = run_51(executor, runs=s51["runs"], grid_runs=s51["grid_runs"], seed=a)
    t_51 = time.perf_counter() - t0
    say()
    f5 = run_fig5(r51, executor=executor, runs=s51["fig5_runs"], seed=a)
    say()
    sens = run_dpf_sensitivity(executor, runs=s51["sens_runs"], seed=a, main=r51)
    say()
    dekf_sens = run_dekf_sensitivity(executor, runs=s51["runs"], seed=a)
    say()
    t0 = time.perf_counter()
    r52 = run_52(runs=s52["runs"], executor=executor, seed=b)
    t_52 = time.perf_counter() - t0
    say()
    r52_lit = run_52("literal", runs=s52["literal_runs"], executor=executor, seed=b)
    # the readings beyond the main one (fewer runs, stated in the chapter)
    t0 = time.perf_counter()
    say()
    th51 = {th: run_51_theta(th, executor, runs=s51["theta_runs"], seed=a) for th in s51["thetas"][1:]}
    rg51 = {tuple(b_): run_51_range(b_, executor, runs=s51["sens_runs"], seed=a) for b_ in s51["ranges"][1:]}
    say()
    x51 = run_51_extra(executor, runs=s51["runs"], lw_runs=s51["sens_runs"], seed=a)
    say()
    rd52 = run_52_readings(executor, runs=s52["q_runs"], seed=b)
    t_readings = time.perf_counter() - t0
    say()
    out = Hou2008Results(
        s51=s51, s52=s52, seeds=seeds, r51=r51, f5=f5, sens=sens, dekf_sens=dekf_sens, r52=r52, r52_lit=r52_lit,
        th51=th51, x51=x51, rd52=rd52, tr_ft=truth_trajectory_52("feet"), tr_lit=truth_trajectory_52("literal"),
        crb_ft=crb_theta_52("feet"), crb_lit=crb_theta_52("literal"), integ=integration_error_52(),
        pub=published.table(PAPER, "Sec 5.1"),
        seconds={"5.1": t_51, "5.2": t_52, "readings": t_readings}, rg51=rg51)
    return out
