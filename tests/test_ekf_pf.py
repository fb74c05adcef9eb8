"""Tests for the Li et al. (2012) EKF-vs-PF experiment code (pfrepro.experiments.ekf_pf_li2012)."""
from __future__ import annotations

import numpy as np
import pytest

from pfrepro import claims
from pfrepro.experiments import ekf_pf_li2012 as ex
from pfrepro.filters import BootstrapParticleFilter, ExtendedKalmanFilter, GridFilter
from pfrepro.filters.ekf_variants import PreviousEstimateJacobianEKF
from pfrepro.montecarlo import truth_rng


def _paper_f(which, x, k):
    """Sec 2 of the paper, typed from the text."""
    if which == 1:
        return x / 2 + 25 * x / (1 + x**2) + 8 * np.cos(1.2 * (k - 1))
    return x / 2 + 18 * np.cos(1.2 * (k - 1))


@pytest.mark.parametrize("which", [1, 2])
def test_models_match_paper(which):
    m = ex.make_model(which)
    x = np.linspace(-25, 25, 11)[:, None]
    for k in (1, 2, 7, 60):
        np.testing.assert_allclose(m.f(x, k), _paper_f(which, x, k), rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(m.h(x), x**2 / 20)
    assert m.Q[0, 0] == 10.0 and m.R[0, 0] == 1.0 and m.x0[0] == 0.1
    assert m.m0[0] == 0.1 and m.P0[0, 0] == ex.P0_DEFAULT
    sim = ex.simulate(which, 3, 1)
    assert sim.x.shape == (3, ex.T + 1, 1) and sim.y.shape == (3, ex.T, 1)
    assert np.all(sim.x[:, 0, 0] == 0.1)


@pytest.mark.parametrize("which", [1, 2])
def test_jacobians_match_finite_differences(which):
    err = ex.jacobian_check(ex.make_model(which))
    assert max(err.values()) < 1e-6


@pytest.mark.parametrize("which", [1, 2])
def test_ekf_is_the_papers_eq11(which):
    m = ex.make_model(which)
    sim = m.simulate(ex.T, 5, truth_rng(3))
    ours = ExtendedKalmanFilter(m).filter(sim.y).x
    literal = ex.literal_eq11_ekf(m, sim.y)
    np.testing.assert_allclose(ours, literal, rtol=1e-8, atol=1e-8)


def test_previous_estimate_ekf_matches_circulating_code():
    m = ex.make_model(1)
    sim = m.simulate(30, 3, truth_rng(4))
    got = PreviousEstimateJacobianEKF(m).filter(sim.y).x[..., 0]
    for r in range(3):  # the scalar loop of the widely copied MATLAB demo
        xhat, P = 0.1, ex.P0_DEFAULT
        for k in range(1, 31):
            F = 0.5 + 25 * (1 - xhat**2) / (1 + xhat**2) ** 2
            P = F * P * F + 10.0
            H = xhat / 10
            K = P * H / (H * P * H + 1.0)
            xhat = 0.5 * xhat + 25 * xhat / (1 + xhat**2) + 8 * np.cos(1.2 * (k - 1))
            xhat = xhat + K * (sim.y[r, k - 1, 0] - xhat**2 / 20)
            P = (1 - K * H) * P
            assert got[r, k - 1] == pytest.approx(xhat, rel=1e-9, abs=1e-9)
    assert not np.allclose(got, ExtendedKalmanFilter(m).filter(sim.y).x[..., 0])


@pytest.mark.parametrize("which", [1, 2])
def test_grid_agrees_with_large_n_particle_filter(which):
    """The exact reference and a 200 000-particle PF agree within the PF's Monte Carlo error."""
    m = ex.make_model(which)
    sim = m.simulate(10, 3, truth_rng(10 + which))
    grid = GridFilter(m, bounds=ex.GRID_BOUNDS, n_grid=ex.GRID_N).filter(sim.y)
    assert np.max(np.abs(grid.diagnostics["lost_mass"])) < 1e-9
    pf = BootstrapParticleFilter(m, 200_000, resampling="systematic").filter(sim.y, rng=np.random.default_rng(5))
    var = grid.P[..., 0, 0]
    mc_sd = np.sqrt(var / pf.diagnostics["ess"])
    diff = np.abs(pf.x[..., 0] - grid.x[..., 0])
    assert np.all(diff <= 6 * mc_sd + 1e-3), float(np.max(diff / (mc_sd + 1e-12)))


def test_run_checks_grid_mass_and_shapes():
    res = ex.run(1, 4, 7, ("EKF", "UKF", "PF", "Exact"), n_particles=200)
    for name in ("EKF", "UKF", "PF", "Exact"):
        assert res.results[name].x.shape == (4, ex.T, 1)
    # the exact posterior mean has the lowest MSE in expectation; on 4 runs check it beats the EKF
    assert res.rmse("Exact").mean() < res.rmse("EKF").mean()


def test_bad_inputs_raise():
    with pytest.raises(ValueError, match="models 1 and 2"):
        ex.make_model(3)
    with pytest.raises(ValueError, match="P0"):
        ex.make_model(1, P0=-1.0)
    with pytest.raises(ValueError, match="unknown filter"):
        ex.make_filters(ex.make_model(1), ("EKF", "KF"))
    with pytest.raises(ValueError, match="unknown resampling"):
        ex.make_filters(ex.make_model(1), ("PF",), resampling="bogus")
    with pytest.raises(ValueError):
        ex.ratio_of_means([1.0, 2.0], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError):
        ex.literal_eq11_ekf(ex.make_model(1), np.zeros((3, 4)))
    with pytest.raises(ValueError):
        ex.run(1, 0, 1)
    with pytest.raises(RuntimeError, match="follow predict"):
        PreviousEstimateJacobianEKF(ex.make_model(1)).update(np.zeros((1, 1)), np.eye(1)[None], np.zeros((1, 1)))


def test_published_table1_is_data():
    t = ex.published_table1()
    assert list(t.index) == ["EKF", "PF"] and list(t.columns) == ["Model 1", "Model 2"]
    assert t.loc["EKF", "Model 1"] == pytest.approx(30.1709)
    assert t.loc["PF", "Model 2"] == pytest.approx(1.0479)


def test_table1_and_statistics_small():
    res = {w: ex.run(w, 6, 11, ("EKF", "PF", "Exact"), n_particles=200) for w in (1, 2)}
    t1 = ex.table1(res)
    assert len(t1) == 4 and set(t1["verdict"]) <= set(claims.VERDICTS)
    st = ex.statistic_readings(res[1], ["EKF", "PF"])
    assert np.all(st.values > 0)
    pt = ex.per_time_rmse(res[2], ["EKF", "PF"])
    assert pt.shape == (ex.T, 2) and pt.index[0] == 1
    g = ex.gap_to(res[1], "PF")
    assert set(g) == {"gap", "se", "relative"}
    eff = ex.resampling_after_estimate_effect(res[1])
    assert 0 < eff["relative_to_mse"] < 0.05


def test_ratio_of_means():
    b = np.array([1.0, 2.0, 3.0, 4.0])
    r, se = ex.ratio_of_means(2 * b, b)
    assert r == pytest.approx(2.0) and se == pytest.approx(0.0, abs=1e-12)
    rng = np.random.default_rng(0)
    a, b = rng.gamma(5, size=4000), rng.gamma(5, size=4000)
    r, se = ex.ratio_of_means(a, b)
    assert abs(r - 1.0) < 4 * se and 0.005 < se < 0.05


def test_eq9_printed_form_is_a_misprint():
    chk = ex.eq9_linearisation_check(ex.make_model(1))
    c = chk["corrected_max_err"].to_numpy()
    assert np.allclose(c[1:] / c[:-1], 0.01, rtol=1e-6)  # error ~ delta^2 (h is quadratic)
    assert chk["printed_max_err"].min() > 1.0


def test_sensitivity_and_cost_small():
    sims = {w: ex.simulate(w, 4, 21) for w in (1, 2)}
    sens = ex.sensitivity(sims, 21, P0_values=(1.0, 2.0), schemes=("multinomial", "systematic"))
    assert len(sens) == 2 * (2 + 2 + 2)
    assert set(sens["verdict_EKF"]) <= set(claims.VERDICTS)
    nn = ex.rmse_and_cost_vs_n(1, sims[1], 21, n_values=(20, 40), repeats=1)
    assert list(nn.index) == [20, 40] and np.all(nn["rmse"] > 0)
    cr = ex.cost_ratios(2, sims[2], include=("EKF", "PF"), repeats=1)
    assert cr.loc["EKF", "single_run_ratio"] == 1.0


def test_cost_ratios_need_the_ekf():
    sim = ex.simulate(1, 2, 5)
    with pytest.raises(ValueError, match="EKF"):
        ex.cost_ratios(1, sim, include=("PF",), repeats=1)
    with pytest.raises(ValueError, match="exact"):
        ex.rmse_and_cost_vs_n(1, sim, 5, n_values=(10,), exact=np.ones(3), repeats=1)


# ------------------------------------------------------------------ free choices, readings, SIS ---
def test_choices_rows():
    from pfrepro.choices import FIXED, READING, SWEEP, choices_table

    by = {c.name: c for c in ex.CHOICES}
    assert by["P0"].status == SWEEP and by["resampling"].status == SWEEP
    assert by["statistic"].status == READING and by["statistic"].value in ex.STATISTICS
    assert by["few"].status == READING and by["ekf_linearisation"].status == FIXED
    assert len(choices_table(ex.CHOICES)) == len(ex.CHOICES)


def test_statistic_readings_and_jackknife():
    res = ex.run(1, 8, 3, ("EKF", "PF"), n_particles=100)
    e = np.sqrt(((res.results["PF"].x - res.x_true) ** 2)[..., 0].mean(axis=1))
    v, se = ex.statistic_reading(res, "PF", "mean_run_rmse")
    assert v == pytest.approx(e.mean()) and se == pytest.approx(e.std(ddof=1) / np.sqrt(8))
    # the jackknife of a mean is the usual standard error
    e2 = ((res.results["PF"].x - res.x_true) ** 2)[..., 0]
    assert ex._jackknife_se([e2], lambda a: np.sqrt(a.mean(axis=1)).mean()) == pytest.approx(se)
    st = ex.statistic_readings(res, ["EKF", "PF"])
    for s_ in ex.STATISTICS:
        v, se = ex.statistic_reading(res, "EKF", s_)
        assert v == pytest.approx(st.loc["EKF", s_]) and se > 0
        r, r_se = ex.ratio_reading(res, "EKF", "PF", s_)
        assert r == pytest.approx(st.loc["EKF", s_] / st.loc["PF", s_]) and r_se > 0
    with pytest.raises(ValueError):
        ex.statistic_reading(res, "PF", "median")


def test_ratio_claims_test_the_papers_words():
    from pfrepro.verdicts import ekf_pf_li2012 as V

    assert V.RATIO_STRONG_MIN == 7.0  # "more than 7 times" (sec 2)
    assert V.ratio_claim_holds(1, 4.2, 0.2) is False and V.ratio_claim_holds(1, 7.7, 0.2) is True
    assert V.ratio_claim_holds(1, 7.1, 0.2) is None
    assert V.ratio_claim_holds(2, 1.11, 0.01) is True and V.ratio_claim_holds(2, 1.5, 0.01) is False


def test_sis_never_resamples_and_degenerates():
    res = ex.run(1, 5, 4, ("SIS", "PF"), n_particles=300)
    sis, pf = res.results["SIS"].diagnostics, res.results["PF"].diagnostics
    assert not sis["resampled"].any() and pf["resampled"].all()
    d = ex.degeneracy(res, n_particles=300)
    t = d["ess_over_time"]
    assert t.shape == (ex.T, 6) and t.index[0] == 1
    assert np.all(t[("SIS", "median")] <= 1.0 + 1e-12) and np.all(t[("SIS", "q10")] <= t[("SIS", "q90")])
    assert d["SIS"]["late"].shape == (5,) and np.all(d["SIS"]["late"] < d["PF"]["late"])
    assert np.all(d["SIS"]["late"] >= 1.0 - 1e-9)  # ESS >= 1 always
    with pytest.raises(ValueError, match="window"):
        ex.late_ess(res, "SIS", window=(0, 10))


def test_sensitivity_with_sis_columns():
    sims = {w: ex.simulate(w, 4, 21) for w in (1, 2)}
    sens = ex.sensitivity(sims, 21, P0_values=(2.0, 5.0), schemes=("multinomial",), sis_runs=3)
    rows = sens[sens["setting"].isin(["P0", "resampling"])]
    assert rows[["SIS_ess", "PF_ess", "ess_gain", "ess_gain_se"]].notna().all().all()
    assert np.allclose(rows["ess_gain"], rows["PF_ess"] - rows["SIS_ess"])
    assert np.all(sens["diff_se"] > 0)


def test_ekf_seed_spread_small():
    sp = ex.ekf_seed_spread(seeds=(1, 2), runs=3)
    assert len(sp) == 2 * 2 * 2 and set(sp["filter"]) == {"EKF", "EKF-prev"}
    one = sp[(sp["model"] == "Model 1") & (sp["seed"] == 2) & (sp["filter"] == "EKF")]["mean"].iloc[0]
    sim = ex.simulate(1, 3, 2)
    ekf = ex.make_filters(ex.make_model(1), ("EKF",))["EKF"]
    assert one == pytest.approx(float(np.sqrt(((ekf.filter(sim.y).x - sim.x[:, 1:]) ** 2).mean(axis=(1, 2))).mean()))


def test_table1_published_text_is_printed():
    assert ex.published_text("EKF", 1) == "30.1709" and ex.published_text("PF", 2) == "1.0479"


def test_new_figures_and_shown_table_small():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pfrepro.figures import ekf_pf_li2012 as F

    sims = {w: ex.simulate(w, 3, 8) for w in (1, 2)}
    sens = ex.sensitivity(sims, 8, P0_values=(2.0,), schemes=("multinomial",), ekf_variants=("EKF",))
    res = {w: ex.run(w, 3, 8, ("EKF", "PF", "SIS"), n_particles=60) for w in (1, 2)}
    for fig in (F.sweep_plot(sens), F.ess_plot({w: ex.degeneracy(res[w], n_particles=60) for w in (1, 2)}, 60)):
        assert len(fig.axes) == 2
        plt.close(fig)
    shown = F.table1_shown(ex.table1(res)).data   # a Styler (no index column)
    assert shown["published"].tolist() == ["30.1709", "3.9459", "1.1281", "1.0479"]


def test_chapter_tables_and_figures_small():
    """The tables and plots the chapter draws from run_all's results (and its timing cells)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pfrepro.figures import ekf_pf_li2012 as F

    sims = {w: ex.simulate(w, 3, 8) for w in (1, 2)}
    res = {w: ex.run(w, 3, 8, ex.FILTERS, sim=sims[w], n_particles=60) for w in (1, 2)}
    assert F.statistic_readings_table(res).data.shape == (4, 6)
    assert F.gap_table(res).data.shape == (6, 6)   # (model, filter) x RMSE, se, exact, gap, gap se, relative
    cnt = {w: ex.cost_evidence(w, sims[w], repeats=1, seed=8) for w in (1, 2)}
    assert list(cnt[1].columns) == ["model evals / step", "count ratio", "time ratio", "time ratio min",
                                    "time ratio max"]
    assert cnt[1]["count ratio"].equals(ex.cost_count_table(1, sims[1], seed=8)["count ratio"])
    assert "count ratio" in F.count_table(cnt).to_html()
    cost = {w: ex.cost_ratios(w, sims[w], include=("EKF", "UKF", "PF"), repeats=1, seed=8) for w in (1, 2)}
    assert F.cost_table(cost).data.shape == (3, 4)
    sens = ex.sensitivity(sims, 8, P0_values=(2.0,), schemes=("multinomial",))
    shown = F.sensitivity_shown(sens)
    assert len(shown) == len(sens) and set(" ".join(shown["verdicts"]).split()) <= set("RQNI–")
    ns = {w: ex.rmse_and_cost_vs_n(w, sims[w], 8, n_values=(20, 40), exact=res[w].rmse("Exact"), repeats=1)
          for w in (1, 2)}
    for fig in (F.seed_spread_plot(ex.ekf_seed_spread(seeds=(1, 2), runs=3)), F.nsweep_plot(ns, res)):
        assert len(fig.axes) in (2, 3)
        plt.close(fig)
