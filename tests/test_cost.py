"""Cost counts against hand-computed values; the counting proxy changes nothing; timing repeats."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pfrepro.cost import (COUNT_COLUMNS, PRINTED_COLUMNS, CountingModel, cost_counts, count_model_calls,
                          median_interval, time_repeats, time_summary)
from pfrepro.filters import (BootstrapParticleFilter, CMSParticleFilter, EvolutionSamplingParticleFilter,
                             ExtendedKalmanFilter, GaussianParticleFlowFilter, GridFilter, KalmanFilter,
                             UnscentedKalmanFilter)
from pfrepro.models import CWPA, UNGM, BearingsOnly

T = 6


@pytest.fixture(scope="module")
def ung():
    m = UNGM.zhang2016()
    return m, m.simulate(T, 3, np.random.default_rng(1))


@pytest.fixture(scope="module")
def bot():
    m = BearingsOnly.zhang2016()
    return m, m.simulate(T, 2, np.random.default_rng(2))


def zeros_except(c, **expected):
    for col in ("transitions", "likelihoods", "f", "h", "jacobian_f", "jacobian_h", "flow"):
        assert c[col] == expected.get(col, 0), (col, c[col], expected.get(col, 0))
    assert c["model_evaluations"] == sum(c[k] for k in ("transitions", "likelihoods", "f", "h",
                                                        "jacobian_f", "jacobian_h"))


def test_pf_counts_n_t_transitions_and_likelihoods(ung):
    m, sim = ung
    N, runs = 37, sim.runs
    c = count_model_calls(BootstrapParticleFilter(m, N), sim.y, np.random.default_rng(0))
    zeros_except(c, transitions=runs * N * T, likelihoods=runs * N * T)


def test_ekf_counts_t_of_each(ung):
    m, sim = ung
    c = count_model_calls(ExtendedKalmanFilter(m), sim.y[:1])
    zeros_except(c, f=T, h=T, jacobian_f=T, jacobian_h=T)


def test_ukf_counts_sigma_points(bot):
    m, sim = bot
    n = m.dim_x  # 4 -> 2n + 1 = 9 sigma points in predict and in update
    c = count_model_calls(UnscentedKalmanFilter(m), sim.y[:1])
    zeros_except(c, f=(2 * n + 1) * T, h=(2 * n + 1) * T)


def test_kf_asks_nothing_of_the_model():
    m = CWPA.zhang2016("gaussian")
    sim = m.simulate(T, 1, np.random.default_rng(3))
    zeros_except(count_model_calls(KalmanFilter(m), sim.y))


def test_gpff_counts_eq41_and_eq43(bot):
    m, sim = bot
    d, N, S = m.dim_x, 11, 5
    c41 = count_model_calls(GaussianParticleFlowFilter(m, N, n_steps=S, field="eq41"), sim.y[:1])
    # h at the 2d+1 sigma points, then at every particle in each of the S Euler steps
    zeros_except(c41, transitions=N * T, h=(2 * d + 1) * T + N * S * T, flow=N * S * T)
    c43 = count_model_calls(GaussianParticleFlowFilter(m, N, n_steps=S, field="eq43"), sim.y[:1])
    # the eq (43) field is affine: d + 1 probe points are integrated, not the N particles
    zeros_except(c43, transitions=N * T, h=(2 * d + 1) * T, flow=(d + 1) * S * T)
    rk4 = count_model_calls(GaussianParticleFlowFilter(m, N, n_steps=S, field="eq41", integrator="rk4"),
                            sim.y[:1])
    assert rk4["flow"] == 4 * N * S * T


def test_cms_espf_and_grid_counts(ung):
    m, sim = ung
    N = 20
    zeros_except(count_model_calls(CMSParticleFilter(m, N), sim.y[:1], np.random.default_rng(0)),
                 transitions=N * T, likelihoods=2 * N * T)
    zeros_except(count_model_calls(EvolutionSamplingParticleFilter(m, N), sim.y[:1], np.random.default_rng(0)),
                 f=N * T, likelihoods=3 * N * T)
    G = 301
    zeros_except(count_model_calls(GridFilter(m, bounds=(-30.0, 30.0), n_grid=G), sim.y[:1]),
                 f=G * T, likelihoods=G * T)


def test_counting_changes_nothing(ung):
    m, sim = ung
    pf = BootstrapParticleFilter(m, 50)
    ref = pf.filter(sim.y, rng=np.random.default_rng(7)).x
    count_model_calls(pf, sim.y, np.random.default_rng(7))
    assert pf.model is m  # the filter itself is untouched
    np.testing.assert_array_equal(pf.filter(sim.y, rng=np.random.default_rng(7)).x, ref)
    # the proxy returns exactly what the model returns
    proxy = CountingModel(m)
    x = np.random.default_rng(0).standard_normal((2, 5, 1))
    np.testing.assert_array_equal(proxy.h(x), m.h(x))
    assert proxy.counts["h"] == 10 and proxy.dim_x == m.dim_x
    proxy.f(np.array([0.3]), 1)
    assert proxy.counts["f"] == 1  # a single state counts one


def test_counts_do_not_depend_on_the_rng(ung):
    m, sim = ung
    pf = BootstrapParticleFilter(m, 30)
    a = count_model_calls(pf, sim.y[:1], np.random.default_rng(1))
    b = count_model_calls(pf, sim.y[:1], np.random.default_rng(2))
    assert a == b


def test_cost_counts_table(ung):
    m, sim = ung
    df = cost_counts({"EKF": ExtendedKalmanFilter(m), "PF(10)": BootstrapParticleFilter(m, 10)}, sim.y[:1])
    assert list(df.columns) == COUNT_COLUMNS + PRINTED_COLUMNS + ["per step"]
    assert df.loc["PF(10)", "resampled"] == 10 * T     # every step, N copies
    assert df.loc["EKF", "printed_operations"] == df.loc["EKF", "model_evaluations"]
    assert df.loc["PF(10)", "model_evaluations"] == 2 * 10 * T
    assert df.loc["EKF", "per step"] == 4
    with pytest.raises(ValueError, match="one run"):
        cost_counts({"EKF": ExtendedKalmanFilter(m)}, sim.y)


def test_time_repeats_and_summary(ung):
    m, sim = ung
    fs = {"EKF": ExtendedKalmanFilter(m), "PF": BootstrapParticleFilter(m, 20)}
    t = time_repeats(fs, sim.y[:1], repeats=3)
    assert t.shape == (3, 2) and (t.to_numpy() > 0).all()
    s = time_summary(t, reference="EKF")
    np.testing.assert_allclose(s.loc["EKF", ["ratio median", "ratio min", "ratio max"]].to_numpy(float), 1.0)
    assert s.loc["PF", "time min [s]"] <= s.loc["PF", "time median [s]"] <= s.loc["PF", "time max [s]"]
    assert median_interval([3.0, 1.0, 2.0]) == (2.0, 1.0, 3.0)
    with pytest.raises(ValueError):
        median_interval([])
    with pytest.raises(ValueError, match="repeats"):
        time_repeats(fs, sim.y[:1], repeats=0)
    assert isinstance(t, pd.DataFrame)


def test_cms_fig3_counts_are_3n_and_2n():
    from pfrepro.experiments import cmspf_ning2011 as E

    c = E.cost_counts_fig3(Ns=(10, 25))
    assert c["CMS-PF evals / step"].tolist() == [30.0, 75.0]
    assert c["PF evals / step"].tolist() == [20.0, 50.0]


# ---------------------------------------------------------------- parameterised models (state × parameter)
def _theta_data(runs=2, T_=3):
    from pfrepro.experiments.dpf_hou2008 import model_51
    m = model_51()
    return m, m.simulate(T_, runs, np.random.default_rng(3))


def test_dpf_counts_every_state_times_parameter_evaluation():
    """Hand count of one DPF step (predictive weight, module docstring of filters.dual_pf), per run:
    state filter: N_x transitions and N_x likelihoods; parameter filter: f at the one state
    estimate under each of the N_θ draws (N_θ evaluations, not 1), one Jacobian of f (at θ̂),
    and h and its Jacobian at the N_θ predicted states."""
    from pfrepro.filters.dual_pf import DualParticleFilter
    m, sim = _theta_data()
    nx, nt, runs, T_ = 7, 5, sim.runs, sim.y.shape[1]
    c = count_model_calls(DualParticleFilter(m, n_x=nx, n_theta=nt), sim.y, np.random.default_rng(0))
    zeros_except(c, transitions=runs * T_ * nx, likelihoods=runs * T_ * nx, f=runs * T_ * nt,
                 jacobian_f=runs * T_, h=runs * T_ * nt, jacobian_h=runs * T_ * nt)
    assert c["model_evaluations"] == runs * T_ * (2 * nx + 3 * nt + 1)   # 30 per run and step here


def test_liu_west_counts_four_per_particle():
    from pfrepro.filters.liu_west import LiuWestFilter
    m, sim = _theta_data()
    N, runs, T_ = 11, sim.runs, sim.y.shape[1]
    c = count_model_calls(LiuWestFilter(m, N), sim.y, np.random.default_rng(0))
    # auxiliary step: f at the N kernel locations and their likelihoods; then N transitions, N likelihoods
    zeros_except(c, f=runs * T_ * N, likelihoods=2 * runs * T_ * N, transitions=runs * T_ * N)


def test_parameter_broadcast_counts_pairs():
    """f(x, k, θ) at one state (runs, 1, d) and N_θ draws (runs, N_θ, 1) is runs · N_θ evaluations; a
    scalar θ (or one vector (dim_θ,)) broadcasts to every state."""
    from pfrepro.experiments.dpf_hou2008 import model_51
    proxy = CountingModel(model_51())
    proxy.f(np.zeros((3, 1, 1)), 1, np.full((3, 4, 1), 0.5))
    assert proxy.counts["f"] == 12
    proxy.f(np.zeros((3, 6, 1)), 1, 0.5)
    proxy.f(np.zeros((3, 6, 1)), 1, np.array([0.5]))
    assert proxy.counts["f"] == 12 + 18 + 18
    proxy.sample_transition(np.zeros((2, 5, 1)), 1, np.full((2, 1, 1), 0.5), np.random.default_rng(0))
    assert proxy.counts["transitions"] == 10


# -- today's methods (issue 22): hand counts per step and run ------------------------------------
def test_todays_particle_filters_hand_counts(ung, bot):
    """APF: f and a likelihood at the look-ahead point, then a transition and a likelihood (4N);
    RPF: the bootstrap PF's 2N (the kernel jitter is no model call); EKF-proposal PF: f, h and
    dh/dx at each particle's transition mean, one likelihood (4N); UT-proposal PF: f, h at the
    2n+1 sigma points, one likelihood; PFPF: the EKF alongside (f, Jacobian of f, Jacobian of h:
    one each), f and a transition per particle, h and its Jacobian at the linearisation point in
    each pseudo-time step (EDH: one point; LEDH: one per particle), one likelihood per particle."""
    from pfrepro.filters import (AuxiliaryParticleFilter, GaussianProposalParticleFilter,
                                 ParticleFlowParticleFilter, RegularizedParticleFilter)
    m, sim = ung
    N, runs = 11, sim.runs
    c = count_model_calls(AuxiliaryParticleFilter(m, N), sim.y)
    zeros_except(c, f=runs * N * T, likelihoods=2 * runs * N * T, transitions=runs * N * T)
    c = count_model_calls(RegularizedParticleFilter(m, N), sim.y)
    zeros_except(c, transitions=runs * N * T, likelihoods=runs * N * T)
    c = count_model_calls(GaussianProposalParticleFilter(m, N), sim.y)
    zeros_except(c, f=runs * N * T, h=runs * N * T, jacobian_h=runs * N * T, likelihoods=runs * N * T)
    mb, sb = bot
    n = mb.dim_x
    c = count_model_calls(GaussianProposalParticleFilter(mb, N, proposal="unscented"), sb.y)
    zeros_except(c, f=sb.runs * N * T, h=sb.runs * N * (2 * n + 1) * T, likelihoods=sb.runs * N * T)
    S = 7    # pseudo-time steps
    for flow, pts in (("edh", 1), ("ledh", N)):
        c = count_model_calls(ParticleFlowParticleFilter(mb, N, flow=flow, n_steps=S), sb.y)
        r = sb.runs
        zeros_except(c, jacobian_f=r * T, f=r * (N + 1) * T, transitions=r * N * T,
                     h=r * S * pts * T, jacobian_h=r * (S * pts + 1) * T, likelihoods=r * N * T)
    assert cost_counts({"p": ParticleFlowParticleFilter(mb, 100)}, sb.y[:1]).loc["p", "per step"] == 3 * 100 + 61


def test_jump_markov_pf_counts_its_mode_models():
    """The jump-Markov PF moves each particle with its mode's f (one per particle) and weights it
    once: 2N per step, counted through the system's mode models."""
    from pfrepro.experiments import immpfor_zhou2017 as IMM
    from pfrepro.filters import JumpMarkovParticleFilter

    sim = IMM.simulate(runs=2)
    N = 13
    c = count_model_calls(JumpMarkovParticleFilter(IMM.filter_system(), N), sim.y[:, :T])
    zeros_except(c, f=2 * N * T, likelihoods=2 * N * T)


def test_smc2_count_is_its_hand_count_per_run():
    """SMC²: 2 M N_x per PF step, T steps plus the PMMH reruns of its diagnostics, per run
    (:func:`pfrepro.cost.smc2_evaluations` equals the proxy's count on each run)."""
    from pfrepro.cost import smc2_evaluations
    from pfrepro.filters import SMC2
    from pfrepro.models.linear_theta import LinearTheta
    from pfrepro.rng import RunStreams

    m = LinearTheta(theta_true=0.7, c=1.0)
    sim = m.simulate(12, 3, RunStreams.from_entropy(3, 3))
    f = SMC2(m, 16, 5)
    res = f.filter(sim.y, RunStreams.from_entropy(4, 3))
    per_run = smc2_evaluations(res, 16, 5)
    assert res.diagnostics["pmmh_steps"].max() > 0          # the moves are part of the count
    for i in range(3):
        c = count_model_calls(f, sim.y[i:i + 1], RunStreams.from_entropy(4, 1, start=i))
        zeros_except(c, transitions=c["transitions"], likelihoods=c["likelihoods"])
        assert c["transitions"] == c["likelihoods"] and c["model_evaluations"] == per_run[i]


def test_imm_filters_count_through_their_system_and_mode_filters():
    """The IMM particle filters read their jump-Markov system (``.system``), the IMM Kalman filters
    their mode filters: both used to count nothing. IMMPF/IMMPFOR: one transition and one
    measurement evaluation per particle and mode (r N each per step); IMM-EKF: per mode one f, one
    h and one Jacobian of each per step; IMM-UKF: 2n + 1 = 13 sigma points through f and h per mode."""
    from pfrepro.experiments import immpfor_zhou2017 as IMM

    sim = IMM.simulate(runs=2)
    y, N, r = sim.y[:, :T], 7, 3
    for build in (IMM.immpf, IMM.immpfor):
        zeros_except(count_model_calls(build(N=N), y), transitions=2 * r * N * T, h=2 * r * N * T)
    zeros_except(count_model_calls(IMM.imm_ekf(), y), f=2 * r * T, h=2 * r * T, jacobian_f=2 * r * T,
                 jacobian_h=2 * r * T)
    n = IMM.filter_system().dim_x
    zeros_except(count_model_calls(IMM.imm_ukf(), y), f=2 * r * (2 * n + 1) * T, h=2 * r * (2 * n + 1) * T)
    # the counting copy changes no number
    f = IMM.immpf(N=N)
    a = f.filter(y, np.random.default_rng(3)).x
    from pfrepro.cost import _with_model
    b = _with_model(f, CountingModel(f.system)).filter(y, np.random.default_rng(3)).x
    np.testing.assert_array_equal(a, b)


def _bench_table():
    from pfrepro.cost import SAME_MODEL_RATIO, UNGM_RATIO

    return pd.DataFrame({"particles": [1000, 1000, 100, np.nan, 1500],
                         SAME_MODEL_RATIO: [1.0, 1.9, 2.1, 9.0, 1.0],
                         UNGM_RATIO: [1.0, 6.0, 1.5, 30.0, 3.5],
                         "particle filter": [True, True, True, False, False]},
                        index=["PF", "PF on a 4-D model's", "flow", "EKF", "reference PF"])


def test_count_predicted_judges_on_the_same_model_ratio():
    from pfrepro.cost import count_predicted

    out = count_predicted(_bench_table())
    assert list(out.index) == ["PF", "PF on a 4-D model's", "flow"]     # not the EKF, not the reference row
    assert list(out["within"]) == [True, True, False]                   # 1.9 is within 2, 2.1 is not
    assert list(out["within vs UNGM"]) == [True, False, True]
    assert int(count_predicted(_bench_table(), limit=2.2)["within"].sum()) == 3
    # without the marker column every row with particles counts (the reference row too)
    assert len(count_predicted(_bench_table().drop(columns=["particle filter"]))) == 4
    assert "same N" not in out
    from pfrepro.cost import SAME_N_RATIO

    with_n = _bench_table().assign(**{SAME_N_RATIO: [1.0, 1.9, 1.6, 9.0, 1.0]})
    out = count_predicted(with_n)
    assert list(out["within at the same N"]) == [True, True, True]     # the flow's 2.1 is 1.6 at its own N
    assert list(out["within"]) == [True, True, False]


def test_count_predicted_says_which_filters_are_within_in_every_repeat():
    """With the ratio's range over the benchmark's repeats in the table, a filter is within its
    count in every repeat, over it in every repeat, or at the edge (neither)."""
    from pfrepro.cost import SAME_MODEL_RATIO, SAME_N_RATIO, count_predicted, repeat_range_columns

    low, high = repeat_range_columns(SAME_MODEL_RATIO)
    table = _bench_table().assign(**{low: [0.9, 1.8, 2.05, 8.0, 0.9], high: [1.1, 2.1, 2.3, 10.0, 1.1]})
    out = count_predicted(table)
    assert list(out["within"]) == [True, True, False]               # the medians
    assert list(out["within in every repeat"]) == [True, False, False]   # 1.9 reached 2.1 in a repeat
    assert list(out["over in every repeat"]) == [False, False, True]
    assert "within in every repeat at the same N" not in out
    lo_n, hi_n = repeat_range_columns(SAME_N_RATIO)
    table = table.assign(**{SAME_N_RATIO: [1.0, 1.9, 1.6, 9.0, 1.0], lo_n: [0.9, 1.85, 1.5, 8.0, 0.9],
                            hi_n: [1.1, 1.95, 1.7, 10.0, 1.1]})
    out = count_predicted(table)
    assert list(out["within in every repeat at the same N"]) == [True, True, True]
    assert list(out["over in every repeat at the same N"]) == [False, False, False]
    assert list(count_predicted(table, limit=2.2)["within in every repeat"]) == [True, True, False]


def test_count_predicted_refuses_bad_tables():
    from pfrepro.cost import SAME_MODEL_RATIO, count_predicted

    with pytest.raises(ValueError, match="no column"):
        count_predicted(_bench_table().drop(columns=[SAME_MODEL_RATIO]))
    bad = _bench_table()
    bad.loc["flow", SAME_MODEL_RATIO] = np.nan
    with pytest.raises(ValueError, match="without a same-model ratio.*flow"):
        count_predicted(bad)
    for limit in (0, -1.0, float("nan"), "2"):
        with pytest.raises(ValueError, match="limit"):
            count_predicted(_bench_table(), limit=limit)


def test_the_book_bench_table_marks_its_particle_filters():
    """The saved table (benchmarks/bench_all.py --book) says which rows are particle filters:
    the 28 of the package, not the Kalman family, not the IMM scenario's reference PF."""
    from pathlib import Path

    from pfrepro.cost import count_predicted

    bench = pd.read_csv(Path(__file__).resolve().parent.parent / "book" / "data" / "bench_all.csv",
                        index_col="filter")
    assert "particle filter" in bench.columns
    pfs = count_predicted(bench)
    assert len(pfs) == 28
    assert not pfs.index.str.contains("CV mode|N = 100").any() and "EKF (BOT)" not in pfs.index
    assert "same N" in pfs and pfs["same N"].notna().all()
    # each round's time is kept: the ratios' range over the rounds says which filters are at the edge
    assert "within in every repeat" in pfs and "over in every repeat at the same N" in pfs


def test_the_book_model_cost_table_has_every_model_of_the_bench():
    """book/data/bench_models.csv (benchmarks/bench_all.py --book): what one evaluation costs per
    model, the growth model first (the unit), each model of the same-model yardstick present."""
    from pathlib import Path

    per_model = pd.read_csv(Path(__file__).resolve().parent.parent / "book" / "data" / "bench_models.csv",
                            index_col="model")
    assert list(per_model["key"]) == ["ung", "ung_ning", "bot", "imm"]
    assert per_model["vs growth model"].iloc[0] == 1.0
    assert (per_model[["transition ns/state", "likelihood ns/state"]] > 0).all().all()
