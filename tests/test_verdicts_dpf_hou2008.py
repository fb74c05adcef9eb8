"""The claims of Hou & Yin (2008) (``pfrepro.verdicts.dpf_hou2008``) on fixtures with known outcomes.

One small run of every experiment (``run_all(runs=2, seeds=1)``, shared by the module) is edited
by hand so that a claim's outcome is known: a reading that flips the verdict, a tie (undecided
ordering -> inconclusive), a lost run (counted, and weighing against its filter), a diverged run
(refused, not dropped), the one-run rule of the four published numbers, the early-phase
"similar" rule, and the branches of the takeaway and of the generated prose. The command line
writes the same claims as :meth:`pfrepro.papers.Paper.run` (the chapter's path), byte for byte,
and another seed changes the numbers but not the claims. The paper has no not-checkable value.
"""
from __future__ import annotations

import copy
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from pfrepro import cli
from pfrepro.claims import ClaimsRegistry
from pfrepro.experiments import dpf_hou2008 as E
from pfrepro.figures import dpf_hou2008 as F
from pfrepro.papers import get_paper
from pfrepro.verdicts import dpf_hou2008 as V

BOOK = Path(__file__).resolve().parents[1] / "book"
#: the chapter's claims, in the chapter's order
IDS = ["s51_rmse_x_dpf", "s51_rmse_theta_dpf", "s51_rmse_x_dekf", "s51_rmse_theta_dekf", "s51_dpf_beats_dekf_x",
       "s51_dpf_beats_dekf_theta", "fig5_dpf_robust_to_guess", "no_parameter_impoverishment", "cap_keeps_flexible",
       "dpf_beats_liu_west_theta", "beta_avoids_outside_draws", "beta_sampling_efficiency", "beta_speeds_convergence",
       "s52_dpf_beats_dekf_alt", "s52_dpf_beats_dekf_alt_10_20", "s52_dpf_beats_dekf_vel",
       "s52_dpf_beats_dekf_vel_10_20", "s52_dpf_beats_dekf_th", "s52_dpf_beats_dekf_th_10_20", "s52_similar_early",
       "dpf_beats_liu_west_theta_reentry", "dual_more_stable_than_joint", "dual_cheaper_than_joint"]


#: fewer particles than the chapter (500 + 500, 2000 + 2000) for the fixtures: the rules do not
#: depend on them, and the runs take a few seconds
FEW = {"S51": {"n_x": 100, "n_theta": 100, "lw_n": 100}, "S52": {"n_x": 200, "n_theta": 200}}


def run_small(seeds, mp):
    for which, values in FEW.items():
        for k, v in values.items():
            mp.setitem(getattr(E, which), k, v)
    return get_paper("dpf").run(runs=2, seeds=seeds)


@pytest.fixture(scope="module")
def small():
    """``Paper.run(runs=2, seeds=1)`` with :data:`FEW` particles: the results and the registry
    (never edited: tests copy them)."""
    with pytest.MonkeyPatch.context() as mp:
        return run_small(1, mp)


def claims_of(R) -> dict:
    reg = V.record_claims(ClaimsRegistry(E.PAPER, choices=E.CHOICES), R)
    return {c.claim_id: c for c in reg.claims}


# -- the shape of the claims; seeds; the command line ------------------------------------------
def test_claim_ids_in_the_chapters_order_and_main_claims(small):
    _, reg = small
    assert [c.claim_id for c in reg.claims] == IDS
    assert set(V.MAIN_CLAIMS) <= set(IDS) and 3 <= len(V.MAIN_CLAIMS) <= 6
    assert all(c.depends_on for c in reg.claims)      # every claim rests on a declared free choice


def test_run_counts_and_seeds_travel_as_arguments(small):
    R, _ = small
    assert R.s51["runs"] == R.s51["grid_runs"] == R.s51["sens_runs"] == R.s51["theta_runs"] == R.s51["fig5_runs"] == 2
    assert R.s52["runs"] == R.s52["q_runs"] == R.s52["literal_runs"] == R.s52["fig_runs"] == 2
    assert R.seeds == {"sec51": 1, "sec52": 2}
    assert E.S51["runs"] == E.RUNS_51 and E.S51["n_x"] == 500 and E.SEEDS == {"sec51": 200851, "sec52": 200852}   # untouched
    assert R.r51.sim.y.shape[0] == 2 and R.rd52[("Q52", "small")].sim.y.shape[0] == 2
    with pytest.raises(ValueError, match="runs must be an integer >= 2"):
        E.scaled_settings(1)


def test_another_seed_changes_the_numbers_not_the_claims(small, monkeypatch):
    R1, reg1 = small
    R2, reg2 = run_small(2, monkeypatch)
    assert [c.claim_id for c in reg1.claims] == [c.claim_id for c in reg2.claims] == IDS
    assert R2.seeds == {"sec51": 2, "sec52": 3}
    assert not np.array_equal(R1.r51.sim.y, R2.r51.sim.y) and not np.array_equal(R1.r52.sim.y, R2.r52.sim.y)
    d1 = {c.claim_id: (c.reproduced, c.diff) for c in reg1.claims}
    d2 = {c.claim_id: (c.reproduced, c.diff) for c in reg2.claims}
    # every number that is not a count over two runs (coverage, a share of 0/2 runs) moves
    same = {i for i in IDS if d1[i] == d2[i]}
    assert same <= {"cap_keeps_flexible", "s52_similar_early", "beta_avoids_outside_draws",
                    "dual_more_stable_than_joint", "dual_cheaper_than_joint"}, same


def test_the_command_line_writes_the_chapters_claims(small, tmp_path, capsys, monkeypatch):
    """``pfrepro run dpf --runs 2 --seed 1`` and ``Paper.run(runs=2, seeds=1)`` (the chapter's call)
    save the same bytes; the table and figures are written too. The experiments are the fixture's
    (``run_all`` is called with the same arguments: checked), so the test runs them once."""
    R, reg = small
    calls = []

    def run_all(**kw):
        calls.append(kw)
        return R

    monkeypatch.setattr(E, "run_all", run_all)
    code = cli.main(["run", "dpf", "--runs", "2", "--seed", "1", "--out", str(tmp_path / "cli")])
    out = capsys.readouterr().out
    assert code == 0
    assert [(c["runs"], c["seeds"]) for c in calls] == [(2, 1)]
    assert "verdicts of the 23 claims (the chapter's claims" in out and "seed (5.2): 2" in out
    reg.save(tmp_path / "book")
    for rel in ("dpf_hou2008.json", "choices/dpf_hou2008.json"):
        assert (tmp_path / "cli" / "claims" / rel).read_bytes() == (tmp_path / "book" / rel).read_bytes(), rel
    for f in ("rmse_table.csv", "fig4.png", "fig5.png", "figs_7_9.png"):
        assert (tmp_path / "cli" / f).stat().st_size > 0


def test_tables_and_figures_come_from_the_results(small):
    R, _ = small
    tab = F.tables(R)["RMSE table"]
    direct = E.rmse_table_51(R.r51, ["DPF", "DEKF", "Liu-West"])
    assert tab.loc["DPF", "eq14 x"] == F.pm(direct.loc["DPF", "eq14 x"], direct.loc["DPF", "eq14 x se"], 3)
    assert list(tab.index)[-1] == "paper (1 run)" and "exact (2 runs)" in tab.index
    assert set(F.TABLES) == set(F.tables(R)) and F.N_STEPS == len(E.STEPS)


def test_every_glue_key_of_the_chapter_is_glued(small):
    """Each ``{glue}`` key of the chapter's prose comes from ``prose``, the figures, or the few
    values the chapter glues itself (equation checks, wall times, the today section)."""
    import matplotlib.pyplot as plt

    R, reg = small
    src = (BOOK / "50_dpf.md").read_text(encoding="utf-8")
    used = set(re.findall(r"\{glue(?::\w+)?\}`([^`:]+)", src)) | set(re.findall(r"```\{glue(?::\w+)?\} (\w+)", src))
    figs = F.chapter_figures(R)
    plt.close("all")
    glued = set(V.prose(reg, R)) | set(figs) | {"dpf_findings"}
    in_chapter = {k for k in used - glued if re.search(rf'"{re.escape(k)}"', src)}
    assert used - glued == in_chapter, sorted(used - glued - in_chapter)
    assert {k for k in in_chapter if not k.startswith(("dpf_chk_", "dpf_sec_", "dpf_today_"))} == \
        {"dpf_exec_seconds", "dpf_cpu_seconds"}


# -- known outcomes ----------------------------------------------------------------------------
def _outside(R, beta, gauss):
    """Set the share of parameter draws outside the range per run and step: Beta DPF, Gaussian DPF."""
    R.r51.results["DPF"].diagnostics["outside"] = np.asarray(beta, float)
    R.x51.results[V.GA].diagnostics["outside"] = np.asarray(gauss, float)


@pytest.mark.parametrize("case, expected, readings", [
    # the Gaussian puts 10 % / 20 % of its draws outside in every step: holds at T = 100 and T = 50
    ("both", "reproduced", {"T51=100": "reproduced", "T51=50": "reproduced"}),
    # outside only after step 50: holds at T = 100; an exact tie (0 - 0, se 0) at T = 50, inside the margin
    ("late", "inconclusive (depends on the reading)", {"T51=100": "reproduced", "T51=50": "inconclusive"}),
    # the Beta is the one outside (it cannot be, but the rule must see it): fails at both
    ("beta", "not reproduced", {"T51=100": "not reproduced", "T51=50": "not reproduced"}),
])
def test_the_horizon_reading_flips_the_outside_draws_claim(small, case, expected, readings):
    R = copy.deepcopy(small[0])
    T = R.s51["T"]
    per_run = np.array([[0.1], [0.2]]) * np.ones((2, T))
    zero = np.zeros((2, T))
    late = per_run * (np.arange(T) >= 50)
    _outside(R, *{"both": (zero, per_run), "late": (zero, late), "beta": (per_run, zero)}[case])
    c = claims_of(R)["beta_avoids_outside_draws"]
    assert {r: v for r, v, _ in c.judgement.per_reading} == readings
    assert c.verdict_text() == expected
    assert c.margin == V.MARGINS["beta_avoids_outside_draws"][0] and all(v[2] == 2 for v in c.reading_diffs.values())


def _tie_theta_52(R):
    """DEKF's θ estimates equal the DPF's in every sec 5.2 reading that judges DPF against DEKF."""
    dpf = R.r52.results["DPF"].diagnostics["theta"]
    for key in (("weight", "plugin"), ("roughening", R.s52["roughenings"][1]), ("resampling", "multinomial")):
        R.rd52[key].results["DPF"].diagnostics["theta"] = dpf[: R.rd52[key].sim.y.shape[0]].copy()
    R.r52.results["DEKF"].diagnostics["theta"] = dpf.copy()
    R.rd52[("dekf52", "prior")].results["DEKF"].diagnostics["theta"] = dpf.copy()
    for q in ("small", "printed"):
        run = R.rd52[("Q52", q)]
        run.results["DEKF"].diagnostics["theta"] = run.results["DPF"].diagnostics["theta"].copy()


def test_a_tie_is_inconclusive(small):
    R = copy.deepcopy(small[0])
    _tie_theta_52(R)
    c = claims_of(R)["s52_dpf_beats_dekf_th"]
    assert c.diff == 0 and c.diff_se == 0
    counted = {k: v for k, v in c.reading_diffs.items() if k not in c.excluded}
    assert {v[0] for v in counted.values()} == {0.0} and len(counted) == 8   # main + 7 readings (literal excluded)
    assert set(c.excluded) == {"units52=literal"} and "l.242" in c.excluded["units52=literal"]
    # an exact tie under every counted reading: inside the stated margin
    assert c.verdict_text() == "inconclusive (tie within the stated margin)"


def _early_ratio(R, ratio):
    """DEKF's state errors = ``ratio`` x the DPF's, run by run, in every sec 5.2 reading."""
    dpf = R.r52.results["DPF"].x
    for key in (("weight", "plugin"), ("roughening", R.s52["roughenings"][1]), ("resampling", "multinomial")):
        R.rd52[key].results["DPF"].x = dpf.copy()
    for run in (R.r52, R.rd52[("Q52", "small")], R.rd52[("Q52", "printed")]):
        truth = run.sim.x[:, 1:]
        run.results["DEKF"].x = truth + ratio * (run.results["DPF"].x - truth)
    R.rd52[("dekf52", "prior")].results["DEKF"].x = R.r52.results["DEKF"].x.copy()


@pytest.mark.parametrize("ratio, expected", [(1.1, "reproduced"), (0.9, "reproduced"), (2.0, "not reproduced"),
                                             (0.5, "not reproduced")])
def test_similar_early_is_a_ratio_inside_0_8_1_25(small, ratio, expected):
    R = copy.deepcopy(small[0])
    _early_ratio(R, ratio)
    c = claims_of(R)["s52_similar_early"]
    assert c.verdict == expected
    assert f"main ratios {ratio:.2f}, {ratio:.2f}" in c.note


def _run52(dpf_err, dekf_err, T=10):
    """A synthetic sec 5.2 run: per-run constant altitude and speed errors of the two filters."""
    runs = len(dpf_err)
    x = np.zeros((runs, T + 1, 2))
    model = SimpleNamespace(theta_true=np.array([1e-3]))
    res = {n: SimpleNamespace(x=np.ones((runs, T, 2)) * np.asarray(e, float)[:, None, None],
                              diagnostics={"theta": np.full((runs, T), 1e-3)})
           for n, e in (("DPF", dpf_err), ("DEKF", dekf_err))}
    return SimpleNamespace(sim=SimpleNamespace(x=x, y=np.zeros((runs, T, 1))), results=res,
                           filters={n: SimpleNamespace(model=model) for n in res})


@pytest.mark.parametrize("dekf, holds", [([1.2, 2.4, 3.6], True), ([1.3, 2.6, 3.9], False),
                                         ([0.5, 2.0, 6.0], None)])
def test_similar_rule_on_hand_made_runs(dekf, holds):
    got, parts = V.similar(_run52([1.0, 2.0, 3.0], dekf))
    assert got is holds
    if holds is not None:
        assert parts[0][0] == pytest.approx(np.log(dekf[0]))


def test_a_lost_run_is_counted_and_weighs_against_its_filter(small):
    R0, reg0 = small
    R = copy.deepcopy(R0)
    before = V.prose(reg0, R0)["dpf_52_DPF_fail"]
    R.r52.results["DPF"].x[:, :, 0] += 1e6         # both runs 10^6 ft off: lost (> 1000 ft at T)
    c = claims_of(R)["s52_dpf_beats_dekf_alt"]
    assert c.reading_diffs["Q52=0"][0] < 0 and c.diff < 0
    assert c.verdict in ("not reproduced", "inconclusive")
    reg = V.record_claims(ClaimsRegistry(E.PAPER, choices=E.CHOICES), R)
    assert V.prose(reg, R)["dpf_52_DPF_fail"] == 2 >= before
    assert int(F.table_52_display(R).loc["DPF", "failures"]) == 2


def test_a_diverged_run_is_refused_not_dropped(small):
    R = copy.deepcopy(small[0])
    R.r51.results["DPF"].x[0, 5, 0] = np.nan
    with pytest.raises(ValueError, match="finite"):
        claims_of(R)


def test_one_run_rule():
    v = np.arange(1.0, 102.0)            # quantiles 2.5 %: 3.5, 50 %: 51, 97.5 %: 98.5
    med, half, (lo, hi) = V.one_run(v, p=10.0)
    assert (med, lo, hi) == (51.0, 3.5, 98.5) and half == pytest.approx((51 - 3.5) / 2)
    assert V.one_run(v, p=90.0)[1] == pytest.approx((98.5 - 51) / 2)   # the published value's side


def test_published_number_far_outside_is_never_reproduced(small, monkeypatch):
    R = copy.deepcopy(small[0])
    R.pub = R.pub.copy()
    R.pub.loc["RMSE x", "DPF"] = 0.01    # far below our single runs (the printed effect stays > 0)
    monkeypatch.setattr(V.published, "printed", lambda paper, table, row, col: repr(float(R.pub.loc[row, col])))
    c = claims_of(R)["s51_rmse_x_dpf"]
    assert c.published == 0.01 and c.verdict != "reproduced"
    # the fallback is the ordering DPF < DEKF (relative, printed size) under every admissible reading
    per = {v for r, v, _ in c.judgement.per_reading}
    pos = {"reproduced", "qualitatively reproduced"}
    assert c.verdict == ("qualitatively reproduced" if per <= pos else
                         "not reproduced" if per == {"not reproduced"} else "inconclusive")


# -- takeaway and prose ------------------------------------------------------------------------
def _reg(**verdicts):
    base = {"s51_dpf_beats_dekf_x": "reproduced", "fig5_dpf_robust_to_guess": "reproduced",
            "dpf_beats_liu_west_theta": "inconclusive"}
    base.update(verdicts)
    claims = [SimpleNamespace(claim_id=k, verdict=v) for k, v in base.items()]
    return SimpleNamespace(claims=claims, verdicts=lambda: dict(base))


@pytest.mark.parametrize("acc, guess, start", [
    ("reproduced", "reproduced", "On the paper's growth model the dual PF is the safer"),
    ("reproduced", "inconclusive", "The dual PF tracks the state better than the dual EKF"),
    ("inconclusive", "reproduced", "The dual PF does not depend on the initial parameter guess, but its state "
                                   "accuracy against the dual EKF is inconclusive"),
    ("not reproduced", "inconclusive", "The dual PF's advantages over the dual EKF are not established"),
])
def test_takeaway_first_sentence_follows_the_verdicts(monkeypatch, acc, guess, start):
    monkeypatch.setattr(V, "liu_west_vs_dpf", lambda R: {"θ": (-1.0, 0.1)})
    out = V.takeaway(_reg(s51_dpf_beats_dekf_x=acc, fig5_dpf_robust_to_guess=guess), None)
    assert out.startswith(start)
    assert "learns θ more accurately (z = -10.0 in our main reading" in out


@pytest.mark.parametrize("lw, pair, phrase", [
    ("reproduced", (1.0, 0.1), "It also learns θ better than a joint Liu–West filter"),
    ("not reproduced", (-1.0, 0.1), "But a joint Liu–West filter at the same number of likelihood evaluations "
                                    "learns θ more accurately (z = -10.0"),
    ("inconclusive", (0.1, 1.0), "But it is not shown to learn θ better than a joint Liu–West filter"),
])
def test_takeaway_second_sentence_follows_liu_west(monkeypatch, lw, pair, phrase):
    monkeypatch.setattr(V, "liu_west_vs_dpf", lambda R: {"θ": pair})
    out = V.takeaway(_reg(dpf_beats_liu_west_theta=lw), None)
    assert phrase in out and out.count(". ") == 1 and out.endswith(".")


@pytest.mark.parametrize("pair, word", [
    ((1.0, 0.1), "the DPF is measurably worse than the exact posterior mean"),
    ((-1.0, 0.1), "a warning sign"),
    ((0.1, 0.1), "not distinguishable from it at our z = 2 threshold"),
])
def test_prose_exact_word(small, monkeypatch, pair, word):
    R, reg = small
    monkeypatch.setattr(V, "dpf_vs_exact", lambda R: pair)
    out = V.prose(reg, R)
    assert word in out["dpf_exact_dx_word"] and out["dpf_exact_dx_z"] == pytest.approx(pair[0] / pair[1])


def test_prose_verdict_words_and_sentence(small):
    R, reg = small
    out = V.prose(reg, R)
    for c in reg.claims:
        assert out[f"dpf_v_{c.claim_id}"] == c.verdict
    n = sum(c.verdict == "inconclusive" for c in reg.claims)
    assert out["dpf_verdict_sentence"].startswith("Of 23 claims, ") and f"{n} are inconclusive" in out["dpf_verdict_sentence"]
    assert out["dpf_runs"] == 2 and out["dpf_grid_runs"] == 2 and out["dpf_lit_runs"] == 2


def test_not_held_lists_the_failing_readings():
    R51 = {("main", "m"): {("order", "x"): (3.0, 1.0)}, ("theta51", 0.2): {("order", "x"): (1.0, 1.0)},
           ("T51", 50): {("order", "x"): (-3.0, 1.0)}, ("cap", 50): {("order", "x"): (1.0, 1.0)}}
    # theta51 = 0.2 is excluded by the paper's text (l.200, l.211): not listed
    assert V.not_held_51(R51, "x") == "T51 = 50 (z = -3.0), cap = 50 (z = 1.0)"
    assert V.not_held_51({("main", "m"): {("order", "x"): (3.0, 1.0)}}, "x") == "none"


def test_the_chapter_decides_nothing_itself():
    src = (BOOK / "50_dpf.md").read_text(encoding="utf-8")
    assert "reg.add" not in src and "verdict(" not in src and "ordering_holds" not in src
    assert 'get_paper("dpf_hou2008").run(executor=POOL)' in src and "reg.save()" in src


# -- issue 31: printed effect, margins, excluded readings, plans, design choices ----------------------
@pytest.mark.parametrize("rel, expected", [
    ("printed", "reproduced"),                  # the printed relative effect attained under every reading
    (0.95, "qualitatively reproduced"),          # the direction shown, the printed size excluded
    (-0.5, "not reproduced"),                    # reversed
    (0.01, "not reproduced"),                    # not shown and the printed size excluded (se 0.01)
])
def test_the_printed_relative_effect_is_tested(small, monkeypatch, rel, expected):
    R = copy.deepcopy(small[0])
    eff = V.effects_51(R)
    assert eff["x"] == pytest.approx(1 - 0.345 / 0.626) and eff["theta"] == pytest.approx(1 - 0.00314 / 0.00585)
    monkeypatch.setattr(V, "relative", lambda a, b: (eff["x"] if rel == "printed" else rel, 0.01))
    c = claims_of(R)["s51_dpf_beats_dekf_x"]
    assert c.effect == pytest.approx(eff["x"]) and c.margin is None
    assert c.verdict == expected


def test_true_theta_rows_are_excluded_with_the_paper_line(small, monkeypatch):
    R = copy.deepcopy(small[0])
    base = V.relative
    # the theta51 = 0.2 row says the DPF is far worse; excluded, it must not move the verdict
    monkeypatch.setattr(V, "relative", lambda a, b: (0.6, 0.01))
    before = claims_of(R)["s51_dpf_beats_dekf_x"]
    R.th51[0.2].results["DPF"].x = R.th51[0.2].results["DPF"].x + 50.0
    monkeypatch.setattr(V, "relative", base)
    c = claims_of(R)["s51_dpf_beats_dekf_x"]
    assert {"theta51=0.2", "theta51=0.7", "cap=none"} <= set(c.excluded)
    assert "l.200, l.211" in c.excluded["theta51=0.2"] and "l.244" in c.excluded["cap=none"]
    assert c.reading_diffs["theta51=0.2"][0] < 0                # shown as context ...
    assert "theta51=0.2" not in {r for r, _, _ in c.judgement.per_reading}   # ... not counted
    assert before.verdict == "qualitatively reproduced"


def test_a_tie_inside_the_margin_and_too_few_runs(small, monkeypatch):
    R = copy.deepcopy(small[0])
    ess = np.full_like(R.r51.results["DPF"].diagnostics["ess_theta"], 300.0)
    R.r51.results["DPF"].diagnostics["ess_theta"] = ess
    R.x51.results[V.GA].diagnostics["ess_theta"] = ess + np.array([[0.1], [-0.1]])   # Beta - Gaussian: ±0.1
    c = claims_of(R)["beta_sampling_efficiency"]
    assert c.verdict_text() == "inconclusive (tie within the stated margin)"
    R.x51.results[V.GA].diagnostics["ess_theta"] = ess + np.array([[40.0], [-40.0]])  # huge spread, mean 0
    c = claims_of(R)["beta_sampling_efficiency"]
    assert c.verdict == "inconclusive" and c.cause == "too few runs" and c.runs_needed > 2


def test_stability_claim_follows_the_lost_runs(small):
    R = copy.deepcopy(small[0])
    # the joint filter loses every run of every sec 5.2 reading (10^6 ft off), the dual PF none
    runs52 = [R.r52, R.rd52[("Q52", "small")], R.rd52[("Q52", "printed")], R.rd52[("liu_west", R.s52["lw_deltas"][1])]]
    for run in runs52:
        if "Liu-West" in run.results:
            run.results["Liu-West"].x = run.results["Liu-West"].x + 1e6
    for run in [R.r52, R.rd52[("Q52", "small")], R.rd52[("Q52", "printed")], R.rd52[("weight", "plugin")],
                R.rd52[("roughening", R.s52["roughenings"][1])], R.rd52[("resampling", "multinomial")]]:
        run.results["DPF"].x = run.sim.x[:, 1:].copy()
    c = claims_of(R)["dual_more_stable_than_joint"]
    assert c.diff == 1.0 and c.verdict == "reproduced"
    assert claims_of(R)["dual_cheaper_than_joint"].verdict == "not reproduced"   # 2N = N_x + N_theta, not fewer


def test_plans_and_run_counts():
    from pfrepro.stats import plan_runs

    for k, (sd, size, why) in E.PILOT.items():
        assert E.PLANS[k] == plan_runs(sd, size) and why
    assert E.S51["runs"] == E.S51["sens_runs"] == E.RUNS_51 >= max(E.PLANS[k] for k in E.PLANS if not k.startswith(("s52", "dpf_beats_liu_west_theta_", "dual_")))
    assert E.S52["runs"] == E.S52["q_runs"] == E.RUNS_52 >= max(E.PLANS[k] for k in E.PLANS if k.startswith(("s52", "dpf_beats_liu_west_theta_", "dual_")))
    rows = {c.name: c for c in E.CHOICES}
    assert all(f"plan_{k}" in rows and rows[f"plan_{k}"].status == "design choice" for k in E.PLANS)


def test_fixed_rows_cite_the_paper_and_our_choices_are_design_choices():
    rows = {c.name: c for c in E.CHOICES}
    for c in rows.values():
        if c.status == "fixed by the paper":
            assert re.search(r"\bl\.\d+", c.source), (c.name, c.source)
    for name in ("resampling", "runs51", "runs52", "dekf52", "range51", "guards", "truth52"):
        assert rows[name].status == "design choice" and rows[name].reason, name
    assert rows["theta51"].status == "fixed by the paper" and "l.211" in rows["theta51"].source


def test_every_ordering_has_a_size(small):
    _, reg = small
    for c in reg.claims:
        if c.reading_diffs:
            assert (c.effect is None) != (c.margin is None), c.claim_id
            assert all(v[2] for v in c.reading_diffs.values()), c.claim_id
            assert c.readings is None, c.claim_id
    assert {c.claim_id for c in reg.claims if c.effect} == {
        "s51_rmse_x_dpf", "s51_rmse_theta_dpf", "s51_rmse_x_dekf", "s51_rmse_theta_dekf",
        "s51_dpf_beats_dekf_x", "s51_dpf_beats_dekf_theta"}


def test_fig1_and_fig3_are_drawn():
    import matplotlib.pyplot as plt

    fig = F.fig1()
    assert len(fig.axes[0].lines) == len(F.FIG1_PAIRS)
    fig3 = F.fig3()
    texts = " ".join(t.get_text() for t in fig3.axes[0].texts)
    assert "state filter" in texts and "parameter filter" in texts and "z_k" in texts
    plt.close("all")
