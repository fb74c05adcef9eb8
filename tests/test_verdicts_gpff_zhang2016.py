"""The deciding code of the GPFF chapter (pfrepro.verdicts.gpff_zhang2016) on fixtures with known outcomes.

The fixtures are the results of ``run_all(runs=3)`` (three runs, so that one diverged run still
leaves a paired difference over two) with some filters' estimates replaced by
hand-made ones (an estimate ``x_true + c`` has MSE exactly ``c**2`` in every run), so that each
test knows what the rule must decide. Counts are deterministic (run 1 only), so the cost
claims decide as at the paper's scale.
"""
from __future__ import annotations

import copy
import dataclasses
import math
import re
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest

from pfrepro import published
from pfrepro.choices import DESIGN, FIXED
from pfrepro.claims import ClaimsRegistry
from pfrepro.experiments import gpff_zhang2016 as E
from pfrepro.figures import gpff_zhang2016 as F
from pfrepro.papers import get_paper
from pfrepro.prose import Md
from pfrepro.verdicts import gpff_zhang2016 as V

CHAPTER = Path(__file__).resolve().parents[1] / "book" / "20_gpff.md"


@pytest.fixture(scope="module")
def base():
    return E.run_all(runs=3, seeds=1)


@pytest.fixture
def res(base):
    return copy.deepcopy(base)


def decide(results):
    reg = ClaimsRegistry(E.PAPER, choices=E.CHOICES)
    V.record_claims(reg, results)
    return reg, {c.claim_id: c for c in reg.claims}


def set_x(mc, names, fn):
    """Replace the estimates of every filter in ``names`` of MonteCarloResult ``mc`` by ``fn(x_true)``."""
    for n in names:
        mc.results[n] = dataclasses.replace(mc.results[n], x=fn(mc.x_true.copy()))


def offset(c):
    return lambda xt: xt + c


def labels(mc, prefix):
    return [n for n in mc.results if n.startswith(prefix)]


# ---------------------------------------------------------------------------- the claims, in order
def test_claim_ids_and_order_are_the_chapters(base):
    reg, cl = decide(base)
    ids = [c.claim_id for c in reg.claims]
    assert len(ids) == 54 and len(set(ids)) == 54
    assert ids[:3] == ["kb_equivalence", "cwpa_gauss_equal", "cwpa_mixture_gpff_better"]
    assert ids[3:11] == [f"t1_mse_{n}" for n in E.UNG_LABELS]
    assert ids[11:16] == ["ung_gpff_beats_ekf_ukf", "ung_pf_most_accurate", "ung_gpff_more_stable",
                          "ung_gpff_cost_growth", "ung_gpff_cheaper_than_pf_1000"]
    assert ids[16:40] == [f"t2_{c}_{f}" for f in E.BOT_LABELS for c in E.COMPONENTS]
    assert ids[40:] == ["bot_gpff_lowest", "bot_pf4000_worse", "bot_ukf_better_than_ekf", "bot_pf_y_error",
                        "bot_gpff_stable", "bot_pf_worse_than_ekf", "bot_pf_start_sensitive",
                        "bot_ekf_ukf_gpff_converge", "bot_gpff_converges_faster", "bot_time_gpff_vs_pf500",
                        "intro_fewer_particles", "moments_every_step_costly", "eq9_intractable", "intro_background"]
    assert set(V.MAIN_CLAIMS) <= set(ids) and 3 <= len(V.MAIN_CLAIMS) <= 6
    # only the two statements the paper quotes from the literature and tests nowhere are 'not checkable'
    assert [c.claim_id for c in reg.claims if c.not_checkable] == ["eq9_intractable", "intro_background"]
    # every ordering is judged per reading on its paired difference against a printed effect or a margin
    for c in reg.claims:
        if c.diff is not None and c.claim_id != "cwpa_gauss_equal":
            assert c.reading_diffs and (c.effect == 1.0 or c.margin) and c.runs == 3 and not c.readings, c.claim_id


def test_seeds_change_the_numbers_not_the_claims(base):
    steps = []
    other = E.run_all(runs=3, seeds=2, steps=steps.append)
    assert len(steps) == F.N_STEPS      # the command line's progress bar
    assert base.settings["seeds"] != other.settings["seeds"] and other.settings["runs"] == 3
    a, b = decide(base)[0], decide(other)[0]
    assert [c.claim_id for c in a.claims] == [c.claim_id for c in b.claims]
    ra = {c.claim_id: c.reproduced for c in a.claims}
    rb = {c.claim_id: c.reproduced for c in b.claims}
    for cid in ("t1_mse_EKF", "t1_mse_GPFF(100)", "t2_y_PF(500)", "t2_x_GPFF(100)"):
        assert ra[cid] != rb[cid]
    assert not np.array_equal(base.checks["equivalence"].to_numpy(), other.checks["equivalence"].to_numpy())
    assert not np.array_equal(base.references.pcrb_prior, other.references.pcrb_prior)


def test_command_line_tables_and_figures(base):
    reg = decide(base)[0]
    assert get_paper("gpff").verdicts_module is V and get_paper("gpff").figures_module.N_STEPS == 6
    tabs, figs = F.tables(base), F.figures(base)
    assert tuple(tabs) == F.TABLES and tuple(figs) == F.FIGURES
    plt.close("all")
    assert tabs["Table 1"].loc["EKF", "MSE mean"] == pytest.approx(
        next(c for c in reg.claims if c.claim_id == "t1_mse_EKF").reproduced)


# ---------------------------------------------------------------------------- sec 3.2
def test_kb_equivalence_fails_above_the_solver_and_fd_tolerances(res):
    assert decide(res)[1]["kb_equivalence"].verdict == "reproduced"
    eqv = res.checks["equivalence"]
    eqv.iloc[0, 2] = 10 * V.KB_TOL_SOLVER
    assert decide(res)[1]["kb_equivalence"].verdict == "not reproduced"
    eqv.iloc[0, 2] = 0.0
    res.checks["interior"].iloc[0, 0] = 10 * V.KB_TOL_FD
    assert decide(res)[1]["kb_equivalence"].verdict == "not reproduced"


# ---------------------------------------------------------------------------- sec 5.1
def _gpff_cwpa_like_kf(res, noise, c=0.0):
    mc, rd = res.cwpa[noise], res.cwpa_readings[noise]
    kf = mc.results["KF"].x
    mc.results["GPFF"] = dataclasses.replace(mc.results["GPFF"], x=kf + c)
    for n in rd.results:
        rd.results[n] = dataclasses.replace(rd.results[n], x=kf + c)
    if noise == "mixture":
        for m2 in res.cwpa_r2.values():
            m2.results["GPFF"] = dataclasses.replace(m2.results["GPFF"], x=m2.results["KF"].x + c)


def test_cwpa_equality_holds_then_one_integrator_flips_it(res):
    _gpff_cwpa_like_kf(res, "gaussian")
    c = decide(res)[1]["cwpa_gauss_equal"]
    assert c.verdict == "reproduced" and c.readings == {f"integrator={m}": True for m in E.INTEGRATORS}
    p = V.prose(decide(res)[0], res)
    assert p["cwpa_equiv_word"] == "equivalent within the margin" and p["cwpa_g_word"] == "not significant"
    rd = res.cwpa_readings["gaussian"]
    rd.results["GPFF | integrator=midpoint"] = dataclasses.replace(
        rd.results["GPFF | integrator=midpoint"], x=res.cwpa["gaussian"].x_true + 3.0)
    c = decide(res)[1]["cwpa_gauss_equal"]
    assert c.readings["integrator=midpoint"] is False and c.readings["integrator=euler"] is True
    assert c.verdict == "inconclusive"
    res.cwpa["gaussian"].results["GPFF"] = dataclasses.replace(res.cwpa["gaussian"].results["GPFF"],
                                                               x=res.cwpa["gaussian"].x_true + 3.0)
    p = V.prose(decide(res)[0], res)
    assert p["cwpa_equiv_word"] == "outside the margin (not equivalent)" and p["cwpa_g_word"] == "GPFF *worse*"
    assert isinstance(p["cwpa_equiv_word"], Md)


def test_cwpa_mixture_tie_is_inconclusive(res):
    _gpff_cwpa_like_kf(res, "mixture")
    res.cwpa_r_sweep["GPFF − KF"] = 0.0
    res.cwpa_r_sweep["SE of difference"] = 0.0
    reg, cl = decide(res)
    c = cl["cwpa_mixture_gpff_better"]
    assert c.diff == 0 and c.diff_se == 0 and {tuple(v[:2]) for v in c.reading_diffs.values()} == {(0.0, 0.0)}
    assert set(c.reading_diffs) >= {"r2_symmetric=0.003", "r2_symmetric=0.005", "r2_symmetric=0.001"}
    assert c.verdict == "inconclusive" and c.cause == "tie within the stated margin"
    assert "it was no better than the KF" in V.takeaway(reg, res)


def test_cwpa_mixture_kf_better_everywhere_is_not_reproduced(res):
    _gpff_cwpa_like_kf(res, "mixture", c=0.5)     # GPFF worse than KF in every run, every integrator
    res.cwpa_r_sweep["GPFF − KF"] = 1.0
    res.cwpa_r_sweep["SE of difference"] = 0.1
    reg, cl = decide(res)
    assert cl["cwpa_mixture_gpff_better"].verdict == "not reproduced"
    assert "it was worse than the KF" in V.takeaway(reg, res)
    # better than the KF under one reading of R2 only: the claim depends on the reading
    m2 = res.cwpa_r2["0.005"]
    m2.results["GPFF"] = dataclasses.replace(m2.results["GPFF"], x=m2.x_true)
    c = decide(res)[1]["cwpa_mixture_gpff_better"]
    assert c.verdict == "inconclusive" and c.cause == "depends on the reading"
    assert c.judgement.under("holds") == ["r2_symmetric=0.005"]


# ---------------------------------------------------------------------------- sec 5.2 (Table 1)
def test_table1_number_under_readings(res):
    """t1_mse_UKF: matched under every ut reading -> reproduced; one reading off -> inconclusive;
    all off -> not reproduced (MSE of x_true + c is c**2 in every run)."""
    ung, rd = res.ung, res.ung_readings
    target = 51.49                                      # the printed UKF mean MSE
    set_x(ung, ["UKF"], offset(math.sqrt(target)))
    set_x(rd, labels(rd, "UKF |"), offset(math.sqrt(target)))
    assert decide(res)[1]["t1_mse_UKF"].verdict == "reproduced"
    # the UT setting Table 1 itself excludes is shown, not counted
    set_x(rd, ["UKF | ut=alpha=1e-3"], offset(math.sqrt(2 * target)))
    c = decide(res)[1]["t1_mse_UKF"]
    assert c.verdict == "reproduced" and c.reading_values["ut=alpha=1e-3"][0] == pytest.approx(2 * target)
    assert "l.370" in c.excluded["ut=alpha=1e-3"] and "51.49" in c.excluded["ut=alpha=1e-3"]
    assert "(excluded)" in V.reading_table(decide(res)[0]).loc["t1_mse_UKF", "ut=alpha=1e-3"]
    set_x(rd, ["UKF | ut=alpha=0.5"], offset(math.sqrt(2 * target)))
    c = decide(res)[1]["t1_mse_UKF"]
    assert c.verdict == "inconclusive" and c.cause == "depends on the reading"
    set_x(ung, ["UKF"], offset(math.sqrt(2 * target)))
    set_x(rd, labels(rd, "UKF |"), offset(math.sqrt(2 * target)))
    assert decide(res)[1]["t1_mse_UKF"].verdict == "not reproduced"


def _printed_ung(res, scale=1.0, rows=None):
    """Every UNG estimate (table rows and their readings) off by a constant whose MSE is ``scale`` times
    the row's printed Table 1 mean (``rows``: only those)."""
    pub = published.table(E.PAPER, "Table 1")["MSE mean"]
    for mc in (res.ung, res.ung_readings):
        for n in mc.results:
            base = n.split(" |")[0]
            if base in pub.index and (rows is None or base in rows):
                set_x(mc, [n], offset(math.sqrt(scale * pub[base])))


def test_ung_orderings_against_the_printed_effects(res):
    _printed_ung(res)                                    # every row exactly at its printed mean
    cl = decide(res)[1]
    for cid in ("ung_gpff_beats_ekf_ukf", "ung_pf_most_accurate"):
        c = cl[cid]
        assert c.effect == 1.0 and c.diff == pytest.approx(1.0) and c.verdict == "reproduced", cid
        assert set(c.excluded) == {"ut=alpha=1e-3"}
    # the GPFF rows halfway to the UKF: the direction holds, the printed size does not
    pub = published.table(E.PAPER, "Table 1")["MSE mean"]
    for mc in (res.ung, res.ung_readings):
        for n in mc.results:
            if n.startswith("GPFF(") and n.split(" |")[0] in pub.index:
                g = pub[n.split(" |")[0]]
                set_x(mc, [n], offset(math.sqrt(g + 0.5 * (pub["UKF"] - g))))
    c = decide(res)[1]["ung_gpff_beats_ekf_ukf"]
    assert c.verdict == "qualitatively reproduced" and 0.4 < c.diff < 0.6
    # constant errors: equal spreads, the printed stability effect excluded and the direction not shown
    assert decide(res)[1]["ung_gpff_more_stable"].verdict == "not reproduced"
    # GPFF worse than the UKF under one admissible ut reading: the claim depends on the reading ...
    set_x(res.ung_readings, ["GPFF(500) | ut=alpha=0.5"], offset(math.sqrt(2 * pub["UKF"])))
    c = decide(res)[1]["ung_gpff_beats_ekf_ukf"]
    assert c.verdict == "inconclusive" and c.cause == "depends on the reading"
    assert c.judgement.under("fails") == ["ut=alpha=0.5"]
    # ... under the excluded one, it does not count
    set_x(res.ung_readings, ["GPFF(500) | ut=alpha=0.5"], offset(math.sqrt(pub["GPFF(500)"])))
    set_x(res.ung_readings, ["GPFF(500) | ut=alpha=1e-3"], offset(math.sqrt(2 * pub["UKF"])))
    c = decide(res)[1]["ung_gpff_beats_ekf_ukf"]
    assert c.verdict == "qualitatively reproduced" and "ut=alpha=1e-3" not in [r for r, _, _ in c.judgement.per_reading]


def test_worst_pair_decides_and_orders_causes():
    # one pair attains its printed size, the other shows the direction only: the weaker decides
    assert V.worst_pair([(2.0, 0.1, 2.0), (1.0, 0.1, 4.0)], effect=1.0) == pytest.approx((0.25, 0.025))
    # a reversed pair beats an undecided one to the verdict
    assert V.worst_pair([(0.0, 1.0, 1.0), (-5.0, 1.0, 1.0)], effect=1.0) == (-5.0, 1.0)
    # a tie within the margin is worse than too few runs
    d, s = V.worst_pair([(0.0, 0.01, 1.0), (0.3, 1.0, 1.0)], margin=0.1)
    assert (d, s) == (0.0, 0.01)
    with pytest.raises(ValueError):
        V.worst_pair([], effect=1.0)


def test_ung_a_diverged_gpff_run_fails_stability(res):
    ung, rd = res.ung, res.ung_readings
    for mc in (ung, rd):
        for n in labels(mc, "GPFF("):
            x = mc.results[n].x.copy()
            x[0, 7] = np.nan
            mc.results[n] = dataclasses.replace(mc.results[n], x=x)
    c = decide(res)[1]["ung_gpff_more_stable"]
    assert (c.diff, c.diff_se) == (-1.0, 0.0) and {tuple(v[:2]) for v in c.reading_diffs.values()} == {(-1.0, 0.0)}
    assert c.verdict == "not reproduced"


def test_ung_cost_claims_on_counts(res):
    cl = decide(res)[1]
    # the counts of run 1 (deterministic): cheaper in model evaluations, not as printed
    c = cl["ung_gpff_cheaper_than_pf_1000"]
    assert c.verdict == "inconclusive"
    assert all(v for k, v in c.readings.items() if k.startswith("cost_basis=model evaluations"))
    assert not any(v for k, v in c.readings.items() if k.startswith("cost_basis=as printed"))
    cnt = res.ung_counts
    for col in V.COST_BASES.values():
        cnt.loc["GPFF(100)", col], cnt.loc["GPFF(1000)", col] = 10.0, 40.0
        for sch in E.PF_SCHEMES:
            cnt.loc[V._pf_row(100, sch), col], cnt.loc[V._pf_row(1000, sch), col] = 10.0, 50.0
    cl = decide(res)[1]
    assert cl["ung_gpff_cheaper_than_pf_1000"].verdict == "reproduced"
    # growth 4 against the PF's 5: below (1 - margin) x 5 = 4.5 -> grows more slowly
    assert cl["ung_gpff_cost_growth"].verdict == "reproduced"
    for col in V.COST_BASES.values():
        cnt.loc["GPFF(1000)", col] = 47.0                  # 4.7: inside the margin -> alike
    cl = decide(res)[1]
    assert cl["ung_gpff_cost_growth"].verdict == "not reproduced"
    assert cl["ung_gpff_cheaper_than_pf_1000"].verdict == "reproduced"


# ---------------------------------------------------------------------------- sec 5.3 (Table 2)
def _pub2(f):
    """The printed Table 2 means of row ``f`` in state order (x, y, xdot, ydot)."""
    t = published.table(E.PAPER, "Table 2")
    return np.array([t.loc[f"{lab} mean", f] for lab in ("x", "xdot", "y", "ydot")])   # printed rows 2-3 swapped


def at_printed(f, scale=1.0):
    """An estimate whose per-component MSE is ``scale`` times row ``f``'s printed Table 2 mean."""
    return offset(np.sqrt(scale * _pub2(f)))


def test_bot_ukf_better_than_ekf_against_the_printed_effect(res):
    bot, rd = res.bot, res.bot_readings
    set_x(bot, ["UKF"], at_printed("UKF"))
    set_x(rd, labels(rd, "UKF |"), at_printed("UKF"))
    set_x(bot, ["EKF"], at_printed("EKF"))
    c = decide(res)[1]["bot_ukf_better_than_ekf"]
    assert c.verdict == "reproduced" and c.diff == pytest.approx(1.0)
    # the UKF as bad as the EKF under the excluded UT setting: shown, not counted
    set_x(rd, ["UKF | ut=alpha=1e-3"], at_printed("EKF", 2.0))
    c = decide(res)[1]["bot_ukf_better_than_ekf"]
    assert c.verdict == "reproduced" and set(c.excluded) == {"ut=alpha=1e-3"}
    set_x(rd, ["UKF | ut=alpha=0.5"], at_printed("EKF", 2.0))
    c = decide(res)[1]["bot_ukf_better_than_ekf"]
    assert c.verdict == "inconclusive" and c.cause == "depends on the reading"
    assert c.judgement.under("fails") == ["ut=alpha=0.5"] and c.judgement.under("holds") == ["ut=alpha=1"]


def test_bot_gpff_lowest_and_the_median_reading(res):
    bot, rd = res.bot, res.bot_readings
    everyone = [n for n in E.BOT_LABELS if n != "GPFF(100)"]
    set_x(bot, everyone, offset(1.0))
    set_x(rd, [n for n in rd.results if not n.startswith("GPFF(100)")], offset(1.0))
    set_x(bot, ["GPFF(100)", "GPFF(100) eq43"], offset(0.5))
    set_x(rd, labels(rd, "GPFF(100)"), offset(0.5))
    c = decide(res)[1]["bot_gpff_lowest"]
    # lower everywhere, but not by the printed margins (e.g. 0.006 in xdot against our 0.75)
    assert c.verdict == "qualitatively reproduced" and set(c.reading_diffs) >= {"statistic=mean", "statistic=median"}
    # the eq (43) field worse than the PF: that reading fails, the claim depends on the reading
    set_x(bot, ["GPFF(100) eq43"], offset(2.0))
    c = decide(res)[1]["bot_gpff_lowest"]
    assert c.judgement.under("fails") == ["field=eq43"] and "field=eq41" in c.judgement.under("holds")
    assert c.verdict == "inconclusive" and c.cause == "depends on the reading"


def test_bot_stability_judges_the_orderings_the_paper_prints(base):
    b = V._Bot(base)
    pairs = b.stable_pairs()
    # Table 2 prints GPFF's x spread (0.033) above the EKF's, the UKF's and PF(4000)'s: not claimed there
    assert ("EKF", "x") not in pairs and ("PF(4000)", "x") not in pairs and ("PF(500)", "x") in pairs
    assert len(pairs) == 15


def test_new_bot_claims_with_known_errors(res):
    bot, rd = res.bot, res.bot_readings
    # the PF from the paper's start far worse than from the true x0: the start matters
    set_x(bot, ["PF(500)"], at_printed("PF(500)"))
    set_x(rd, labels(rd, "PF(500) | pf_resampling"), at_printed("PF(500)"))
    set_x(rd, labels(rd, E.PF_START_X0), offset(0.01))
    set_x(bot, ["EKF"], at_printed("EKF"))
    cl = decide(res)[1]
    assert cl["bot_pf_start_sensitive"].verdict == "reproduced" and cl["bot_pf_start_sensitive"].margin == V.MARGIN_REL
    assert cl["bot_pf_worse_than_ekf"].verdict == "reproduced" and cl["bot_pf_worse_than_ekf"].diff == pytest.approx(1.0)
    # the same start: a tie within the margin
    set_x(rd, labels(rd, E.PF_START_X0), at_printed("PF(500)"))
    c = decide(res)[1]["bot_pf_start_sensitive"]
    assert c.verdict == "inconclusive" and c.cause == "tie within the stated margin"
    # EKF, UKF and GPFF exact in position: they converge under every band
    exact = ["EKF", "UKF", "GPFF(100)", "GPFF(100) eq43"]
    set_x(bot, exact, offset(0.0))
    set_x(rd, labels(rd, "UKF |") + labels(rd, "GPFF(100)"), offset(0.0))
    c = decide(res)[1]["bot_ekf_ukf_gpff_converge"]
    assert c.verdict == "reproduced" and c.diff == pytest.approx(1.0)
    # the UKF 3 off in position at the end: the band of 2 (and 1) fails, 4 holds
    set_x(bot, ["UKF"], offset(np.array([3.0, 0.0, 0.0, 0.0])))
    c = decide(res)[1]["bot_ekf_ukf_gpff_converge"]
    assert c.verdict == "inconclusive" and c.cause == "depends on the reading"
    assert c.judgement.under("holds")[0] == "conv_band=4" and "conv_band=2" in c.judgement.under("fails")
    assert np.allclose(V.final_position_error(res, "UKF"), 9.0)


def test_bot_a_diverged_gpff_run_fails_stability(res):
    for mc in (res.bot, res.bot_readings):
        for n in labels(mc, "GPFF(100)"):
            x = mc.results[n].x.copy()
            x[1, 3] = np.nan
            mc.results[n] = dataclasses.replace(mc.results[n], x=x)
    c = decide(res)[1]["bot_gpff_stable"]
    assert (c.diff, c.diff_se) == (-1.0, 0.0) and {tuple(v[:2]) for v in c.reading_diffs.values()} == {(-1.0, 0.0)}
    assert c.verdict == "not reproduced"


def test_bot_convergence_known_steps(res):
    bot, rd = res.bot, res.bot_readings
    T = bot.sim.T

    def late(xt, k=50):
        xt[:, :k, :2] += 10.0          # far off for the first k steps, exact afterwards
        return xt

    set_x(bot, ["EKF", "UKF"], late)
    set_x(rd, labels(rd, "UKF |"), late)
    set_x(bot, ["GPFF(100)", "GPFF(100) eq43"], lambda xt: late(xt, 5))
    set_x(rd, labels(rd, "GPFF(100)"), lambda xt: late(xt, 5))
    assert np.array_equal(V.convergence_steps(res, "EKF", 2.0), [51.0, 51.0, 51.0])
    c = decide(res)[1]["bot_gpff_converges_faster"]
    assert c.diff == 45.0 and c.diff_se == 0.0 and c.verdict == "reproduced" and c.margin == V.CONV_MARGIN
    tab = V.convergence_table(res)
    assert tab.loc["GPFF(100)", "median convergence step"] == 6.0 and tab.loc["EKF", "runs never within the band"] == 0
    set_x(bot, ["EKF"], lambda xt: late(xt, T))            # never within the band: step T + 1
    assert V.convergence_table(res).loc["EKF", "runs never within the band"] == 3


def test_bot_cost_reading_of_the_field(res):
    c = decide(res)[1]["bot_time_gpff_vs_pf500"]
    # eq (41) evaluates h at every particle in every flow step: dearer than PF(500); eq (43) is
    # cheaper in model evaluations only (deterministic counts of run 1)
    assert c.verdict == "inconclusive"
    assert not any(v for k, v in c.readings.items() if "field=eq41" in k)
    cnt = res.bot_counts
    for col in V.COST_BASES.values():
        cnt.loc["GPFF(100)", col] = cnt.loc["GPFF(100) | field=eq43", col] = 1.0
    assert decide(res)[1]["bot_time_gpff_vs_pf500"].verdict == "reproduced"


# ---------------------------------------------------------------------------- findings and prose
def _fake(verdicts, mix_diff=(0.0, 0.0)):
    """A registry with the claims the takeaway reads, each with the given verdict."""
    reg = ClaimsRegistry(E.PAPER)
    how = {"reproduced": dict(qualitative=True), "not reproduced": dict(qualitative=False),
           "inconclusive": dict(readings={"a": True, "b": False})}
    for cid in ("kb_equivalence", "ung_gpff_beats_ekf_ukf", "ung_pf_most_accurate", "bot_gpff_lowest",
                "ung_gpff_cheaper_than_pf_1000", "bot_time_gpff_vs_pf500"):
        reg.add(cid, cid, **how[verdicts.get(cid, "reproduced")])
    mix = verdicts.get("cwpa_mixture_gpff_better", "reproduced")
    reg.add("cwpa_mixture_gpff_better", "mix", diff=mix_diff[0], diff_se=mix_diff[1],
            readings={"reproduced": {"a": True}, "not reproduced": {"a": False},
                      "inconclusive": {"a": True, "b": False}}[mix])
    return reg


def test_takeaway_branches(base):
    t = V.takeaway(_fake({}), base)
    assert "yet it beat the KF" in t and ", though a PF was more accurate" in t
    assert "it was the most accurate filter on bearings-only tracking" in t and "it cost less than a PF" in t
    t = V.takeaway(_fake({"cwpa_mixture_gpff_better": "inconclusive", "ung_pf_most_accurate": "not reproduced",
                          "bot_gpff_lowest": "not reproduced", "ung_gpff_cheaper_than_pf_1000": "not reproduced",
                          "bot_time_gpff_vs_pf500": "not reproduced"}, mix_diff=(1.0, 0.1)), base)
    assert "use the KF" in t and "beat the KF under some readings only" in t and "though a PF" not in t
    assert "was not the most accurate" in t and "it did not cost less than a PF" in t
    t = V.takeaway(_fake({"kb_equivalence": "not reproduced", "ung_gpff_beats_ekf_ukf": "inconclusive",
                          "bot_gpff_lowest": "inconclusive", "bot_time_gpff_vs_pf500": "inconclusive"}), base)
    assert "second look" in t and "depends on the reading" in t and "not clearly" in t
    assert "depends on what is counted" in t


def test_prose_covers_every_glue_key_of_the_chapter(base):
    reg, _ = decide(base)
    p = V.prose(reg, base)
    text = CHAPTER.read_text(encoding="utf-8")
    used = set(re.findall(r"\{glue(?::\w+)?\}`([^`:]+)", text)) | set(re.findall(r"```\{glue\}\s+(\S+)", text))
    glued_in_chapter = {"gpff_findings", "gpff_today_runs", "gpff_today_sentence"}
    assert used - glued_in_chapter <= set(p), sorted(used - glued_in_chapter - set(p))
    # words agree with the verdicts they describe
    t1 = {w: [n for n in E.UNG_LABELS if next(c for c in reg.claims if c.claim_id == f"t1_mse_{n}").verdict == w]
          for w in ("reproduced", "not reproduced", "inconclusive")}
    assert p["t1_ok"] == (", ".join(t1["reproduced"]) or "none") and isinstance(p["t1_ok"], Md)
    assert p["n_claims"] == 54 and p["runs"] == 3 and p["timing_repeats"] == 1
    assert sum(p[f"n_{v}"] for v in ("reproduced", "qualitatively_reproduced", "not_reproduced", "not_checkable",
                                     "inconclusive")) == 54


def test_prose_words_follow_the_numbers(res):
    bot, rd = res.bot, res.bot_readings
    set_x(bot, [n for n in E.BOT_LABELS if n != "GPFF(100)"], offset(1.0))
    set_x(bot, ["GPFF(100)"], offset(0.5))
    p = V.prose(decide(res)[0], res)
    assert p["bot_gpff_best_count"] == 4 and p["bot_gpff_notbest"] == "in all of them"
    set_x(bot, ["UKF"], offset(0.25))
    p = V.prose(decide(res)[0], res)
    assert p["bot_gpff_best_count"] == 0 and p["bot_gpff_notbest"].startswith("not in *x* (best: UKF)")


# ---------------------------------------------------------------------------- issue 31: plans, items, digits
def test_power_plans_and_their_assumption_rows(base):
    reg, cl = decide(base)
    plans = V.power_plans(reg)
    sized = [c.claim_id for c in reg.claims if (c.effect or c.margin) and c.diff_se is not None]
    assert list(plans.index) == sized and (plans["runs per reading"] == 3).all()
    c = cl["bot_gpff_lowest"]
    from pfrepro.stats import plan_runs
    assert plans.loc["bot_gpff_lowest", "runs planned"] == plan_runs(c.diff_se * math.sqrt(3), 1.0)
    assert plans["plan met"].tolist() == (plans["runs planned"] <= 3).tolist()
    rows = V.plan_choices(reg)
    assert [r.name for r in rows] == [f"runs_{cid}" for cid in sized] and {r.status for r in rows} == {DESIGN}
    # the chapter's table: the fixed rows cite the paper's line, our own values are design choices
    status = {c.name: c for c in E.CHOICES}
    assert status["r2_symmetric"].status != FIXED and status["mse_std"].status == DESIGN
    assert status["bot_bearing"].status == DESIGN
    assert all("l." in c.source for c in E.CHOICES if c.status == FIXED)


def test_items_table_names_every_item_and_its_verdict(base):
    reg, cl = decide(base)
    items = V.items_table(reg)
    assert len(items) == len(V.ITEMS) == 10
    for (item, line, by), (_, row) in zip(V.ITEMS, items.iterrows()):
        assert row["paper"] == line and row["judged by"].startswith(by)
        if by.startswith("claim "):
            assert row["judged by"].endswith(cl[by.split("claim ", 1)[1]].verdict_text())
    text = CHAPTER.read_text(encoding="utf-8")
    assert "l.203, identity for (37)" in text and "sec 5.1, text (l.337)" in text


def test_new_derivation_checks(base):
    e15, eps = base.checks["eq15"], base.checks["eps_identity"]
    assert e15["(15) left = right"].max() < 1e-10 and e15["(15) right = log h − E log h"].max() < 1e-10
    assert e15["(15) left with (14)'s printed sign (+tr A)"].min() > 0.1
    assert eps["printed: error"].min() > 0.5 and eps["corrected: error"].iloc[-1] < 1e-6
    r = eps["corrected: error / eps²"]
    assert r.max() / r.min() < 1.5                       # O(eps^2)
    cnt = V.moment_cost_counts(4, 2, 100, 20)
    assert cnt["particles at every Δλ"] == 20 * (400 + 1600)
    assert decide(base)[1]["moments_every_step_costly"].verdict == "reproduced"


def test_reading_table_shows_printed_digits(base):
    """The table of which reading the published numbers point to shows the paper's digits (29.00, not 29)."""
    reg, _ = decide(base)
    tab = V.reading_table(reg)
    shown = dict(zip(tab.index, tab["published"]))
    assert shown["t1_mse_GPFF(500)"] == "29.00" and shown["t1_mse_GPFF(1000)"] == "28.50"
    assert shown["t2_ydot_PF(500)"] == "1.280"
    for cid, text in shown.items():
        c = next(c for c in reg.claims if c.claim_id == cid)
        assert text == c.published_text


def test_centred_start_exclusion_cites_the_paper():
    why = V.bot_centred_start_exclusion()
    assert "l.293" in why and "非理想初值" in why and "not a reading" in why


# ---------------------------------------------------------------------------- the page: words, tables, figures
#: a snake_case identifier (a claim id, a choice name) -- what a reader should not have to decode
_ID = re.compile(r"(?<![\w./:@-])[a-z][a-z0-9]*(?:_[a-z0-9]+)+(?![\w(])")


def test_readings_and_choices_in_words():
    assert V.reading_words("pf_resampling=ESS<N/2, field=eq43") == "PF resampling ESS<N/2, flow field eq43"
    assert V.reading_words("cost_basis=as printed") == "cost basis as printed"
    assert V.reading_words("the main reading") == "the main reading"
    assert V.reading_words("ut=alpha=0.5") == "UT parameters alpha=0.5"
    assert V.choice_words("some_new_choice") == "some new choice"
    assert all(not _ID.search(V.choice_words(c.name)) for c in E.CHOICES)


def test_the_pages_tables_name_claims_and_readings_in_words(base):
    """The tables the chapter shows about claims and readings: the claim's text, the readings in words,
    no row numbers, at most 8 columns."""
    reg, cl = decide(base)
    texts = {c.text for c in reg.claims}
    rt = V.reading_table_shown(reg)
    assert list(rt.columns) == ["entry", "published", "ours, under each reading", "verdict"]
    assert set(rt["entry"]) <= texts and len(rt) == len(V.reading_table(reg))
    assert not any(_ID.search(v) for v in rt["ours, under each reading"])
    assert all(v.startswith("main reading: ") for v in rt["ours, under each reading"])
    rd = V.readings_disagree_shown(reg)
    assert set(rd["claim"]) <= texts and rd.shape[1] <= 6
    assert not any(_ID.search(str(v)) for col in rd.columns.drop(["claim", "cause"]) for v in rd[col])
    pp = V.power_plans_shown(reg)
    assert set(pp["claim"]) <= texts and set(pp["plan met"]) <= {"yes", "no"}
    ch = V.choices_shown(list(E.CHOICES) + V.plan_choices(reg), reg)
    assert not any(_ID.search(v) for v in ch["choice"]) and ch.shape[1] <= 8
    assert any(v.startswith("runs for “") for v in ch["choice"])
    it = V.items_shown(reg)
    assert len(it) == len(V.ITEMS) and not any(_ID.search(v) for v in it["judged by"])
    # the claim's verdict, in words, where a claim judges the statement
    k = [i for i, (_, _, by) in enumerate(V.ITEMS) if by == "claim bot_pf_start_sensitive"][0]
    assert it.loc[k, "judged by"].endswith(cl["bot_pf_start_sensitive"].verdict_text())


def test_generated_sentences_name_claims_and_readings_in_words(base, monkeypatch):
    """The plans sentence names an unmet plan's claim by its text and the best reading in words; with
    every plan met it says so (the sentence follows the plans, not a typed count)."""
    reg, cl = decide(base)
    p = V.prose(reg, base)
    plans = V.power_plans(reg)
    unmet = plans[~plans["plan met"]]
    assert len(unmet) > 0          # three runs: plans that ask for more are not met
    s = str(p["plans_sentence"])
    assert s.startswith(f"{len(unmet)} of {len(plans)} plans {'is' if len(unmet) == 1 else 'are'} not met")
    assert all(f"“{cl[cid].text}”" in s for cid in unmet.index) and not any(f"`{cid}`" in s for cid in unmet.index)
    assert not _ID.search(str(p["ptr_best"]).split(" (")[0])
    met = plans.assign(**{"plan met": True, "runs per reading": plans["runs planned"].max()})
    monkeypatch.setattr(V, "power_plans", lambda reg: met)      # every plan met: the other sentence
    p2 = V.prose(reg, base)
    assert str(p2["plans_sentence"]).startswith("Every plan is met")


@pytest.mark.parametrize("name", ["fig1", "fig2", "fig3", "fig4", "fig5", "fig_convergence_dlambda",
                                  "fig_convergence_n", "fig_bot_bound"])
def test_every_figure_is_drawn_for_the_laptop_and_the_phone(base, name):
    """Each figure of the chapter, drawn by :func:`pfrepro.plotting.responsive`: no text below the layout's
    size (10.5 pt laptop, 12 pt phone) and the phone drawing no wider than the phone layout (a legend
    outside the axes wider than the phone would shrink everything)."""
    from pfrepro import plotting

    args = {"fig1": (base.cwpa["gaussian"], base.cwpa["mixture"]), "fig2": (base.cwpa["mixture"],),
            "fig3": (base.ung,), "fig4": (base.bot,), "fig5": (base.bot,),
            "fig_convergence_dlambda": (base.checks["conv_dlambda"],),
            "fig_convergence_n": (base.checks["conv_n"],), "fig_bot_bound": (base,)}[name]
    r = plotting.responsive(getattr(F, name), *args, alt="a figure")
    assert r.desktop_min_pt >= plotting.DESKTOP.min_pt and r.phone_min_pt >= plotting.PHONE.min_pt
    assert int.from_bytes(r.phone_png[16:20], "big") <= plotting.PHONE.width_in * plotting.BOOK_DPI * 1.05
    assert int.from_bytes(r.desktop_png[16:20], "big") <= plotting.DESKTOP.width_in * plotting.BOOK_DPI * 1.05
