"""The claims of the CMS-PF chapter (Ning et al. 2011), decided by pfrepro.verdicts.cmspf_ning2011.

The rules are tested on the results of ``run_all(runs=2)`` edited into cases with known outcomes
(an ordering that holds under every reading, one reading that flips it, a tie, a published number
matched under every reading or only some, a count that fails, a diverged run), so that a change
of a rule shows here and not in a rebuild of the book.
"""
from __future__ import annotations

import copy
import inspect
import json

import numpy as np
import pandas as pd
import pytest

from pfrepro import published
from pfrepro.claims import ClaimsRegistry
from pfrepro.experiments import cmspf_ning2011 as E
from pfrepro.papers import get_paper
from pfrepro.verdicts import cmspf_ning2011 as V


@pytest.fixture(scope="module")
def run1():
    """``Paper.run(runs=2, seeds=1)``: the results and the registry."""
    return get_paper("cmspf").run(runs=2, seeds=1)


def _record(R):
    return V.record_claims(ClaimsRegistry(E.PAPER, choices=E.CHOICES), R)


def _verdicts(reg):
    return {c.claim_id: c.verdict for c in reg.claims}


def _claim(reg, cid):
    return next(c for c in reg.claims if c.claim_id == cid)


# -- seeds travel as arguments ------------------------------------------------------------------
def test_no_function_binds_a_seed_at_import():
    """Every experiment function takes ``seed=None`` (looked up at call time), never ``SEEDS[...]``."""
    for name, fn in inspect.getmembers(E, inspect.isfunction):
        if fn.__module__ != E.__name__:
            continue
        p = inspect.signature(fn).parameters.get("seed")
        if p is not None:
            assert p.default is None or p.default is inspect.Parameter.empty, name


def test_two_seeds_give_other_numbers_and_the_same_claims(run1):
    R1, reg1 = run1
    labels = []
    R2, reg2 = get_paper("cmspf").run(runs=2, seeds=2, steps=labels.append)
    assert labels == list(E.STEPS)                        # the progress bar's N_STEPS is their number
    assert [c.claim_id for c in reg1.claims] == [c.claim_id for c in reg2.claims]
    assert R1.seeds == {k: 1 + i for i, k in enumerate(E.SEEDS)} and R2.seeds["table1"] == 2
    assert E.SEEDS["table1"] == 20111                     # the module's table is never changed
    # every experiment moved with the seed (truths and filter streams)
    for a, b in [(R1.t1, R2.t1), (R1.t1_q10, R2.t1_q10), (R1.t3, R2.t3), (R1.f3_runs, R2.f3_runs),
                 (R1.cons, R2.cons), (R1.mech["main"], R2.mech["main"]), (R1.t3_oracle, R2.t3_oracle)]:
        assert not np.allclose(a.select_dtypes("number").to_numpy(), b.select_dtypes("number").to_numpy())
    assert not np.allclose(R1.t2_res.rmse("PF"), R2.t2_res.rmse("PF"))
    assert not np.allclose(R1.f2.rmse("EKF"), R2.f2.rmse("EKF"))
    assert R1.step_randn["x_true"] != R2.step_randn["x_true"] and R1.f6_base["x_true"] != R2.f6_base["x_true"]
    assert not np.allclose(R1.sens_runs["ref"]["PF"], R2.sens_runs["ref"]["PF"])
    tag = "sigma_v_t2=R 1, sigma_w2=10"
    assert not np.allclose(R1.f6_reading(tag, R1.plans["f6"]["runs"]), R2.f6_reading(tag, R2.plans["f6"]["runs"]))
    repro = [c.reproduced for c in reg1.claims if c.reproduced is not None and c.basis != "count"]
    other = [c.reproduced for c in reg2.claims if c.reproduced is not None and c.basis != "count"]
    assert all(a != b for a, b in zip(repro, other))


def test_run_all_refuses_one_run_and_reads_no_new_reading_afterwards(run1):
    R, _ = run1
    with pytest.raises(ValueError, match="runs >= 2"):
        E.run_all(runs=1)
    with pytest.raises(KeyError, match="not run by run_all"):
        R.t1_reading("sigma_w2=1", 7)
    assert R.settings == {"runs": 2, "seeds": R.seeds}


def test_cli_writes_the_chapters_claims(run1, tmp_path, monkeypatch, capsys):
    """``pfrepro run cmspf`` goes through the same run_all and record_claims: the claims file is the
    registry's bytes (run_all replaced by the fixture's results: the CLI's wiring is what is tested),
    and every table and figure is written."""
    from pfrepro import cli

    R, reg = run1
    monkeypatch.setattr(E, "run_all", lambda **kw: R)
    out = tmp_path / "cli"
    assert cli.main(["run", "cmspf", "--runs", "2", "--seed", "1", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "the chapter's claims" in text and f"verdicts of the {len(reg.claims)} claims" in text
    reg.save(tmp_path / "direct")
    assert (out / "claims" / f"{E.PAPER}.json").read_bytes() == (tmp_path / "direct" / f"{E.PAPER}.json").read_bytes()
    for f in ("table1.csv", "table1_means.csv", "table2.csv", "table3.csv", "fig2.png", "fig3.png", "fig4.png",
              "fig5.png", "fig6.png"):
        assert (out / f).stat().st_size > 0, f


# -- the orderings -------------------------------------------------------------------------------
def _set_t1(R, gap):
    """Every Table 1 frame (main and readings): CMS-PF = PF - gap(run)."""
    for key, t in list(R.readings.items()):
        if key[0] == "t1":
            t = t.copy()
            for N in E.TABLE1_N:
                t[(N, "CMS-PF")] = t[(N, "PF")] - gap(key[1])
            R.readings[key] = t
    R.t1 = R.readings[("t1", "sigma_w2=1", R.n["t1"])]
    R.t1_q10 = R.readings[("t1", "sigma_w2=10", R.n["t1"])]


def test_table1_ordering_holds_flips_and_ties(run1):
    """The printed effect is tested: a gap at the printed size -> reproduced; far above it ->
    qualitatively reproduced; reversed -> not reproduced; one reading flips -> depends on the reading;
    a gap near zero that cannot exclude the printed size -> too few runs."""
    R = copy.deepcopy(run1[0])
    eff = dict(zip(E.TABLE1_N, V.t1_effects()))

    def set_gap(gap):
        for key, t in list(R.readings.items()):
            if key[0] == "t1":
                t = t.copy()
                for N in E.TABLE1_N:
                    t[(N, "CMS-PF")] = t[(N, "PF")] - gap(key[1], N)
                R.readings[key] = t
        R.t1 = R.readings[("t1", "sigma_w2=1", R.n["t1"])]
        R.t1_q10 = R.readings[("t1", "sigma_w2=10", R.n["t1"])]

    jitter = np.array([0.99, 1.01])
    set_gap(lambda tag, N: eff[N] * jitter)                                  # the printed size, every N
    c = _claim(_record(R), "t1_cms_better_than_pf")
    assert c.effect == V.UNIT and c.verdict == "reproduced" and c.judgement.under("holds")
    set_gap(lambda tag, N: 5 * eff[N] * jitter)                              # shown, printed size excluded
    assert _verdicts(_record(R))["t1_cms_better_than_pf"] == "qualitatively reproduced"
    set_gap(lambda tag, N: -eff[N] * jitter if tag == "sigma_w2=10" else eff[N] * jitter)
    c = _claim(_record(R), "t1_cms_better_than_pf")
    assert c.verdict == "inconclusive" and c.cause == "depends on the reading"
    assert c.judgement.under("fails") == ["sigma_w2=10"]
    set_gap(lambda tag, N: -eff[N] * jitter)                                 # worse everywhere
    assert _verdicts(_record(R))["t1_cms_better_than_pf"] == "not reproduced"
    # one N reversed is enough: the worst part decides
    set_gap(lambda tag, N: -eff[N] * jitter if N == 1000 else eff[N] * jitter)
    assert _verdicts(_record(R))["t1_cms_better_than_pf"] == "not reproduced"
    # a noisy gap around half the printed effect: neither 0 nor the effect excluded -> too few runs
    set_gap(lambda tag, N: eff[N] * np.array([-1.0, 2.0]))
    c = _claim(_record(R), "t1_cms_better_than_pf")
    assert c.verdict == "inconclusive" and c.cause == "too few runs" and c.runs_needed > 2


def test_worst_part_and_scaling():
    """Each part in units of its own size; the part with the worst verdict decides."""
    parts = V.scaled([(2.0, 0.1), (0.1, 0.1)], [2.0, 0.5])
    assert parts == [(1.0, 0.05), (0.2, 0.2)]
    assert V.worst(parts) == (0.2, 0.2)                       # 0.2 ± 0.2 excludes the size 1: not reproduced
    assert V.worst([(1.0, 0.05), (3.0, 0.05)]) == (3.0, 0.05)  # size missed ranks below size attained
    assert V.worst([(5.0, 0.1), (0.01, 0.01)], "margin") == (0.01, 0.01)   # a tie ranks below a shown part
    with pytest.raises(ValueError):
        V.scaled([(1.0, 0.1)], [0.0])
    d, se, n = V.reading_diff([(2.0, 0.1), (0.1, 0.1)], [2.0, 0.5], 40)
    assert (d, se, n) == (0.2, 0.2, 40)


def test_plans_follow_the_main_spread_and_the_cap(run1):
    R = copy.deepcopy(run1[0])
    p = V._plan([(0.0, 0.5, 0.1)], 20, 100, "x")
    assert p["need"] == __import__("pfrepro").stats.plan_runs(0.5 * np.sqrt(20), 0.1) and p["runs"] == 100
    assert V._plan([(0.0, 0.01, 1.0)], 20, 100, "x")["runs"] == 20          # never below the paper's count
    assert V._plan([(0.0, 0.01, 1.0)], 20, 4, "x")["runs"] == 20            # the cap never cuts below it
    rows = V.plan_choices(R)
    assert {r.name for r in rows} == {f"plan_{k}" for k in R.plans} and all(r.status == "design choice" for r in rows)
    reg = _record(R)
    assert {f"plan_{k}" for k in R.plans} <= set(reg.choices)
    # every ordering claim carries an effect or a margin and per-reading differences with their runs
    for c in reg.claims:
        if c.reading_diffs:
            assert (c.effect == V.UNIT) != (c.margin == V.UNIT), c.claim_id
            assert all(v[2] and v[2] >= 2 for v in c.reading_diffs.values()), c.claim_id
            assert not c.readings


def test_xhat_claim_follows_the_kept_shares(run1):
    R = copy.deepcopy(run1[0])

    def set_kept(a, b):
        for k, m in R.mech.items():
            m = m.copy()
            m[("x̂-centred map particles", "kept")] = a
            m[("big-centred map particles", "kept")] = b
            R.mech[k] = m
    set_kept(np.array([0.9, 0.92]), np.array([0.3, 0.31]))
    c = _claim(_record(R), "xhat_map_particles_competitive")
    assert c.verdict == "reproduced" and c.margin == V.UNIT and c.source.endswith("(l.106)")
    set_kept(np.array([0.3, 0.31]), np.array([0.9, 0.92]))
    assert _verdicts(_record(R))["xhat_map_particles_competitive"] == "not reproduced"
    set_kept(np.array([0.500, 0.501]), np.array([0.500, 0.500]))           # well inside 5 points: a tie
    c = _claim(_record(R), "xhat_map_particles_competitive")
    assert c.verdict == "inconclusive" and c.cause == "tie within the stated margin"


def test_fig1_step_checks_pass_and_fail():
    t = E.step_checks(runs=3, steps=2)
    assert list(t.index) == list(E.FIG1_STEPS) and t["passes"].all()
    from pfrepro.figures import cmspf_ning2011 as F
    bad = t.copy()
    bad.loc["Step 2.5", "passes"] = False
    assert F.fig1_flowchart(bad) is not None


def test_runs_fig3_is_a_design_choice_and_fixed_rows_cite_lines():
    rows = {c.name: c for c in E.CHOICES}
    assert rows["runs_fig3"].status == "design choice"
    for c in E.CHOICES:
        if c.status == "fixed by the paper":
            assert "l." in c.source, c.name


def test_a_diverged_run_stops_the_decision(run1):
    """A non-finite per-run RMSE is not dropped silently: the paired difference refuses it."""
    R = copy.deepcopy(run1[0])
    t = R.t1.copy()
    t.iloc[0, 0] = np.nan
    R.t1 = R.readings[("t1", "sigma_w2=1", R.n["t1"])] = t
    with pytest.raises(ValueError, match="finite"):
        _record(R)


def test_fig6_picks_on_the_first_half_and_judges_on_the_second():
    # alpha 0.5 is best on runs 1-2 inside the range, 2.0 outside; on runs 3-4 the outside value wins
    er = pd.DataFrame({0.5: [1.0, 1.0, 3.0, 3.1], 0.8: [2.0, 2.0, 0.0, 0.0], 2.0: [1.5, 1.5, 1.0, 1.05],
                       5.0: [9.0, 9.0, 0.0, 0.0]})
    (d, se), = V.f6_pairs(er)
    assert d == pytest.approx(np.mean([1.0 - 3.0, 1.05 - 3.1]))
    assert V.holds([(d, se)]) is False      # outside better: the paper's range is not confirmed
    assert V.f6_margin() == pytest.approx(0.05 * 5.2070)


def test_table3_orderings_on_hand_values():
    t = pd.DataFrame({c: np.array([10.0, 10.5]) for c in E.TABLE3_COLUMNS})
    for c in E.TABLE3_COLUMNS[2:]:
        t[c] = np.array([3.0, 3.2])
    assert V.holds(V.t3_below_ekf(t)) is True
    assert V.holds(V.t3_eq6_best(t)) is None                       # all carriers equal: undecided
    t["CMS3-PF"], t["CMSR3-PF"] = np.array([2.0, 2.1]), np.array([2.0, 2.2])
    assert V.holds(V.t3_eq6_best(t)) is True
    # no resampling: CMS_i more than 10 % worse than CMSR_i -> not non-inferior
    t["CMS1-PF"] = np.array([5.0, 5.1])
    assert V.holds(V.t3_no_resampling(t)) is False


# -- published numbers under the readings -----------------------------------------------------------
def test_published_number_matched_under_every_reading_or_only_some(run1):
    R = copy.deepcopy(run1[0])
    pub = published.value(E.PAPER, "Table 1", "21", "N=10 PF")
    at_pub = np.array([pub - 0.01, pub + 0.01])
    for key, t in list(R.readings.items()):
        if key[0] == "t1":
            t = t.copy()
            t[(10, "PF")] = at_pub
            R.readings[key] = t
    R.t1 = R.readings[("t1", "sigma_w2=1", R.n["t1"])]
    R.t1_q10 = R.readings[("t1", "sigma_w2=10", R.n["t1"])]
    c = _claim(_record(R), "t1_pf_mean_N10")
    assert float(c.published_text) == pub
    assert c.verdict == "reproduced"
    t = R.t1_q10.copy()
    t[(10, "PF")] = at_pub * 3                                      # sigma_w^2 = 10 far off
    R.t1_q10 = R.readings[("t1", "sigma_w2=10", R.n["t1"])] = t
    assert _claim(_record(R), "t1_pf_mean_N10").verdict == "inconclusive"


def test_table3_attainable_and_its_prose(run1):
    R = copy.deepcopy(run1[0])
    pub_min = min(published.value(E.PAPER, "Table 3", "21", c) for c in E.TABLE3_COLUMNS[2:])

    def set_grid(level):
        for lab, t in V.t3_by_reading(R).items():
            g = pd.Series(level(lab) * np.array([1.0, 1.01]), index=t.index)
            if T3 := {(10.0, None): "t3", (10.0, 10.0): "t3_q10"}.get(E.T3_READINGS[lab]):
                setattr(R, T3, getattr(R, T3).assign(**{"Grid (exact)": g}))
            else:
                R.readings[("t3 grid", lab, R.n["t3"])] = g
    set_grid(lambda lab: pub_min * 0.5)                             # exact far below: attainable everywhere
    reg = _record(R)
    assert _verdicts(reg)["t3_attainable_by_a_filter"] == "reproduced"
    p = V.prose(reg, R)
    assert "attainable by a filter under every reading" in p["cms_concl_t3"] and p["cms_n_below"] == 0
    set_grid(lambda lab: pub_min * 3)                               # published far below the optimum
    reg = _record(R)
    assert _verdicts(reg)["t3_attainable_by_a_filter"] == "not reproduced"
    assert "needs the true state" in V.prose(reg, R)["cms_concl_t3"]
    first = next(iter(E.T3_READINGS))
    set_grid(lambda lab: pub_min * (3 if lab == first else 0.5))    # the readings disagree
    reg = _record(R)
    p = V.prose(reg, R)
    assert _verdicts(reg)["t3_attainable_by_a_filter"] == "inconclusive"
    assert p["cms_concl_t3"].startswith("Whether the published") and f"Under {first} the published" in p["cms_read_para"]


# -- counts, statements and the generated text --------------------------------------------------------
def test_cost_and_eq6_claims_follow_their_counts(run1):
    R = copy.deepcopy(run1[0])
    v = _verdicts(_record(R))
    assert v["t2_time_cms_over_pf"] == v["t2_time_espf_over_pf"] == v["eq6_white"] == "reproduced"
    R.cost2 = R.cost2.copy()
    R.cost2.loc["CMS-PF", "model evals / step"] = 2.5 * R.cost2.loc["PF", "model evals / step"]
    R.checks["mean6"] = 0.5
    v = _verdicts(_record(R))
    assert v["t2_time_cms_over_pf"] == "not reproduced" and v["eq6_white"] == "not reproduced"
    assert V.eq6_white({"mean6": 0.0, "ac6": [0.001], "xc6": [0.009], "bound6": 0.01}) is True
    assert V.eq6_white({"mean6": 0.0, "ac6": [0.001], "xc6": [0.011], "bound6": 0.01}) is False


def test_takeaway_and_prose_follow_the_verdicts(run1):
    R = copy.deepcopy(run1[0])
    _set_t1(R, lambda tag: -np.array([1.0, 1.1]))                   # CMS-PF worse everywhere
    reg = _record(R)
    assert set(V.MAIN_CLAIMS) <= {c.claim_id for c in reg.claims}
    tk = V.takeaway(reg, R)
    assert tk.startswith("On the paper's benchmark CMS-PF was not more accurate")
    _set_t1(R, lambda tag: np.array([1.0, 1.1]))                    # better everywhere
    reg = _record(R)
    assert V.takeaway(reg, R).startswith("CMS-PF beat the bootstrap PF")
    _set_t1(R, lambda tag: np.array([-2.0, 2.5]))                   # undecided: neither 0 nor the printed size excluded
    assert V.takeaway(_record(R), R).startswith("Whether CMS-PF beats the bootstrap PF is not decided")
    # the bias sentence follows the consistency numbers: a distance that falls clearly with N
    cons = R.cons.copy()
    cms = cons["filter"] == "CMS-PF"
    cons.loc[cms, "dist to exact mean"] = np.linspace(4.0, 1.0, cms.sum())
    cons.loc[cms, "se"] = 0.01
    R.cons = cons
    reg = _record(R)
    assert "the gap closes only slowly" in V.takeaway(reg, R)
    p = V.prose(reg, R)
    assert p["cms_cons_bias_short"] == "more particles shrink its bias only slowly"
    cons.loc[cms, "dist to exact mean"] = 2.0                       # flat: no shrinking
    assert "do not shrink" in V.takeaway(reg, R)
    # every key the chapter's prose uses is glued
    import re
    from pathlib import Path
    src = (Path(__file__).resolve().parents[1] / "book" / "40_cmspf.md").read_text(encoding="utf-8")
    used = set(re.findall(r"\{glue:[a-z]*\}`([^`:]+)", src))
    glued_in_chapter = {"cms_today_runs", "cms_today_sentence", "cms_exec_seconds"}
    assert used - glued_in_chapter <= set(V.prose(reg, R))
    n = sum(p[f"cms_n_{v.replace(' ', '_')}"] for v in ("reproduced", "qualitatively reproduced", "not reproduced",
                                                       "not checkable", "inconclusive"))
    assert n == p["cms_n_claims"] == len(reg.claims) and p["cms_verdict_sentence"].startswith(f"Of {n} claims")


def test_which_reading_counts_matched_cells(run1):
    _, reg = run1
    cells, table = V.which_reading(reg)
    assert set(cells["table"]) == {"Table 1", "Table 2", "Table 3"}
    n_t1 = sum(1 for c in reg.claims if c.claim_id.startswith("t1_") and "_mean_N" in c.claim_id)
    assert (cells[cells.table == "Table 1"]["claim"].nunique()) == n_t1 == 10
    one = cells[(cells.table == "Table 1") & (cells.reading == "sigma_w2=1")]
    assert len(one) == 10 and "sigma_w2=1" in table.loc["Table 1"].index


def test_saved_claims_are_json_of_the_registry(run1, tmp_path):
    _, reg = run1
    path = reg.save(tmp_path)
    rows = json.loads(path.read_text())
    assert [r["claim_id"] for r in rows][:2] == ["t1_pf_mean_N10", "t1_cms_mean_N10"]
    assert rows[-1]["claim_id"] == "f6_alpha_range" and len(rows) == 44
    assert all(r["cause"] for r in rows if r["verdict"] == "inconclusive")
