"""The deciding code of Li et al. (2012), ``pfrepro.verdicts.ekf_pf_li2012``, on fixtures with known outcomes.

The fixtures are the results of ``run_all(runs=2)`` with the numbers the claims read replaced by
hand: a filter's error is made a constant offset per run (so its per-run RMSE, under every
reading of the statistic, is that offset), and the sweep rows are set directly. Each test then
knows the verdict the rule must give, and a change of rule fails here, not in a rebuild.
(The paper has no diverged runs and no number its unpublished settings decide, so there is no
lost-run or not-checkable case to test.)
"""
from __future__ import annotations

import copy
import inspect
import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pfrepro import cli
from pfrepro.claims import ClaimsRegistry
from pfrepro.experiments import ekf_pf_li2012 as E
from pfrepro.papers import get_paper
from pfrepro.prose import Md
from pfrepro.verdicts import ekf_pf_li2012 as V

IDS = ["table1-ekf-model1", "table1-pf-model1", "table1-ekf-model2", "table1-pf-model2", "ratio-7x",
       "close-weak-nonlinearity", "figs-pf-better", "figs-pf-better-model2", "sis-degenerates",
       "resampling-limits-degeneracy", "pf-cost", "kf-optimal-linear", "more-particles-less-degeneracy",
       "more-particles-cost", "optimal-proposal-hard", "prior-ignores-y", "ekf-error-truncation"]
CHAPTER = Path(__file__).resolve().parents[1] / "book" / "30_ekf_pf.md"


@pytest.fixture(scope="module")
def run1():
    """``Paper.run(runs=2, seeds=1)``: the chapter's path at two runs."""
    return get_paper("li2012").run(runs=2, seeds=1)


def _errors(mc, name, per_run):
    """Make filter ``name``'s error a constant per run: its per-run RMSE is exactly ``per_run``."""
    mc.results[name].x[...] = mc.x_true + np.asarray(per_run, float)[:, None, None]


def _rows(R, w, setting=None):
    m = R.sens["model"] == E.MODEL_LABELS[w]
    return m & (R.sens["setting"] == setting) if setting else m


def _holding(run1):
    """A fixture under which every claim but the table cells holds, decided by known numbers."""
    R = copy.deepcopy(run1[0])
    for w, ekf, pf in ((1, [8.0, 8.2], [1.0, 1.0]), (2, [1.1, 1.1], [1.0, 1.0])):
        _errors(R.res[w], "EKF", ekf)
        _errors(R.res[w], "PF", pf)
        ratio = np.mean(ekf) / np.mean(pf)
        for st in ("P0", "resampling"):
            R.sens.loc[_rows(R, w, st), ["EKF/PF", "EKF/PF_se", "diff", "diff_se"]] = [ratio, 0.01, 2.0, 0.1]
            R.sens.loc[_rows(R, w, st), ["SIS_ess", "SIS_ess_se", "ess_gain", "ess_gain_se"]] = [1.1, 0.1, 300.0, 5.0]
        gain = V.printed_pf_gain(w)                           # the printed EKF - PF: attained
        R.sens.loc[_rows(R, w, "P0") | _rows(R, w, "resampling"), ["diff", "diff_se"]] = [gain, 0.01 * gain]
        _errors(R.figs[w], "EKF", [1.0 + gain - 0.001 * gain, 1.0 + gain + 0.001 * gain])
        _errors(R.figs[w], "PF", [1.0, 1.0])
        R.deg[w]["SIS"]["late"] = np.array([1.0, 1.2])
        R.deg[w]["PF"]["late"] = np.array([300.0, 310.0])
        R.prop[w].update(ess_prior=np.array([300.0, 310.0]), ess_opt=np.array([700.0, 720.0]),
                         bimodal_share=np.array([0.4, 0.5]))
    R.trunc.update({"EKF": np.array([20.0, 22.0]), "Gaussian, exact moments": np.array([5.0, 5.5]),
                    "Exact": np.array([4.5, 5.0])})
    R.kf.update(max_dev=1e-5, mse={"KF": np.array([1.0, 1.1]), "Exact": np.array([1.0, 1.1]),
                                   "PF N=100": np.array([1.06, 1.17]), "PF N=1000": np.array([1.006, 1.107])})
    for n, late in ((100, [1.0, 1.05]), (1000, [15.0, 16.0]), (10000, [200.0, 220.0])):
        R.degen_n[n]["late"] = np.array(late)                  # each tenfold N: more particles and a larger share
    for n, d in R.degen_n.items():
        d["late_frac"] = d["late"] / n
    return R


def _claims(R) -> dict:
    reg = V.record_claims(ClaimsRegistry(E.PAPER, choices=E.CHOICES), R)
    return {c.claim_id: c for c in reg.claims}


def _verdicts(R) -> dict:
    return {k: c.verdict for k, c in _claims(R).items()}


# ------------------------------------------------------------------ the registry ----------
def test_every_claim_in_the_chapters_order(run1):
    R, reg = run1
    assert [c.claim_id for c in reg.claims] == IDS
    by = {c.claim_id: c for c in reg.claims}
    assert by["table1-pf-model1"].depends_on == ["P0", "statistic", "resampling"]
    assert by["table1-ekf-model1"].depends_on == ["P0", "statistic"]    # the EKF draws no random numbers
    assert "over 2 runs" in by["table1-ekf-model2"].note                 # the runs actually used
    assert by["pf-cost"].basis == "count" and by["pf-cost"].reproduced == 500.0   # N = 1000: 2000 vs 4 per step


def test_known_fixture_every_statement_holds(run1):
    v = _verdicts(_holding(run1))
    assert {k: v[k] for k in IDS[4:]} == dict.fromkeys(IDS[4:], "reproduced")


def test_a_prior_that_flips_the_7x_ratio_makes_it_inconclusive(run1):
    R = _holding(run1)
    assert _verdicts(R)["ratio-7x"] == "reproduced"          # 8.1 against the printed 7.65, > 7 everywhere
    R.sens.loc[_rows(R, 1, "P0") & (R.sens["value"] == 0.1), "EKF/PF"] = 3.0
    c = _claims(R)["ratio-7x"]
    assert c.reading_diffs["P0=0.1"][0] == pytest.approx(-4.0) and c.reading_diffs["P0=2"][0] == pytest.approx(1.1)
    assert c.effect == pytest.approx(30.1709 / 3.9459 - 7)     # the printed ratio's distance from 7
    assert c.judgement.under("fails") == ["P0=0.1"]
    assert c.verdict == "inconclusive" and c.cause == "depends on the reading"
    R.sens.loc[_rows(R, 1, "P0") | _rows(R, 1, "resampling"), "EKF/PF"] = 3.0
    _errors(R.res[1], "EKF", [3.0, 3.0])                     # 3x under every reading: contradicted
    assert _verdicts(R)["ratio-7x"] == "not reproduced"


def test_the_statistic_reading_decides_a_table_cell(run1):
    """The PF's model-2 cell matched under the main reading and every swept value is reproduced;
    a reading of the statistic that misses the printed number makes it inconclusive."""
    R = copy.deepcopy(run1[0])
    _errors(R.res[2], "PF", [1.05, 1.05])                      # printed: 1.0479
    for st in ("P0", "resampling"):
        R.sens.loc[_rows(R, 2, st), ["PF", "PF_se"]] = [1.05, 0.01]
    c = _claims(R)["table1-pf-model2"]
    assert c.reading_values["statistic=mean_time_rmse"][0] == pytest.approx(1.05)
    assert c.verdict == "reproduced"
    # error 1.5 over the first half of every run, 0 after: per-run RMSE 1.06 (matched), but the time
    # average of the per-time RMSE is 0.75 (not matched)
    x = R.res[2].x_true.copy()
    x[:, : E.T // 2] += 1.5
    R.res[2].results["PF"].x[...] = x
    c = _claims(R)["table1-pf-model2"]
    assert c.reproduced == pytest.approx(1.5 / np.sqrt(2)) and c.reading_values["statistic=pooled"][0] == pytest.approx(1.5 / np.sqrt(2))
    assert c.reading_values["statistic=mean_time_rmse"][0] == pytest.approx(0.75)
    assert c.verdict == "inconclusive"


def test_a_tie_on_the_figure_runs_is_inconclusive(run1):
    R = _holding(run1)
    assert _verdicts(R)["figs-pf-better"] == "reproduced"      # the printed 26.2 attained everywhere
    _errors(R.figs[1], "EKF", [41.0, 1.0])                     # EKF - PF = 40, 0: mean 20, se 20
    c = _claims(R)["figs-pf-better"]
    per = {r: (v, cause) for r, v, cause in c.judgement.per_reading}
    assert per["figure runs"] == ("inconclusive", "too few runs")   # 0 and 26.2 both inside
    assert c.verdict == "inconclusive" and c.cause == "too few runs" and c.runs_needed > 2
    _errors(R.figs[1], "EKF", [2.0, 0.0])                      # mean 0, se 1: the printed size excluded
    assert {r: v for r, v, _ in _claims(R)["figs-pf-better"].judgement.per_reading}["figure runs"] == "not reproduced"
    _errors(R.figs[1], "EKF", [0.5, 0.5])                      # the EKF better on every run: contradicted
    c = _claims(R)["figs-pf-better"]
    assert c.verdict == "inconclusive" and c.cause == "depends on the reading"   # Table 1 readings: the PF
    for st in ("P0", "resampling"):
        R.sens.loc[_rows(R, 1, st), ["diff", "diff_se"]] = [-2.0, 0.1]
    assert _verdicts(R)["figs-pf-better"] == "not reproduced"
    for st in ("P0", "resampling"):                            # the direction everywhere, the size nowhere
        R.sens.loc[_rows(R, 1, st), ["diff", "diff_se"]] = [10.0, 0.5]
    _errors(R.figs[1], "EKF", [11.0, 11.2])
    assert _verdicts(R)["figs-pf-better"] == "qualitatively reproduced"


def test_weak_nonlinearity_ratio_too_large_is_not_reproduced(run1):
    R = _holding(run1)
    _errors(R.res[2], "EKF", [1.5, 1.5])
    for st in ("P0", "resampling"):
        R.sens.loc[_rows(R, 2, st), "EKF/PF"] = 1.5
    assert _verdicts(R)["close-weak-nonlinearity"] == "not reproduced"


def test_very_few_particles_reading_flips_the_sis_claim(run1):
    R = _holding(run1)
    for w in (1, 2):
        R.deg[w]["SIS"]["late"] = np.array([20.0, 20.2])      # 2 % of N: "few" at 5 %, not at 1 %
    c = _claims(R)["sis-degenerates"]
    assert c.judgement.under("fails") == ["few=1%"] and "few=5%" in c.judgement.under("holds")
    assert c.verdict == "inconclusive" and c.cause == "depends on the reading"
    assert _verdicts(R)["resampling-limits-degeneracy"] == "reproduced"
    for w in (1, 2):
        R.deg[w]["PF"]["late"] = np.array([20.0, 20.2])       # resampling gains nothing on the main runs: a tie
    c = _claims(R)["resampling-limits-degeneracy"]
    assert {r: cause for r, _, cause in c.judgement.per_reading}["main"] == "tie within the stated margin"
    assert c.verdict == "inconclusive" and c.cause == "depends on the reading"   # the readings still gain


def test_cost_count_below_ten_is_not_reproduced(run1):
    R = _holding(run1)
    R.cnt[1].loc["PF", "count ratio"] = 10.0                   # "far exceeds": at least 10 times
    assert _verdicts(R)["pf-cost"] == "reproduced"
    R.cnt[1].loc["PF", "count ratio"] = 5.0
    assert _verdicts(R)["pf-cost"] == "not reproduced"
    assert V.timing_prose(*_timings(amortised=5.0))["li_v_cost_amort"] == "not reproduced"
    assert V.timing_prose(*_timings(amortised=50.0))["li_v_cost_amort"] == "reproduced"


def test_ratio_statements():
    assert V.ratio_diff(1, 7.5) == pytest.approx(0.5) and V.ratio_diff(2, 1.0) == pytest.approx(0.2)
    with pytest.raises(ValueError):
        V.ratio_diff(3, 1.0)
    assert V.alternative_statistics() == ["pooled", "mean_time_rmse"]


# ------------------------------------------------------------------ takeaway and prose -----
def test_takeaway_branches(run1):
    R = _holding(run1)
    reg = V.record_claims(ClaimsRegistry(E.PAPER, choices=E.CHOICES), R)
    t = V.takeaway(reg, R)
    assert "as the paper says" in t and "8.1 times" in t and "1.10 times" in t and "1/500" in t
    R.sens.loc[_rows(R, 1, "P0") | _rows(R, 1, "resampling"), "EKF/PF"] = 4.0
    _errors(R.res[1], "EKF", [4.0, 4.0])
    _errors(R.res[2], "EKF", [1.5, 1.5])
    for st in ("P0", "resampling"):
        R.sens.loc[_rows(R, 2, st), "EKF/PF"] = 1.5
    reg = V.record_claims(ClaimsRegistry(E.PAPER, choices=E.CHOICES), R)
    t = V.takeaway(reg, R)
    assert "not the paper's 'more than 7 times'" in t and "4.0 times" in t
    assert "'about the same' is not reproduced" in t
    _errors(R.figs[1], "EKF", [2.0, 0.0])
    reg = V.record_claims(ClaimsRegistry(E.PAPER, choices=E.CHOICES), R)
    assert V.takeaway(reg, R).startswith("That the PF tracks better than the EKF is inconclusive here")


def test_prose_words_follow_the_verdicts(run1):
    R = _holding(run1)
    reg = V.record_claims(ClaimsRegistry(E.PAPER, choices=E.CHOICES), R)
    p = V.prose(reg, R)
    assert p["li_v_ratio"] == "reproduced" and p["li_ratio_m1"] == pytest.approx(8.1)
    assert p["li_ratio_m1_z"] == pytest.approx((p["li_ratio_m1"] - 7) / p["li_ratio_m1_se"])
    assert p["li_runs_table"] == 2 and p["li_seed_table"] == 1 and p["li_n_seeds"] == 1 + E.N_SPREAD_SETS
    incon = [c.claim_id for c in reg.claims if c.claim_id.startswith("table1") and c.verdict == "inconclusive"]
    assert p["li_cells_incon"] == V.cells_in_words(incon) and p["li_n_cells_incon"] == len(incon)
    assert isinstance(p["li_n_cells_incon_phrase"], Md)
    assert str(p["li_n_cells_incon_phrase"]) == f"{len(incon)} {'is' if len(incon) == 1 else 'are'} matched"
    # every table cell inconclusive: the phrase agrees in number, the list names all four
    for w, name, printed in ((1, "EKF", 30.1709), (1, "PF", 3.9459), (2, "EKF", 1.1281), (2, "PF", 1.0479)):
        _errors(R.res[w], name, [printed, printed])
        R.sens.loc[_rows(R, w, "P0") | _rows(R, w, "resampling"), name] = printed
        R.sens.loc[_rows(R, w, "P0") & (R.sens["value"] == 10.0), name] = 3 * printed   # one prior misses it
    reg = V.record_claims(ClaimsRegistry(E.PAPER, choices=E.CHOICES), R)
    p = V.prose(reg, R)
    assert str(p["li_n_cells_incon_phrase"]) == "4 are matched" and p["li_n_cells_repro"] == 0
    assert p["li_cells_incon"] == "the model 1 EKF, model 1 PF, model 2 EKF and model 2 PF cells"


def test_prose_seed_rank_and_sis_never_below(run1):
    R = copy.deepcopy(run1[0])
    sp = R.spread
    sel = (sp["model"] == E.MODEL_LABELS[1]) & (sp["filter"] == "EKF-prev")
    sp.loc[sel, "mean"] = np.arange(sel.sum(), dtype=float)       # the Table 1 seed (first) is the smallest
    R.deg[1]["SIS"]["first_below"] = np.array([np.nan, np.nan])
    reg = V.record_claims(ClaimsRegistry(E.PAPER, choices=E.CHOICES), R)
    p = V.prose(reg, R)
    assert p["li_seed_prev_rank"] == f"{sel.sum()}th largest" and p["li_seed_prev_min_m1"] == 0.0
    assert np.isnan(p["li_sis_first_med_m1"]) and p["li_sis_never_m1"] == 2
    assert p["li_sis_never_phrase"] == f"it never does in 2 of the {R.runs['table']} runs of model 1 and 0 of model 2"
    sp.loc[sel, "mean"] = -np.arange(sel.sum(), dtype=float)      # now the largest
    p = V.prose(V.record_claims(ClaimsRegistry(E.PAPER, choices=E.CHOICES), R), R)
    assert p["li_seed_prev_rank"] == "largest"


def _timings(amortised=50.0, n_values=(50, 1000)):
    cost = {w: pd.DataFrame({"single_run_ratio": [1.0, 2.0, 5.0, 9.0], "amortised_ratio": [1.0, 2.0, amortised, 99.0]},
                            index=["EKF", "UKF", "PF", "Exact"]) for w in (1, 2)}
    ns = {w: pd.DataFrame({"gap": [0.5, 0.01], "gap_se": [0.1, 0.005], "amortised_ratio": [3.0, 40.0]},
                          index=pd.Index(list(n_values), name="N")) for w in (1, 2)}
    return cost, ns


def test_timing_prose_without_the_papers_n():
    p = V.timing_prose(*_timings())
    assert p["li_n_small"] == 50 and p["li_n_large"] == 1000 and p["li_n_gap_paper_m1"] == 0.01
    p = V.timing_prose(*_timings(n_values=(50, 200)))
    assert "li_n_gap_paper_m1" not in p and p["li_n_large"] == 200


def test_every_glue_key_of_the_chapter_is_glued(run1):
    """A glue key the text uses but nothing glues fails the strict build: every one is in prose(),
    timing_prose() or a glue_all / chapter_findings call of the chapter's own cells."""
    src = CHAPTER.read_text(encoding="utf-8")
    used = set(re.findall(r"\{glue:[a-z]+\}`([A-Za-z0-9_]+)", src)) | set(re.findall(r"```\{glue\} (\S+)", src))
    cells = "\n".join(re.findall(r"```\{code-cell\}[^\n]*\n(.*?)\n```", src, flags=re.S))
    in_cells = set(re.findall(r"[\"'](li_[A-Za-z0-9_]+)[\"']", cells))
    R, reg = run1
    glued = set(V.prose(reg, R)) | set(V.timing_prose(*_timings())) | in_cells
    assert used and not used - glued, sorted(used - glued)
    for bad in ("reg.add", "verdict(", "def "):                   # nothing decides a claim in the chapter
        assert bad not in cells


# ------------------------------------------------------------------ seeds and the command line ----
def test_two_seeds_give_other_numbers_and_the_same_claims(run1):
    R1, reg1 = run1
    R2, reg2 = get_paper("li2012").run(runs=2, seeds=2)
    assert R1.seeds == {"table": 1, "figures": 2, "spread": 3} and R2.seeds["table"] == 2
    assert [c.claim_id for c in reg1.claims] == [c.claim_id for c in reg2.claims] == IDS
    assert not np.array_equal(R1.res[1].x_true, R2.res[1].x_true)
    assert not np.array_equal(R1.figs[1].x_true, R2.figs[1].x_true)
    assert set(R1.spread["seed"]) != set(R2.spread["seed"])
    for a, b in zip(reg1.claims[:6], reg2.claims[:6]):
        assert a.reproduced != b.reproduced
    assert E.SEEDS == {"table": 2012, "figures": 2013, "spread": 2101}   # never mutated


def test_cli_writes_the_chapters_claims_byte_for_byte(run1, tmp_path, capsys):
    _, reg = run1
    assert cli.main(["run", "li2012", "--runs", "2", "--seed", "1", "--out", str(tmp_path / "cli")]) == 0
    capsys.readouterr()
    chapter = reg.save(tmp_path / "chapter")
    assert (tmp_path / "cli" / "claims" / chapter.name).read_bytes() == chapter.read_bytes()
    assert [c["claim_id"] for c in json.loads(chapter.read_text())] == IDS


def test_no_function_binds_a_module_seed():
    seeds = set(E.SEEDS.values())
    for name, fn in vars(E).items():
        if inspect.isfunction(fn) and fn.__module__ == E.__name__:
            for p in inspect.signature(fn).parameters.values():
                d = p.default
                assert not (isinstance(d, int) and d in seeds), f"{name}({p.name}={d}) binds a module seed"
                assert not (isinstance(d, tuple) and seeds & set(d)), f"{name}({p.name}) binds module seeds"


def test_runs_below_two_are_refused():
    with pytest.raises(ValueError, match="at least 2 runs"):
        E.run_all(runs=1)


# ------------------------------------------------------------------ issue 31: effects, plans, statements ----
def test_pf_beats_ekf_is_the_one_function_of_the_comparison(run1):
    """The figure claims take their numbers from pf_beats_ekf (shared with the synthesis chapter)."""
    out = V.pf_beats_ekf([20.0, 22.0, 24.0], [4.0, 4.0, 5.0], which=1)
    assert out == {"diff": pytest.approx(17.666666, rel=1e-6), "diff_se": pytest.approx(np.std([16, 18, 19], ddof=1) / np.sqrt(3)),
                   "runs": 3, "effect": pytest.approx(30.1709 - 3.9459)}
    assert V.pf_beats_ekf([1.2, 1.2], [1.0, 1.1], which=2)["effect"] == pytest.approx(1.1281 - 1.0479)
    with pytest.raises(ValueError):
        V.pf_beats_ekf([1.0, 2.0], [1.0], which=1)                 # common runs only
    R = _holding(run1)
    c = _claims(R)
    for w, cid in ((1, "figs-pf-better"), (2, "figs-pf-better-model2")):
        m = V.pf_beats_ekf(R.figs[w].rmse("EKF"), R.figs[w].rmse("PF"), w)
        assert c[cid].effect == pytest.approx(m["effect"]) and c[cid].diff == pytest.approx(m["diff"])
        assert c[cid].reading_diffs["figure runs"] == [pytest.approx(m["diff"]), pytest.approx(m["diff_se"]), 2]


def test_every_ordering_has_an_effect_or_a_margin_and_runs(run1):
    R = _holding(run1)
    for c in _claims(R).values():
        if c.diff is not None or c.reading_diffs:
            assert (c.effect is None) != (c.margin is None), c.claim_id
            assert c.runs and all(v[2] for v in (c.reading_diffs or {}).values()), c.claim_id
            assert not c.readings, c.claim_id                        # orderings use reading_diffs


def test_power_plans_rows_and_the_sis_plan(run1):
    R = _holding(run1)
    plans = V.power_plans(R)
    assert {p["claim"] for p in plans} >= {"ratio-7x", "figs-pf-better", "sis-degenerates", "ekf-error-truncation",
                                           "prior-ignores-y"}
    from pfrepro.stats import plan_runs
    for p in plans:
        assert p["needed"] == plan_runs(p["sd"], p["size"])
    reg = V.record_claims(ClaimsRegistry(E.PAPER, choices=E.CHOICES), R)
    rows = [c for n, c in reg.choices.items() if n.startswith("plan_")]
    assert len(rows) == len(plans) and all(c.status == "design choice" for c in rows)
    assert any("too few" in c.value for c in rows) == any(p["run"] < p["needed"] for p in plans)
    # the SIS plan: from the main reading's spread, against the stated margins
    sd = max(float(np.std(E.late_ess(R.res[w], "PF") - E.late_ess(R.res[w], "SIS"), ddof=1)) for w in (1, 2))
    assert V.sis_plan(R.res) >= plan_runs(sd, V.MARGIN_RESAMPLING)


def test_fixed_rows_cite_the_paper_line():
    for c in E.CHOICES:
        if c.status == "fixed by the paper":
            assert re.search(r"l\.\d+", c.source), c.name


def test_the_statements_of_secs_0_to_2(run1):
    R = _holding(run1)
    v = _verdicts(R)
    assert all(v[k] == "reproduced" for k in V.STATEMENT_CLAIMS), {k: v[k] for k in V.STATEMENT_CLAIMS}
    # more particles that buy no effective particle: the degeneracy half fails, the cost half stays
    R.degen_n[10000]["late"] = np.array([15.05, 16.15])        # 1000 -> 10000 buys nothing, 100 -> 1000 does
    R.degen_n[10000]["late_frac"] = R.degen_n[10000]["late"] / 10000
    c = _claims(R)["more-particles-less-degeneracy"]
    assert c.verdict == "inconclusive" and c.cause == "depends on the reading"
    assert c.judgement.under("fails") == ["degen_measure=count,degen_N=1000-10000",
                                          "degen_measure=fraction,degen_N=1000-10000"]
    for n in (100, 1000, 10000):
        R.degen_n[n]["late"] = np.array([1.0, 1.1]) + n * 1e-6
        R.degen_n[n]["late_frac"] = R.degen_n[n]["late"] / n
    v = _verdicts(R)
    assert v["more-particles-less-degeneracy"] == "not reproduced" and v["more-particles-cost"] == "reproduced"
    # a Gaussian filter with exact moments no better than the EKF: the error is not the truncation
    R.trunc["Gaussian, exact moments"] = R.trunc["EKF"] - np.array([0.1, -0.1])
    assert _verdicts(R)["ekf-error-truncation"] == "not reproduced"
    # the optimal proposal gains nothing: a tie within the stated 10 particles
    for w in (1, 2):
        R.prop[w]["ess_opt"] = R.prop[w]["ess_prior"] + np.array([-1.0, 1.2])
    c = _claims(R)["prior-ignores-y"]
    assert c.verdict == "inconclusive" and c.cause == "tie within the stated margin"
    for w in (1, 2):
        R.prop[w]["bimodal_share"] = np.array([0.0, 0.005])
    assert _verdicts(R)["optimal-proposal-hard"] == "not reproduced"
    R.kf["max_dev"] = 0.1
    assert _verdicts(R)["kf-optimal-linear"] == "not reproduced"


def test_gaussian_filter_with_exact_moments_is_the_kf_on_a_linear_model():
    """Equation check: without nonlinearity nothing is truncated, so the exact-moment Gaussian filter is the KF."""
    from pfrepro.filters import KalmanFilter

    m = E.linear_model()
    sim = m.simulate(E.T, 3, E.truth_streams(5, 3))
    kf = KalmanFilter(m).filter(sim.y).x[..., 0]
    assert np.max(np.abs(E.gaussian_adf(m, sim.y) - kf)) < 1e-6


def test_bimodality_test_of_the_optimal_proposal():
    """The cubic-discriminant test of proposal_check against counting the maxima on a grid."""
    Q, R, a = 10.0, 1.0, 1 / 20
    x = np.linspace(-60, 60, 240001)
    for mu, y in ((0.0, 20.0), (10.0, 5.0), (0.5, 0.1), (-3.0, 12.0), (15.0, 2.0)):
        g = -(x - mu) ** 2 / (2 * Q) - (y - a * x * x) ** 2 / (2 * R)
        maxima = int(((g[1:-1] > g[:-2]) & (g[1:-1] > g[2:])).sum())
        c3, c1, c0 = 2 * a * a * Q / R, 1.0 - 2 * a * y * Q / R, -mu
        assert (maxima == 2) == bool(-4 * c3 * c1 ** 3 - 27 * c3 * c3 * c0 ** 2 > 0), (mu, y)
