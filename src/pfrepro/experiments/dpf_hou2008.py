"""Hou & Yin (2008), dual particle filter: models, filters and settings of every experiment.

Every unstated setting is fixed here, before any run, with its reason (``ASSUMPTIONS``);
the chapter ``book/50_dpf.md`` only calls these functions and plots. Seeds are picked once.

Randomness: the truth of run i comes from ``truth_streams(seed, runs)`` and filter ``name``'s
draws from ``filter_streams(seed, name, runs)`` (per-run streams keyed by name), so run i's
numbers do not depend on how many runs an experiment has, and every filter sees the same
truths (paired comparisons).
"""
from __future__ import annotations

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
from ..montecarlo import run_monte_carlo, truth_streams

__all__ = ["PAPER", "SEED_51", "SEED_52", "S51", "S52", "ASSUMPTIONS", "assumptions_table", "model_51",
           "model_52", "simulate_51", "simulate_52", "dpf_51", "dekf_51", "liu_west_51", "grid_51",
           "run_51", "run_fig5", "run_dpf_sensitivity", "run_dekf_sensitivity",
           "run_52", "rmse_eq14", "rmse_usual", "mean_se", "coverage", "crb_theta_52"]

PAPER = "dpf_hou2008"
#: seeds, picked once (the paper's year + section); never changed
SEED_51 = 200851
SEED_52 = 200852

#: Sec 5.1 settings
S51 = dict(
    T=100,              # horizon: not given; the classic UNGM horizon of Kitagawa (ref [17]) and most PF studies
    runs=100,           # paper: one run; we use 100 Monte Carlo runs
    bounds=(0.0, 1.0),  # [r_l, r_u]: not given; the unit interval of sec 3.2 (eq 6)
    theta_true=0.5,
    n_x=500, n_theta=500,
    cap=500.0,          # = n_theta: the Beta's pseudo-count may not exceed the draws it is fitted from
    theta0=0.5,         # the uniform prior's mean: DPF's θ̂_0 and DEKF's start (same prior information)
    sens_runs=30,       # runs of the sweeps (weight readings, caps): budget
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
    runs=50, n_x=2000, n_theta=2000,
    cap=2000.0,           # = n_theta, the same rule as in 5.1
    theta0=3e-5,          # the classic filter start, far from θ = 1e-3
    P_theta0=1e-4,        # the classic initial variance of θ (DEKF)
    truth_substeps=64,    # truth: RK4 with 64 substeps per second
    filter_substeps=4,    # filters: 4 substeps (integration error ~0.01 ft over 60 s, 1e-4 of the noise sd; see the chapter)
    roughening=0.2,       # Gordon et al. (1993) roughening of the state PF: Q = 0 would collapse it
    literal_runs=10,
)

ASSUMPTIONS = [
    ("5.1 horizon T", "100", "not stated; the classic UNGM horizon (Kitagawa, ref [17])"),
    ("5.1 range [r_l, r_u]", "[0, 1]", "not stated; the interval on which sec 3.2 fits the Beta (eq 6)"),
    ("5.1 x_0", "N(0, 5) for truth and filters", "eq 12 text: N(mu, sigma^2), 5 is a variance"),
    ("5.1 forcing", "8 cos(1.2 k)", "as printed in eq (12)"),
    ("Monte Carlo runs", "100 (5.1), 50 (5.2)", "5.1: the paper shows one run; 5.2: as printed"),
    ("DPF parameter weight", "N(z_k; h(f(x̂_{k-1}, θ)), H P⁻ Hᵀ + R)",
     "eq (11)'s E[x_k | θ, z_1:k-1] with the predictive variance; the literal p(z_k | θ, x̂_k) is flat in θ"),
    ("DPF θ̂_0 (state filter at k = 1)", "prior mean 0.5 (5.1), 3e-5 (5.2)",
     "the paper starts the Beta at α = β = 1; the initial guess enters only through θ̂_0"),
    ("Beta cap", "max(α, β) ≤ N_θ, mean kept",
     "paper: 'upper limits on α, β', value not given; a pseudo-count above the number of draws "
     "claims more precision than the draws carry"),
    ("Refit guards", "ν = α + β floored at 2 when σ² ≥ μ(1 − μ); capped when σ² = 0", "eq (7) fails there"),
    ("Step 3(d) variance", "Σ w (θ − θ̂)²", "printed with an extra factor θ^i (erratum)"),
    ("DPF resampling", "systematic, every step", "step 2(e)"),
    ("DEKF", "Wan & Nelson dual EKF, recurrent derivative without ∂K/∂θ",
     "Q^θ_k = max(1e-3 P_θ0 · 0.995^k, 1e-6 P_θ0): ReBEL-style annealing, fixed before any run"),
    ("DEKF start (5.1)", "θ̂_0 = 0.5, P_θ0 = 1/12", "the uniform prior's mean and variance"),
    ("DEKF parameter update", "noise of the 'measurement' z_k = h(x⁻(θ)) is the innovation covariance S",
     "prediction-error form: the innovation, not z_k alone, carries the state uncertainty"),
    ("Liu-West", "δ = 0.99, N = 500, auxiliary form", "2N = 1000 likelihoods per step, as the DPF's N_x + N_θ"),
    ("Exact θ posterior", "81 θ nodes × 241 x nodes on [-30, 30], first 40 runs",
     "cubic interpolation of the log-evidence; cost limits it to 40 of the 100 runs"),
    ("Sweeps (weight readings, caps)", "first 30 runs", "budget of the chapter"),
    ("5.2 units", "feet (Athans et al. 1968)", "γ, noise variance and θ are foot values; plots in metres"),
    ("5.2 drag", "−θ x2² exp(−γ x1)", "the classic problem; the paper's eq (16) drops the square"),
    ("5.2 10⁶, 4·10⁶", "initial covariance P_0, no process noise", "the classic problem; printed as process noise"),
    ("5.2 θ", "truth 1e-3, start 3e-5 (DEKF P_θ0 = 1e-4), range [0, 2e-3]", "the classic problem"),
    ("5.2 horizon", "60 s, 1 s sampling", "the classic problem (KalmTool)"),
    ("5.2 integration", "RK4, 64 substeps (truth), 4 (filters)", "4-substep error ≈ 0.01 ft against 100 ft noise; halves the cost"),
    ("5.2 state PF", "roughening K = 0.2 (Gordon et al. 1993)", "with Q = 0 a bootstrap PF collapses to one particle"),
    ("5.2 DEKF noise", "Q^θ = 0 (static θ)", "the classic set-up"),
    ("5.2 Liu-West", "N = 2000, δ = 0.99, θ_0 ~ U[0, 2e-3]", "4000 likelihoods per step, as the DPF's 2000 + 2000"),
    ("DEKF projection", "θ̂ clipped to [r_l, r_u]", "the same prior information as the DPF's Beta; unprojected as a sensitivity row"),
]


def assumptions_table() -> pd.DataFrame:
    return pd.DataFrame(ASSUMPTIONS, columns=["item", "our choice", "reason"])


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
def model_51() -> UNGMTheta:
    return UNGMTheta(theta_true=S51["theta_true"], bounds=S51["bounds"])


def simulate_51(runs=None):
    runs = S51["runs"] if runs is None else runs
    return model_51().simulate(S51["T"], runs, truth_streams(SEED_51, runs))


def dpf_51(model=None, **over):
    kw = dict(n_x=S51["n_x"], n_theta=S51["n_theta"], cap=S51["cap"], theta0=S51["theta0"])
    kw.update(over)
    return DualParticleFilter(model or model_51(), **kw)


def dekf_51(model=None, theta0=None, q_rel=None, clip=True):
    P0 = (S51["bounds"][1] - S51["bounds"][0]) ** 2 / 12.0
    q_rel = S51["dekf_q_rel"] if q_rel is None else q_rel
    return DualExtendedKalmanFilter(model or model_51(), S51["theta0"] if theta0 is None else theta0, P0,
                                    q0=q_rel * P0, anneal=S51["dekf_anneal"],
                                    q_min=S51["dekf_floor_rel"] * P0 * (q_rel > 0), clip_to_bounds=clip)


def liu_west_51(model=None):
    return LiuWestFilter(model or model_51(), S51["lw_n"], delta=S51["lw_delta"])


def grid_51(model=None):
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


def run_51(executor=None) -> Run:
    """Sec 5.1 at paper scale: DPF, DEKF, Liu-West (equal likelihood count) and the exact θ posterior."""
    m = model_51()
    sim = simulate_51()
    filters = {"DPF": dpf_51(m), "DEKF": dekf_51(m), "Liu-West": liu_west_51(m), "exact": grid_51(m)}
    return _run(filters, sim, SEED_51, executor, runs_of={"exact": S51["grid_runs"]})


def run_fig5(main: Run | None = None, executor=None) -> dict:
    """Fig. 5: DPF and DEKF with initial guesses 0.2 / 0.5 / 0.7 on all runs, with the same truths and
    the same filter streams for every guess (common random numbers). ``main`` (a :func:`run_51`
    result, whose guess is 0.5) is reused for 0.5: it is the same computation. Returns {guess: Run}."""
    m = model_51()
    sim = simulate_51() if main is None else main.sim
    out = {}
    for g0 in S51["guesses"]:
        if main is not None and g0 == S51["theta0"]:
            keep = ("DPF", "DEKF")
            out[g0] = Run(sim=sim, results={k: main.results[k] for k in keep},
                          seconds={k: main.seconds[k] for k in keep}, filters={k: main.filters[k] for k in keep})
        else:
            out[g0] = _run({"DPF": dpf_51(m, theta0=g0), "DEKF": dekf_51(m, theta0=g0)}, sim, SEED_51, executor)
    return out


def run_dpf_sensitivity(executor=None) -> Run:
    """One sweep on the first ``sens_runs`` runs: the three readings of the parameter weight
    (cap N_θ) and the Beta caps (predictive weight). "DPF" is the working setting; every variant
    uses its own named stream."""
    m = model_51()
    sim = simulate_51(S51["sens_runs"])
    filters = {"DPF": dpf_51(m), "plugin weight": dpf_51(m, weight="plugin"),
               "literal weight": dpf_51(m, weight="literal")}
    for c in S51["caps"]:
        if c != S51["cap"]:
            filters[f"cap {c:g}" if c else "no cap"] = dpf_51(m, cap=c)
    return _run(filters, sim, SEED_51, executor)


def run_dekf_sensitivity(executor=None) -> Run:
    m = model_51()
    sim = simulate_51()
    filters = {f"q0 = {q:g} P0": dekf_51(m, q_rel=q) for q in S51["dekf_q_rels"]}
    filters["unprojected"] = dekf_51(m, clip=False)
    return _run(filters, sim, SEED_51, executor)


# --------------------------------------------------------------------------- 5.2
def model_52(reading="feet", substeps=None) -> Reentry:
    return Reentry(reading=reading, n_substeps=S52["filter_substeps"] if substeps is None else substeps)


def simulate_52(runs=None, reading="feet"):
    runs = S52["runs"] if runs is None else runs
    return model_52(reading, S52["truth_substeps"]).simulate(S52["T"], runs, truth_streams(SEED_52, runs))


def run_52(reading="feet", runs=None, executor=None) -> Run:
    """Sec 5.2: DPF (2000 + 2000 particles), DEKF and Liu-West (2000 joint particles) on the re-entry problem."""
    runs = (S52["runs"] if reading == "feet" else S52["literal_runs"]) if runs is None else runs
    m = model_52(reading)
    sim = simulate_52(runs, reading)
    filters = {
        "DPF": DualParticleFilter(m, S52["n_x"], S52["n_theta"], cap=S52["cap"], theta0=S52["theta0"],
                                  roughening=S52["roughening"]),
        "DEKF": DualExtendedKalmanFilter(m, S52["theta0"], S52["P_theta0"], clip_to_bounds=True),
        # joint (not dual) reference at the DPF's likelihood count: 2 x 2000 = 2000 + 2000
        "Liu-West": LiuWestFilter(m, S52["n_x"], delta=S51["lw_delta"]),
    }
    return _run(filters, sim, SEED_52, executor)


def crb_theta_52(reading="feet", T=None):
    """Cramér–Rao bound sd of θ over time for the noise-free truth (θ, x_0 unknown; Fisher information
    from the sensitivities of the range to (x_0, θ), by the variational equations)."""
    T = S52["T"] if T is None else T
    m = model_52(reading, S52["truth_substeps"])
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


def to_metres(v, component):
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
    et = res.diagnostics["theta"][:n] - S51["theta_true"]
    return ex, et


def rmse_table_51(run: Run, names, runs=None) -> pd.DataFrame:
    """Per-run eq-(14) and usual RMSEs of x and θ, mean ± SE over runs."""
    rows = []
    for n in names:
        ex, et = errors_51(run, n, runs)
        row = {"filter": n, "runs": ex.shape[0]}
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
    """x and θ RMSE (usual, mean ± SE), coverage at T, and refit-guard counts, per filter of a sweep."""
    rows = []
    for n, res in run.results.items():
        ex, et = errors_51(run, n, runs)
        mx, sx = mean_se(rmse_usual(ex))
        mt, st = mean_se(rmse_usual(et))
        row = {"variant": n, "RMSE x": mx, "se x": sx, "RMSE θ": mt, "se θ": st}
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
    """Max |x_k(n substeps) − x_k(1024 substeps)| over the 60 s truth trajectory, per substep count."""
    ref_m = model_52("feet", 1024)
    x_ref = [ref_m.x0[None]]
    for k in range(1, S52["T"] + 1):
        x_ref.append(ref_m.f(x_ref[-1], k, ref_m.theta_true[None]))
    x_ref = np.concatenate(x_ref)
    out = {}
    for n in substeps:
        m = model_52("feet", n)
        x = [m.x0[None]]
        for k in range(1, S52["T"] + 1):
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
