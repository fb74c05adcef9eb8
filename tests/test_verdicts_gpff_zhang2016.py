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
    assert len(ids) == 47 and len(set(ids)) == 47
    assert ids[:3] == ["kb_equivalence", "cwpa_gauss_equal", "cwpa_mixture_gpff_better"]
    assert ids[3:11] == [f"t1_mse_{n}" for n in E.UNG_LABELS]
    assert ids[11:16] == ["ung_gpff_beats_ekf_ukf", "ung_pf_most_accurate", "ung_gpff_more_stable",
                          "ung_gpff_cost_growth", "ung_gpff_cheaper_than_pf_1000"]
    assert ids[16:40] == [f"t2_{c}_{f}" for f in E.BOT_LABELS for c in E.COMPONENTS]
    assert ids[40:] == ["bot_gpff_lowest", "bot_pf4000_worse", "bot_ukf_better_than_ekf", "bot_pf_y_error",
                        "bot_gpff_stable", "bot_gpff_converges_faster", "bot_time_gpff_vs_pf500"]
    assert set(V.MAIN_CLAIMS) <= set(ids) and 3 <= len(V.MAIN_CLAIMS) <= 6
    # the paper has no number decided by unpublished settings: nothing is 'not checkable'
    assert not any(c.not_checkable for c in reg.claims)


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
    assert c.diff == 0 and c.diff_se == 0 and set(c.readings.values()) == {None}
    assert c.verdict == "inconclusive"
    assert "it was no better than the KF" in V.takeaway(reg, res)


def test_cwpa_mixture_kf_better_everywhere_is_not_reproduced(res):
    _gpff_cwpa_like_kf(res, "mixture", c=0.5)     # GPFF worse than KF in every run, every integrator
    res.cwpa_r_sweep["GPFF − KF"] = 1.0
    res.cwpa_r_sweep["SE of difference"] = 0.1
    reg, cl = decide(res)
    assert cl["cwpa_mixture_gpff_better"].verdict == "not reproduced"
    assert "it was worse than the KF" in V.takeaway(reg, res)


# ---------------------------------------------------------------------------- sec 5.2 (Table 1)
def test_table1_number_under_readings(res):
    """t1_mse_UKF: matched under every ut reading -> reproduced; one reading off -> inconclusive;
    all off -> not reproduced (MSE of x_true + c is c**2 in every run)."""
    ung, rd = res.ung, res.ung_readings
    target = 51.49                                      # the printed UKF mean MSE
    set_x(ung, ["UKF"], offset(math.sqrt(target)))
    set_x(rd, labels(rd, "UKF |"), offset(math.sqrt(target)))
    assert decide(res)[1]["t1_mse_UKF"].verdict == "reproduced"
    set_x(rd, ["UKF | ut=alpha=1e-3"], offset(math.sqrt(2 * target)))
    c = decide(res)[1]["t1_mse_UKF"]
    assert c.verdict == "inconclusive" and c.reading_values["ut=alpha=1e-3"][0] == pytest.approx(2 * target)
    set_x(ung, ["UKF"], offset(math.sqrt(2 * target)))
    set_x(rd, labels(rd, "UKF |"), offset(math.sqrt(2 * target)))
    assert decide(res)[1]["t1_mse_UKF"].verdict == "not reproduced"


def test_ung_orderings_with_known_errors(res):
    ung, rd = res.ung, res.ung_readings
    set_x(ung, ["EKF", "UKF"], offset(3.0))                     # MSE 9
    set_x(rd, labels(rd, "UKF |"), offset(3.0))
    set_x(ung, labels(ung, "GPFF("), offset(2.0))               # MSE 4
    set_x(rd, labels(rd, "GPFF("), offset(2.0))
    set_x(ung, labels(ung, "PF("), offset(1.0))                 # MSE 1
    set_x(rd, labels(rd, "PF("), offset(1.0))
    cl = decide(res)[1]
    for cid in ("ung_gpff_beats_ekf_ukf", "ung_pf_most_accurate"):
        assert cl[cid].verdict == "reproduced" and all(cl[cid].readings.values())
    # same spread everywhere (constant errors): the stability ordering is a tie
    assert cl["ung_gpff_more_stable"].verdict == "inconclusive"
    # GPFF worse than the UKF under one ut reading only: the readings disagree
    set_x(rd, ["GPFF(500) | ut=alpha=0.5"], offset(4.0))
    c = decide(res)[1]["ung_gpff_beats_ekf_ukf"]
    assert c.readings["ut=alpha=0.5"] is False and c.readings["ut=alpha=1"] is True
    assert c.verdict == "inconclusive"


def test_ung_a_diverged_gpff_run_fails_stability(res):
    ung, rd = res.ung, res.ung_readings
    for mc in (ung, rd):
        for n in labels(mc, "GPFF("):
            x = mc.results[n].x.copy()
            x[0, 7] = np.nan
            mc.results[n] = dataclasses.replace(mc.results[n], x=x)
    c = decide(res)[1]["ung_gpff_more_stable"]
    assert (c.diff, c.diff_se) == (-1.0, 0.0) and set(c.readings.values()) == {False}
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
def test_bot_ukf_better_than_ekf_flips_with_the_errors(res):
    bot, rd = res.bot, res.bot_readings
    set_x(bot, ["UKF"], offset(0.5))
    set_x(rd, labels(rd, "UKF |"), offset(0.5))
    set_x(bot, ["EKF"], offset(1.0))
    assert decide(res)[1]["bot_ukf_better_than_ekf"].verdict == "reproduced"
    set_x(rd, ["UKF | ut=alpha=0.5"], offset(2.0))
    c = decide(res)[1]["bot_ukf_better_than_ekf"]
    assert c.readings == {"ut=alpha=1": True, "ut=alpha=0.5": False, "ut=alpha=1e-3": True}
    assert c.verdict == "inconclusive"


def test_bot_gpff_lowest_and_the_median_reading(res):
    bot, rd = res.bot, res.bot_readings
    everyone = [n for n in E.BOT_LABELS if n != "GPFF(100)"]
    set_x(bot, everyone, offset(1.0))
    set_x(rd, [n for n in rd.results if not n.startswith("GPFF(100)")], offset(1.0))
    set_x(bot, ["GPFF(100)", "GPFF(100) eq43"], offset(0.5))
    set_x(rd, labels(rd, "GPFF(100)"), offset(0.5))
    c = decide(res)[1]["bot_gpff_lowest"]
    assert c.verdict == "reproduced" and set(c.readings) >= {"statistic=mean", "statistic=median"}
    # the eq (43) field worse than the PF: that reading fails, the verdict is inconclusive
    set_x(bot, ["GPFF(100) eq43"], offset(2.0))
    c = decide(res)[1]["bot_gpff_lowest"]
    assert c.readings["field=eq43"] is False and c.readings["field=eq41"] is True
    assert c.verdict == "inconclusive"


def test_bot_a_diverged_gpff_run_fails_stability(res):
    for mc in (res.bot, res.bot_readings):
        for n in labels(mc, "GPFF(100)"):
            x = mc.results[n].x.copy()
            x[1, 3] = np.nan
            mc.results[n] = dataclasses.replace(mc.results[n], x=x)
    c = decide(res)[1]["bot_gpff_stable"]
    assert (c.diff, c.diff_se) == (-1.0, 0.0) and set(c.readings.values()) == {False}
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
    assert c.diff == 45.0 and c.diff_se == 0.0 and c.verdict == "reproduced"
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
    assert p["n_claims"] == 47 and p["runs"] == 3 and p["timing_repeats"] == 1
    assert sum(p[f"n_{v}"] for v in ("reproduced", "qualitatively_reproduced", "not_reproduced", "not_checkable",
                                     "inconclusive")) == 47


def test_prose_words_follow_the_numbers(res):
    bot, rd = res.bot, res.bot_readings
    set_x(bot, [n for n in E.BOT_LABELS if n != "GPFF(100)"], offset(1.0))
    set_x(bot, ["GPFF(100)"], offset(0.5))
    p = V.prose(decide(res)[0], res)
    assert p["bot_gpff_best_count"] == 4 and p["bot_gpff_notbest"] == "in all of them"
    set_x(bot, ["UKF"], offset(0.25))
    p = V.prose(decide(res)[0], res)
    assert p["bot_gpff_best_count"] == 0 and p["bot_gpff_notbest"].startswith("not in *x* (best: UKF)")
