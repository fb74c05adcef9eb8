"""The claims of the IMM chapter (Zhou et al. 2017), decided by ``pfrepro.verdicts.immpfor_zhou2017``.

Hand-built results with known outcomes: every ordering better under every reading (reproduced),
one reading that flips it (inconclusive), a tie, every reading worse (not reproduced), a lost
track in a robustness scenario, the not-checkable Table 1 numbers; the two rules that give an
adaptive reading more runs; the takeaway's and the prose's branches. Then ``run_all`` itself at
``runs=2`` on a shortened scenario (40 steps, N = 50): two seeds give different numbers and the
same claim ids, and ``pfrepro run`` writes the same claims bytes as :meth:`Paper.run`.
"""
from __future__ import annotations

import contextlib
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pfrepro.claims import ClaimsRegistry
from pfrepro.experiments import immpfor_zhou2017 as E
from pfrepro.filters.base import FilterResult
from pfrepro.models.base import Simulation
from pfrepro.verdicts import immpfor_zhou2017 as V

BOOK = Path(__file__).resolve().parents[1] / "book"

ALL_IDS = ["t1_immpf_peak", "t1_immpf_mean", "t1_immpfor_peak", "t1_immpfor_mean", "t1_or_smaller_peak",
           "t1_or_smaller_mean", "f2_or_smaller_velocity", "f3_or_smaller_x", "f3_or_smaller_y", "f4_or_smaller_vx",
           "f4_or_smaller_vy", "or_converges_more_strongly", "or_approximates_posterior", "or_posterior_sets_closer",
           "f5_more_particles_better", "f5_or_better_N2000", "equal_compute", "robust_low_noise", "robust_high_noise",
           "robust_sharp_turns", "robust_sticky_Markov", "or_beats_imm_ekf", "explanation_loss_grows_with_step"]
ORDERINGS = ALL_IDS[4:12]
TAGS = [E.main_tag(), *E.variant_tags(), "lik=mean", *E.SCENARIO_TAGS.values(), *E.HELD_READINGS]


# -- a hand-built results object ----------------------------------------------------------------------
def _stats(diff, se=1.0):
    return {k: (float(diff), float(se)) for k in (*E.STAT_KEYS, "rms")}


def _rob(holds, median=5.0, lost_a=0, lost_b=0, runs=10):
    lo, hi = {True: (1.0, 9.0), False: (-9.0, -1.0), None: (-1.0, 9.0)}[holds]
    return {"holds": holds, "median": median, "se": 1.0, "lo": lo, "hi": hi, "lost_a": lost_a, "lost_b": lost_b,
            "b_better": 7, "runs": runs}


def _main_run(runs=3):
    """Truths at the origin, the IMMPF 100 m off, IMMPFOR 90 m off, IMM-EKF/UKF 80 m; CV probable on the
    straight segments (0.8) and the manoeuvre models in the turns (0.7)."""
    T = E.SCENARIO["duration"]
    xt = np.zeros((runs, T + 1, 6))
    turn = E.mode_timeline() == 1
    mp = np.zeros((runs, T, 3))
    mp[:, ~turn] = (0.8, 0.1, 0.1)
    mp[:, turn] = (0.3, 0.5, 0.2)

    def res(err):
        x = np.zeros((runs, T, 6))
        x[..., 0] = err
        return FilterResult(x, None, {"mode_probs": mp})

    return E.Run(Simulation(xt, np.zeros((runs, T, 3))), {"IMMPF": res(100.0), "IMMPFOR": res(90.0),
                                                          "IMM-EKF": res(80.0), "IMM-UKF": res(80.0)}, 0)


def fixture(diff=5.0):
    """Every ordering of IMMPFOR over the IMMPF at ``diff`` ± 1 under every reading (``diff > 2``: IMMPFOR
    better everywhere), the IMM-EKF as much worse than IMMPFOR, the scenarios' IMMPF means 300-500 m."""
    holds = True if diff > 2 else (False if diff < -2 else None)
    runs = 3
    tags = E.variant_tags()
    pf = np.array([10.0, 12.0, 11.0])
    posterior = {key: {"IMMPF": pf, "IMMPFOR": pf - diff, **{t: pf - diff for t in tags}} for key in ("mean", "w1")}
    # per-run posterior distances: diff with a tiny spread (se 0.005 -> decided unless diff ~ 0)
    for key in posterior:
        for nm in ("IMMPFOR", *tags):
            posterior[key][nm] = posterior[key][nm] + np.array([0.0, 0.01, -0.01])
    scen_rows = {"main": 300.0, "low noise": 320.0, "high noise": 500.0, "sharp turns": 450.0, "sticky Markov": 310.0}
    counts = {k: 10 for k in E.RUN_COUNTS}
    return E.Zhou2017Results(
        counts=counts, seeds=dict(E.SEEDS), main=_main_run(runs), lik_pair=None, N_eq=600, fig5=None, robust={},
        rd=None, abl=None, fav5_pair=None, robust_fav={},
        table1=pd.DataFrame({"peak": [900.0, 800.0], "mean": [400.0, 380.0]}, index=["IMMPF", "IMMPFOR"]),
        table1_se=pd.DataFrame({"peak": [20.0, 20.0], "mean": [5.0, 5.0]}, index=["IMMPF", "IMMPFOR"]),
        table1_diff=pd.DataFrame({"peak": [100.0], "peak_se": [10.0], "mean": [20.0], "mean_se": [2.0]},
                                 index=["IMMPFOR"]),
        fig5_table=pd.DataFrame({"peak": [700.0, 650.0], "mean": [300.0, 290.0]}, index=["IMMPF", "IMMPFOR"]),
        stats={t: _stats(diff) for t in TAGS}, rob={t: _rob(holds) for t in TAGS},
        held_runs={t: 10 for t in E.HELD_READINGS},
        pairs={"rms": (diff, 1.0), "lik": (diff, 1.0), "lik_pf": (0.5, 1.0), "d5": (diff, 1.0), "fav5": (diff, 1.0),
               "dN_pf": (diff, 1.0), "dN_or": (diff, 1.0), "abl": (diff, 1.0)},
        ablation={d: (-diff * d, 1.0) for d in E.ablation_steps()},
        ekf={t: (-diff, 1.0) for t in [E.main_tag(), *tags]}, ekf_pf=(diff, 1.0),   # IMMPFOR - IMM-EKF
        equal={t: (diff, 1.0) for t in [E.main_tag(), *tags]},
        costs={"IMMPF": 300000.0, "IMMPFOR": 360000.0, "IMMPF eq": 360000.0},
        equal_means={"IMMPF": 400.0, "IMMPFOR": 380.0, "IMMPF eq": 390.0},
        posterior=posterior,
        scenarios={lab: {"change": "–", "IMMPF mean": m, "IMMPFOR mean": m - diff, "gain": (diff, 1.0),
                         "rb": _rob(holds), "fav": _rob(holds)} for lab, m in scen_rows.items()},
        scen={"f5": {t: (5, (diff, 1.0)) for t in E.SCENARIO_TAGS.values()},
              "abl": {t: (5, (diff, 1.0)) for t in E.SCENARIO_TAGS.values()}})


def decide(results):
    reg = ClaimsRegistry(E.PAPER, choices=E.CHOICES)
    V.record_claims(reg, results)
    return reg, {c.claim_id: c for c in reg.claims}


# -- the verdicts on known outcomes -------------------------------------------------------------------
def test_better_everywhere_is_reproduced_and_table1_numbers_not_checkable():
    reg, by = decide(fixture(5.0))
    assert [c.claim_id for c in reg.claims] == ALL_IDS
    for cid in ALL_IDS[4:]:
        assert by[cid].verdict == "reproduced", cid
    for cid in ALL_IDS[:4]:
        assert by[cid].verdict == "not checkable"
        # the scenario readings' IMMPF means give the range in the reason (300 and 500 m in the fixture)
        assert "move the IMMPF mean from 300 to 500 m" in by[cid].not_checkable
    assert set(by["t1_or_smaller_mean"].readings) == set(TAGS)
    assert by["t1_immpf_peak"].published_text == "910.1" and by["t1_immpf_peak"].reproduced == 900.0


def test_worse_everywhere_is_not_reproduced():
    _, by = decide(fixture(-5.0))
    for cid in ORDERINGS + ["or_approximates_posterior", "equal_compute", "or_beats_imm_ekf", "robust_high_noise"]:
        assert by[cid].verdict == "not reproduced", cid


def test_one_reading_that_flips_makes_the_ordering_inconclusive():
    R = fixture(5.0)
    stats = {t: dict(v) for t, v in R.stats.items()}
    stats["d=3"]["mean"] = (-5.0, 1.0)              # IMMPFOR worse at d = 3 only, on the mean
    _, by = decide(replace(R, stats=stats))
    assert by["t1_or_smaller_mean"].verdict == "inconclusive"
    assert by["t1_or_smaller_mean"].readings["d=3"] is False
    assert by["t1_or_smaller_peak"].verdict == "reproduced"   # the other statistics are untouched
    # the same flip in the last held reading, which is run last
    stats = {t: dict(v) for t, v in R.stats.items()}
    stats["metric=diagonal"]["tail"] = (-5.0, 1.0)
    _, by = decide(replace(R, stats=stats))
    assert by["or_converges_more_strongly"].verdict == "inconclusive"


def test_a_tie_is_undecided():
    R = fixture(5.0)
    stats = {t: dict(v) for t, v in R.stats.items()}
    stats["lik=mean"]["peak"] = (1.5, 1.0)          # inside two standard errors
    _, by = decide(replace(R, stats=stats))
    assert by["t1_or_smaller_peak"].readings["lik=mean"] is None
    assert by["t1_or_smaller_peak"].verdict == "inconclusive"
    # a tie under every reading too
    _, by = decide(fixture(0.5))
    assert by["t1_or_smaller_mean"].verdict == "inconclusive"
    assert by["or_posterior_sets_closer"].verdict == "reproduced"    # its per-run spread is tiny: 0.5 m is decided


def test_a_lost_track_decides_a_robustness_scenario():
    """The median rule (``E.robustness``): IMMPFOR better in most runs but losing three tracks is
    *worse*; decided so at both values of d the claim is not reproduced, at one only inconclusive."""
    runs, T = 40, 5
    xt = np.zeros((runs, T + 1, 6))

    def res(err):
        x = np.zeros((runs, T, 6))
        x[..., 0] = err
        return FilterResult(x, None, {})

    eb = np.full((runs, T), 90.0)
    eb[:3, -1] = 1e4                                   # 10 km at the last step: lost
    run_ = E.Run(Simulation(xt, np.zeros((runs, T, 3))), {"IMMPF": res(np.full((runs, T), 100.0)),
                                                          "IMMPFOR": res(eb)}, 0)
    rb = E.robustness(run_, seed=1)
    assert rb["lost_b"] == 3 and rb["median"] > 0 and rb["holds"] is False
    R = fixture(5.0)
    scen = {k: dict(v) for k, v in R.scenarios.items()}
    scen["sharp turns"].update(rb=rb, fav=rb)
    _, by = decide(replace(R, scenarios=scen))
    assert by["robust_sharp_turns"].verdict == "not reproduced"
    assert "lost tracks 3 (IMMPFOR) vs 0 (IMMPF)" in by["robust_sharp_turns"].note
    scen["sharp turns"].update(fav=_rob(True))
    _, by = decide(replace(R, scenarios=scen))
    assert by["robust_sharp_turns"].verdict == "inconclusive"
    assert by["robust_low_noise"].verdict == "reproduced"


def test_scenario_readings_of_fig5_and_the_ablation():
    R = fixture(5.0)
    scen = {"f5": dict(R.scen["f5"]), "abl": dict(R.scen["abl"])}
    scen["f5"]["noise=high"] = (10, (-4.0, 1.0))
    _, by = decide(replace(R, scen=scen))
    assert by["f5_more_particles_better"].verdict == "inconclusive"
    assert by["f5_more_particles_better"].readings[V.MAIN_SCENARIO] is True
    assert "noise=high: -4.0 ± 1.0 m on 10 runs" in by["f5_more_particles_better"].note
    assert by["explanation_loss_grows_with_step"].verdict == "reproduced"


# -- how many runs an adaptive reading gets -------------------------------------------------------------
def test_held_readings_get_more_runs_only_where_the_others_agree():
    agree = {t: _stats(5.0) for t in TAGS[:3]}
    st = _stats(5.0)
    assert V.held_needs_more_runs(agree, st) is False          # decided: no more runs
    st["tail"] = (1.0, 1.0)
    assert V.held_needs_more_runs(agree, st) is True           # undecided where the others agree
    disagree = {**agree, "d=3": {**_stats(5.0), "tail": (-5.0, 1.0)}}
    assert V.held_needs_more_runs(disagree, st) is False       # already inconclusive: fewer runs suffice


def test_scenario_readings_get_more_runs_only_where_the_readings_so_far_agree():
    assert V.scenario_needs_more_runs((1.0, 1.0), {"main": True, "noise=low": True}) is True
    assert V.scenario_needs_more_runs((5.0, 1.0), {"main": True}) is False
    assert V.scenario_needs_more_runs((1.0, 1.0), {"main": True, "noise=low": False}) is False
    assert V.scenario_needs_more_runs((1.0, 1.0), {"main": None}) is False


# -- the takeaway and the prose -----------------------------------------------------------------------
def test_takeaway_follows_the_verdicts():
    reg, _ = decide(fixture(5.0))
    text = V.takeaway(reg, fixture(5.0))
    assert text.startswith("IMMPFOR's smaller mean position error held under all 16 readings")
    assert "at equal computation it still wins" in text
    R = fixture(-5.0)
    reg, _ = decide(R)
    text = V.takeaway(reg, R)
    assert text.startswith("IMMPFOR was not more accurate than the plain IMMPF under any of the 16 readings")
    assert "wins under none of 8 readings (loses under 8), so a plain IMMPF with more particles" in text
    R = fixture(5.0)
    stats = {t: dict(v) for t, v in R.stats.items()}
    stats["d=3"] = _stats(-5.0)
    stats["d=0.01"] = _stats(0.5)
    equal = {**R.equal, "d=3": (-5.0, 1.0), "d=0.1": (0.5, 1.0)}
    R = replace(R, stats=stats, equal=equal)
    reg, _ = decide(R)
    text = V.takeaway(reg, R)
    assert "depends on settings the paper does not print (of 16 readings it is better under 14, worse under 1 and " \
           "tied under 1)" in text
    assert text.endswith("at equal computation it wins under 6 and loses under 1 of 8 readings.")


def _chapter_glue_keys():
    txt = (BOOK / "60_immpf.md").read_text(encoding="utf-8")
    return set(re.findall(r"\{glue:[a-z]+\}`([a-zA-Z0-9_]+)", txt))


#: glued by the chapter's own cells (the visible numerical checks, against-today, the execution time)
CHAPTER_GLUED = {"imm_thm_ratio_min", "imm_thm_ratio_max", "imm_mix_c", "imm_mix_m00", "imm_mix_colsum", "imm_ct_dev",
                 "imm_one_model_diff", "imm_conv_x_10000", "imm_conv_u_10000", "imm_conv_x_100", "imm_today_runs",
                 "imm_today_sentence", "imm_exec_seconds"}


def test_prose_glues_every_key_of_the_chapter_and_follows_the_numbers():
    R = fixture(5.0)
    reg, _ = decide(R)
    p = V.prose(reg, R)
    missing = _chapter_glue_keys() - set(p) - CHAPTER_GLUED
    assert not missing, f"glue keys of the chapter that nothing glues: {sorted(missing)}"
    assert p["imm_main_word"] == "goes the paper's way"
    assert p["imm_d_better"] == "1e-06, 0.01, 0.1, 0.3, 1, 3" and p["imm_d_worse"] == "none"
    assert p["imm_rob_better"] == 5 and p["imm_rob_tie"] == "0 scenarios"
    assert p["imm_n_summary"] == "19 reproduced, 0 qualitatively reproduced, 0 not reproduced, 0 inconclusive, 4 not checkable"
    assert p["imm_frac_below"] == 100.0                         # IMMPFOR's curve is below at every step
    assert p["imm_modes_cv_pf"] == pytest.approx(0.8) and p["imm_modes_turn_pf"] == pytest.approx(0.7)
    assert p["imm_t1_ekf_mean"] == pytest.approx(80.0)
    assert "is below" in p["imm_ekf_sentence_or"] and "(IMMPFOR − the IMM-EKF = -5.0 ± 1.0 m)" in p["imm_ekf_sentence_or"]
    stats = {t: dict(v) for t, v in R.stats.items()}
    stats["d=3"] = _stats(-5.0)
    stats[E.main_tag()] = _stats(0.5)
    R2 = replace(R, stats=stats)
    reg2, _ = decide(R2)
    p2 = V.prose(reg2, R2)
    assert p2["imm_d_worse"] == "3" and p2["imm_d_tie"] == "1" and p2["imm_main_word"] == "is undecided"
    assert p2["imm_m_vel_word"] == "a tie at two standard errors"
    assert p2["imm_v_mean"] == "inconclusive"


# -- run_all itself, on a shortened scenario ------------------------------------------------------------
@contextlib.contextmanager
def _short_scenario():
    """40 steps (turns at 10-14 and 25-29 s), N = 50 (100 in Fig. 5, 200 for the reference): the same
    experiments in seconds. Restores the module's settings afterwards."""
    saved = dict(E.SCENARIO), E.TAIL, E.POST_STEPS
    E.SCENARIO.update(duration=40, left_turn=(10, 14), right_turn=(25, 29), N=50, N_fig5=100, N_ref=200)
    E.TAIL, E.POST_STEPS = (31, 40), (20, 40)
    try:
        yield
    finally:
        E.SCENARIO.clear()
        E.SCENARIO.update(saved[0])
        E.TAIL, E.POST_STEPS = saved[1], saved[2]


@pytest.fixture(scope="module")
def short_runs():
    from pfrepro.papers import get_paper

    with _short_scenario():
        yield {s: get_paper("immpf").run(runs=2, seeds=s) for s in (1, 2)}


def test_run_all_seeds_change_the_numbers_not_the_claims(short_runs):
    (r1, reg1), (r2, reg2) = short_runs[1], short_runs[2]
    assert [c.claim_id for c in reg1.claims] == [c.claim_id for c in reg2.claims] == ALL_IDS
    assert r1.seeds == {"main": 1, "robust": 2, "checks": 3} and r2.seeds["main"] == 2
    assert r1.counts == {k: 2 for k in E.RUN_COUNTS} and r1.settings["runs"] == 2
    assert not np.array_equal(r1.main.sim.x, r2.main.sim.x)
    assert not np.array_equal(r1.robust["low noise"].sim.x, r2.robust["low noise"].sim.x)
    assert r1.table1.loc["IMMPF", "mean"] != r2.table1.loc["IMMPF", "mean"]
    assert [c.reproduced for c in reg1.claims[:4]] != [c.reproduced for c in reg2.claims[:4]]
    assert set(r1.stats) == set(TAGS) and list(r1.stats)[:2] == [E.main_tag(), E.d_tags()[0]]
    with pytest.raises(ValueError, match=">= 2"):
        E.run_counts(1)


def test_command_line_writes_the_chapter_claims(short_runs, tmp_path, capsys):
    from pfrepro import cli

    with _short_scenario():
        assert cli.main(["run", "immpf", "--runs", "2", "--seed", "1", "--out", str(tmp_path / "cli")]) == 0
    out = capsys.readouterr().out
    assert "the chapter's claims, decided by the same code" in out
    for f in ("table1.csv", "fig1.png", "fig2.png", "fig3.png", "fig4.png", "fig5.png"):
        assert (tmp_path / "cli" / f).stat().st_size > 0
    _, reg = short_runs[1]
    path = reg.save(tmp_path / "chapter")
    assert (tmp_path / "cli" / "claims" / path.name).read_bytes() == path.read_bytes()
    assert ((tmp_path / "cli" / "claims" / "choices" / path.name).read_bytes()
            == (tmp_path / "chapter" / "choices" / path.name).read_bytes())
