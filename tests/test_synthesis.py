"""Synthesis chapter (issue 13): equal-budget interpolation, decisions, ranking with ties, claims."""
import math

import numpy as np
import pandas as pd
import pytest

from pfrepro.claims import ClaimsRegistry
from pfrepro.experiments import cmspf_ning2011 as CMS
from pfrepro.experiments import gpff_zhang2016 as GPFF
from pfrepro.experiments import synthesis as S
from pfrepro.filters import ExtendedKalmanFilter, GaussianParticleFlowFilter


def fake(err: dict, cost: dict, seconds: dict | None = None, ref="ref", families=None, papers=None, bound=None):
    """A BenchResult from given per-run errors and costs (no filtering)."""
    families = families or {}
    papers = papers or {}
    methods = [S.Method(n, families.get(n, "PF" if n.startswith("PF") else n), None, papers.get(n))
               for n in err if n != ref]
    bench = S.Benchmark("fake", "fake", "none", None, 10, methods, S.Method(ref, "reference", None, bound=bound),
                        "test")
    counts = pd.DataFrame({"model evals / step": pd.Series(cost, dtype=float), "likelihoods / step": 0.0})
    secs = pd.Series(seconds if seconds is not None else {n: c * 1e-6 for n, c in cost.items()}, dtype=float)
    return S.BenchResult(bench, pd.DataFrame(err), counts, secs)


RUNS = 50
RNG = np.random.default_rng(0)
BASE = 1.0 + 0.1 * RNG.random(RUNS)


def test_pf_at_cost_interpolates_per_run_in_log_cost():
    err = {"PF(10)": 4 * BASE, "PF(100)": 2 * BASE, "M": 3 * BASE, "ref": BASE}
    r = fake(err, {"PF(10)": 20, "PF(100)": 200, "M": math.sqrt(20 * 200)})
    v, where = S.pf_at_cost(r, math.sqrt(20 * 200))
    assert where == "inside"
    np.testing.assert_allclose(v, 3 * BASE)          # halfway in log cost: mean of 4 and 2
    v, where = S.pf_at_cost(r, 20.0)
    assert where == "inside"
    np.testing.assert_allclose(v, 4 * BASE)
    # linear in cost would give a different number: the test fails for the wrong formula
    w_lin = (math.sqrt(4000) - 20) / 180
    assert not np.allclose(v.mean(), (1 - w_lin) * 4 * BASE.mean() + w_lin * 2 * BASE.mean())


def test_equal_budget_sign_units_and_tie():
    err = {"PF(10)": 4 * BASE, "PF(100)": 2 * BASE, "good": 1.5 * BASE, "bad": 3.5 * BASE,
           "same": 3 * BASE + 1e-3 * RNG.standard_normal(RUNS), "ref": BASE}
    cost = {"PF(10)": 20, "PF(100)": 200, "good": math.sqrt(4000), "bad": math.sqrt(4000), "same": math.sqrt(4000)}
    r = fake(err, cost)
    g = S.equal_budget(r, "good")
    assert g["holds"] is True
    assert g["d"] == pytest.approx((3 - 1.5) * BASE.mean() / BASE.mean())   # in units of the optimum's MSE
    assert S.equal_budget(r, "bad")["holds"] is False
    assert S.equal_budget(r, "same")["holds"] is None
    assert S._word(S.equal_budget(r, "same")) == "equal (tie)"


def test_off_frontier_keeps_only_what_survives_the_cost_mismatch():
    # frontier strongly improving with cost: not flat at either end
    err = {"PF(10)": 4 * BASE, "PF(100)": 2 * BASE, "cheap_bad": 5 * BASE, "cheap_good": 1.5 * BASE,
           "dear_good": 1.0 * BASE, "dear_bad": 3 * BASE, "ref": BASE}
    cost = {"PF(10)": 20, "PF(100)": 200, "cheap_bad": 4, "cheap_good": 4, "dear_good": 2000, "dear_bad": 2000}
    r = fake(err, cost)
    assert S.equal_budget(r, "cheap_good")["holds"] is True      # beats a dearer PF: better at equal cost too
    assert S.equal_budget(r, "cheap_bad")["holds"] is None       # loses to a dearer PF: undecided
    assert S._word(S.equal_budget(r, "cheap_bad")) == "undecided (off frontier)"
    assert S.equal_budget(r, "dear_bad")["holds"] is False       # loses to a cheaper PF: worse
    assert S.equal_budget(r, "dear_good")["holds"] is None       # beats a cheaper PF: undecided


def test_no_extrapolation_beyond_a_flat_looking_frontier_end():
    """The old "flat end" rule let the dearest PF stand in up to 10x its cost when its last two points
    did not differ; on BOT the PF kept improving beyond. Now a dearer method that beats it is undecided."""
    noise = 0.01 * RNG.standard_normal(RUNS)
    err = {"PF(100)": 2 * BASE, "PF(300)": 2 * BASE + noise, "dear_good": BASE, "ref": BASE}
    r = fake(err, {"PF(100)": 200, "PF(300)": 600, "dear_good": 600 * 1.1}, families={"dear_good": "G"})
    e = S.equal_budget(r, "dear_good")
    assert e["where"] == "above" and e["holds"] is None
    assert S._word(e) == "undecided (off frontier)"


def test_ranking_is_family_wise_and_symmetric():
    # a < b < c, each adjacent pair within noise, but a and c clearly apart: c is beaten by a only
    n = 400
    rng = np.random.default_rng(1)
    base = 1 + rng.random(n)
    noise = 0.4 * rng.standard_normal(n)
    e = {"a": base, "b": base + 0.02 + noise - noise.mean(), "c": base + 0.04, "ref": base}   # z(b - a) = 1
    r = fake(e, {"a": 1, "b": 1, "c": 1}, families={"a": "A", "b": "B", "c": "C"})
    rk = S.ranking(r)
    assert list(rk.index) == ["a", "b", "c"]
    assert rk.loc["a", "rank"] == 1 and rk.loc["b", "rank"] == 1 and rk.loc["b", "tie"] == "= a"
    assert rk.loc["c", "rank"] == 2 and rk.loc["c", "tie"] == "= b"     # beaten by a (only)
    # a difference at z = 2.2 alone is significant; among many pairs Holm no longer calls it so
    dd = 0.2 * rng.standard_normal(n)
    dd = dd - dd.mean() + 2.2 * dd.std(ddof=1) / np.sqrt(n)
    d = {"x": base, "y": base + dd}
    small = S.ranking(fake({**d, "ref": base}, {"x": 1, "y": 1}, families={"x": "X", "y": "Y"}))
    assert small.loc["y", "rank"] == 2
    zs = {}
    for i in range(6):   # six more methods, noisy and centred between x and y: no pair of them is significant
        z = 3.0 * rng.standard_normal(n)
        zs[f"z{i}"] = base + dd.mean() / 2 + z - z.mean()
    many = {**d, **zs, "ref": base}
    big = S.ranking(fake(many, {k: 1 for k in many if k != "ref"}, families={k: k for k in many}))
    assert (big["rank"] == 1).all() and "x" in big.loc["y", "tie"]


def test_ranking_lists_diverged_last():
    e = {"a": BASE, "x": np.r_[np.nan, BASE[1:]], "ref": BASE}
    rk = S.ranking(fake(e, {"a": 1, "x": 1}, families={"a": "A", "x": "X"}))
    assert list(rk.index) == ["a", "x"] and np.isnan(rk.loc["x", "rank"])
    assert "diverged (1 run)" in rk.loc["x", "tie"]


def test_distance_to_a_bound_reference():
    e = {"a": 3 * BASE, "ref": np.full(RUNS, 0.5)}
    dt = S.distance_table(fake(e, {"a": 1}, families={"a": "A"}, bound=0.5))
    assert dt.loc["a", "MSE / opt."] == pytest.approx(6 * BASE.mean())
    assert dt.loc["a", "SE"] == pytest.approx(3 * BASE.std(ddof=1) / 0.5 / math.sqrt(RUNS))


def test_benchmarks_reuse_the_chapters_builders():
    b = S.build("ung_zhang")
    m = {x.name: x for x in b.methods}
    ref = GPFF.ung_table_filters(b.model)
    assert isinstance(m["EKF"].filt, ExtendedKalmanFilter)
    assert m["UKF"].filt.__dict__.keys() == ref["UKF"].__dict__.keys()
    g = m["GPFF eq43 unif."].filt
    assert isinstance(g, GaussianParticleFlowFilter) and g.n_steps == GPFF.N_LAMBDA and g.field == "eq43"
    assert m["GPFF eq43 exp."].filt.schedule == "exponential"
    assert [x.name for x in b.methods if x.family == "PF"] == [f"PF({N})" for N in S.PF_N["ung_zhang"]]
    n = S.build("ung_ning")
    cms = {x.name: x for x in n.methods}["CMS-PF(100)"].filt
    assert cms.eta == CMS.ASSUMPTIONS["eta"] and cms.n_th == CMS.ASSUMPTIONS["n_th"]
    assert S.build("theta_hou").baseline == "Liu-West"
    with pytest.raises(ValueError, match="unknown benchmark"):
        S.build("nope")


def test_run_is_independent_of_the_batch_and_counts_are_per_step():
    b = S.build("ung_ning")
    b.methods = [x for x in b.methods if x.name in ("EKF", "PF(10)", "CMS-PF(100)", "GPFF eq43 unif.")]
    r4 = S.run_benchmark(b, runs=4, time_it=False)
    r1 = S.run_benchmark(b, runs=1, time_it=False)
    pd.testing.assert_frame_equal(r4.err.iloc[:1], r1.err)
    assert r4.counts.loc["PF(10)", "model evals / step"] == 20      # N transitions + N likelihoods
    assert r4.counts.loc["EKF", "likelihoods / step"] == 0
    assert np.all(r4.err["Grid (exact)"] <= r4.err["PF(10)"] * 5)   # sanity: the exact filter is not off


def test_record_claims_readings():
    err = {"PF(10)": 4 * BASE, "PF(100)": 2 * BASE, "M": 1.2 * BASE, "ref": BASE}
    r = fake(err, {"PF(10)": 20, "PF(100)": 200, "M": 60}, seconds={"PF(10)": 1e-5, "PF(100)": 2e-5, "M": 1e-3},
             families={"M": "CMS-PF"}, papers={"M": "cmspf_ning2011"})
    reg = ClaimsRegistry("synthesis")
    rows = S.record_claims(reg, {"fake": r})
    assert len(rows) == 1
    c = reg.claims[0]
    assert c.claim_id == "fake-m"
    # better by count (inside the frontier) -> reproduced; by time it is far above the PF's range and
    # the frontier is not flat (undecided), which is context in the note, not part of the verdict
    assert c.basis == "count" and not c.readings
    assert c.verdict == "reproduced"
    assert "at equal count" in c.note and "time" not in c.note   # claims are identical between builds


def test_synthesis_is_a_claim_source_but_not_a_paper(tmp_path):
    from pfrepro import bookinfo, published

    assert "synthesis" in published.CLAIM_SOURCES and "synthesis" not in published.PAPERS
    with pytest.raises(KeyError, match="unknown paper"):
        published.load("synthesis")
    (tmp_path / "_toc.yml").write_text("format: jb-book\nroot: book/00_intro\nchapters:\n"
                                       "  - file: book/20_a\n  - file: book/70_s\n")
    (tmp_path / "book").mkdir()
    (tmp_path / "book" / "00_intro.md").write_text("# intro\n")
    (tmp_path / "book" / "20_a.md").write_text("from pfrepro.experiments import gpff_zhang2016 as E\n")
    (tmp_path / "book" / "70_s.md").write_text("from pfrepro.experiments import synthesis as S\n")
    assert bookinfo.papers_in_book(tmp_path / "book") == {"gpff_zhang2016": "book/20_a"}   # papers only
    assert bookinfo.papers_in_book(tmp_path / "book", report=True) == {"gpff_zhang2016": "book/20_a",
                                                                       "synthesis": "book/70_s"}


def test_efficient_frontier_drops_dominated_points():
    err = {"PF(10)": 4 * BASE, "PF(30)": 3 * BASE, "PF(100)": 2 * BASE, "ref": BASE}
    r = fake(err, {"PF(10)": 20, "PF(30)": 60, "PF(100)": 200},
             seconds={"PF(10)": 2e-5, "PF(30)": 1e-5, "PF(100)": 3e-5})
    assert S.efficient_frontier(r, "count") == ["PF(10)", "PF(30)", "PF(100)"]
    assert S.efficient_frontier(r, "time") == ["PF(30)", "PF(100)"]   # PF(10): slower and worse than PF(30)


def test_run_all_in_a_pool_equals_serial():
    from pfrepro.montecarlo import process_pool

    serial = S.run_all(("ung_ning",), runs=3, time_it=False)
    with process_pool(2) as pool:
        par = S.run_all(("ung_ning",), runs=3, executor=pool, time_it=False)
    pd.testing.assert_frame_equal(serial["ung_ning"].err, par["ung_ning"].err)
    pd.testing.assert_frame_equal(serial["ung_ning"].counts, par["ung_ning"].counts)


def test_imm_benchmark_from_the_imm_chapters_record(tmp_path):
    """The manoeuvring target reuses the IMM chapter's runs: the saved record round-trips, a record
    of another size is not used, and the benchmark ranks the chapter's filters against IMMPF(2000)."""
    from pfrepro.experiments import immpfor_zhou2017 as IMM

    rec = IMM.run_synthesis_record(runs=3)
    path = tmp_path / "imm.npz"
    np.savez(path, **rec)
    back = IMM.load_synthesis_record(path, runs=3)
    assert set(back) == set(rec) and all(np.array_equal(back[k], rec[k]) for k in rec)
    assert IMM.load_synthesis_record(path, runs=5) is None
    assert IMM.load_synthesis_record(tmp_path / "missing.npz") is None
    r = S.run_imm(runs=3, record=rec, time_it=False)
    n = IMM.SCENARIO["N"]
    # IMMPF cost: r N transitions + r N likelihoods per step (3 modes)
    assert r.counts.loc[f"IMMPF({n})", "model evals / step"] == 2 * 3 * n
    assert r.counts.loc[f"IMMPFOR({n})", "model evals / step"] > 2 * 3 * n      # + density evaluations
    assert r.counts.loc["IMM-EKF", "model evals / step"] == 3 * 4                # f, F, h, H per mode
    assert r.ref == f"IMMPF({IMM.SCENARIO['N_fig5']})"
    np.testing.assert_array_equal(r.err[f"IMMPF({n})"], rec["mse/IMMPF(500)"])
    reg = ClaimsRegistry("synthesis")
    rows = S.record_claims(reg, {"imm_zhou": r})
    assert list(rows["method"]) == [f"IMMPFOR({n})"]
    assert reg.claims[0].basis == "count" and reg.claims[0].verdict in ("reproduced", "not reproduced",
                                                                          "inconclusive")


def test_bot_claim_is_decided_under_both_prior_readings():
    """A BOT claim holds only if it holds with the printed (offset) prior and with the centred one."""
    from pfrepro.choices import as_choice_map
    err = {"PF(10)": 4 * BASE, "PF(100)": 2 * BASE, "G": 1.2 * BASE, "ref": BASE}
    cost = {"PF(10)": 20, "PF(100)": 200, "G": 60}
    off = fake(err, cost, families={"G": "GPFF"}, papers={"G": "gpff_zhang2016"})
    cen = fake({**err, "G": 5 * BASE}, cost, families={"G": "GPFF"}, papers={"G": "gpff_zhang2016"})
    reg = ClaimsRegistry("synthesis", choices=S.CHOICES)
    rows = S.record_claims(reg, {"bot": off, "bot_centred": cen})
    assert list(rows["benchmark"]) == ["bot"]                       # the centred row is a reading, not a claim
    c = reg.claims[0]
    assert c.readings == {"bot_prior=offset": True, "bot_prior=centred": False} and c.depends_on == ["bot_prior"]
    assert c.verdict == "inconclusive" and "centred prior" in c.note
    assert as_choice_map(S.CHOICES)["bot_prior"].status == "reading"


def test_plural():
    assert S.plural(1, "claim") == "1 claim" and S.plural(3, "claim") == "3 claims"
    assert S.plural(1, "is", "are") == "1 is" and S.plural(0, "is", "are") == "0 are"


# -- today's methods (issue 22) --------------------------------------------------------------------
def test_todays_methods_are_their_own_family_and_leave_the_papers_verdicts_alone():
    err = {"PF(10)": 4 * BASE, "PF(100)": 2 * BASE, "M": 1.2 * BASE, "T1": 1.1 * BASE, "ref": BASE}
    r = fake(err, {"PF(10)": 20, "PF(100)": 200, "M": 60, "T1": 60}, papers={"M": "gpff_zhang2016"})
    before = S.verdicts({"fake": fake({k: v for k, v in err.items() if k != "T1"},
                                      {"PF(10)": 20, "PF(100)": 200, "M": 60}, papers={"M": "gpff_zhang2016"})})
    r.bench.methods[[m.name for m in r.bench.methods].index("T1")].today = True
    papers, today = S.verdicts({"fake": r}), S.verdicts({"fake": r}, today=True)
    assert list(papers["method"]) == ["M"] and list(today["method"]) == ["T1"]
    pd.testing.assert_frame_equal(papers, before)


def test_what_to_use_is_the_cheapest_of_rank_one():
    rng = np.random.default_rng(5)
    noise = lambda s: s * rng.standard_normal(RUNS)          # noqa: E731
    err = {"PF(10)": 3 * BASE, "PF(100)": BASE + noise(1e-3), "cheap": BASE + noise(1e-3),
           "bad": 2 * BASE, "ref": BASE}
    r = fake(err, {"PF(10)": 20, "PF(100)": 200, "cheap": 50, "bad": 5}, families={"cheap": "C", "bad": "B"},
             papers={"bad": "gpff_zhang2016"})
    r.bench.methods[[m.name for m in r.bench.methods].index("cheap")].today = True
    w = S.what_to_use({"ung_zhang": r})
    row = w.iloc[0]
    assert row["use"] == "cheap" and "PF(100)" in row["also rank 1"]
    assert row["best paper's method"].startswith("bad (rank") and row["best of today's"].startswith("cheap (rank 1")


def test_bot_reference_convergence_rule():
    """Estimates at N with independent errors of variance c/N: the rule estimates the largest N's excess
    c/N_max from d² at the middle N and checks the 1/N law's ratio."""
    rng = np.random.default_rng(3)
    runs, T = 40, 200
    truth = rng.standard_normal((runs, T, 4))
    post = truth + 0.5 * rng.standard_normal((runs, T, 4))   # the posterior mean: MSE 0.25
    c = 2.0
    x = {N: post + math.sqrt(c / N) * rng.standard_normal((runs, T, 4)) for N in (500, 2000, 8000)}
    err = {"PF(100)": np.full(runs, 1.0), "EKF": np.full(runs, 0.5), "PCRB": np.full(runs, 0.1)}
    r = fake(err, {"PF(100)": 200, "EKF": 4}, ref="PCRB", families={"EKF": "EKF"})
    out = S.bot_reference_tables({"x_true": truth, "x": x}, r)
    assert out["excess"] == pytest.approx(c / 8000, rel=0.05)
    assert out["law_ratio"][0] == pytest.approx(out["law_ratio"][1], rel=0.05)
    assert out["converged"] and out["excess_share"] < 0.01
    assert out["methods"].loc["EKF", "MSE / ref."] == pytest.approx(0.5 / (0.25 + c / 8000), rel=0.02)
    # a filter still far from the posterior mean is not taken as the reference
    x_bad = {N: post + math.sqrt(400 / N) * rng.standard_normal((runs, T, 4)) for N in (500, 2000, 8000)}
    assert not S.bot_reference_tables({"x_true": truth, "x": x_bad}, r)["converged"]
