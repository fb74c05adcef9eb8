"""Synthesis experiments (pfrepro.experiments.synthesis): the benchmarks reuse the chapters' builders,
runs are independent of the batch and the pool, the manoeuvring target reuses the IMM chapter's record,
run_all's seeds travel as arguments. The verdicts: tests/test_verdicts_synthesis.py."""

import numpy as np
import pandas as pd
import pytest

from pfrepro.claims import ClaimsRegistry
from pfrepro.experiments import cmspf_ning2011 as CMS
from pfrepro.experiments import gpff_zhang2016 as GPFF
from pfrepro.experiments import synthesis as S
from pfrepro.verdicts import synthesis as V
from pfrepro.filters import ExtendedKalmanFilter, GaussianParticleFlowFilter


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


def test_run_all_in_a_pool_equals_serial():
    from pfrepro.montecarlo import process_pool

    serial = S.run_benchmarks(("ung_ning",), runs=3, time_it=False)
    with process_pool(2) as pool:
        par = S.run_benchmarks(("ung_ning",), runs=3, executor=pool, time_it=False)
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
    reg = V.record_claims(ClaimsRegistry("synthesis"), {"imm_zhou": r})
    assert [c.claim_id for c in reg.claims] == [f"imm_zhou-immpfor-{n}"]
    assert reg.claims[0].basis == "count" and reg.claims[0].verdict in ("reproduced", "not reproduced",
                                                                          "inconclusive")


def test_run_all_seeds_travel_as_arguments():
    """Two base seeds give other truths (every number moves) and the same claims; SEEDS is left alone."""
    seeds_before = dict(S.SEEDS)
    keys = ("ung_li", "ung_ning")
    a = S.run_all(runs=2, seeds=1, keys=keys, time_it=False)
    b = S.run_all(runs=2, seeds=2, keys=keys, time_it=False)
    assert S.SEEDS == seeds_before
    assert list(a) == list(keys) and a.settings["seeds"]["ung_zhang"] == 1 and b.settings["seeds"]["ung_zhang"] == 2
    assert a.settings["seeds"]["ung_li"] == 2 and a["ung_li"].bench.seed == 2
    for k in keys:
        assert a[k].err.shape == b[k].err.shape == (2, a[k].err.shape[1])
        assert not np.any(np.isclose(a[k].err.to_numpy(), b[k].err.to_numpy(), rtol=1e-12, atol=0))
    ra = V.record_claims(ClaimsRegistry(S.PAPER, choices=S.CHOICES), a)
    rb = V.record_claims(ClaimsRegistry(S.PAPER, choices=S.CHOICES), b)
    assert [c.claim_id for c in ra.claims] == [c.claim_id for c in rb.claims] and len(ra.claims) == 6
    # a benchmark run alone with seed s is the same benchmark inside run_all with that seed
    one = S.run_benchmark(S.build("ung_ning", a.settings["seeds"]), runs=2, time_it=False)
    pd.testing.assert_frame_equal(one.err, a["ung_ning"].err)
    with pytest.raises(ValueError, match="unknown benchmark"):
        S.run_all(runs=2, keys=("nope",))


def test_run_all_runs_replaces_every_count():
    r = S.run_all(runs=1, keys=("ung_ning",), time_it=False)
    assert r.settings["runs"] == 1 and r.settings["runs_of"] == {"ung_ning": 1}
    assert r.ref_conv is None and np.isnan(r.pcrb_x0_known)     # the bearings-only runs only with "bot"
    assert dict(r) == r.benchmarks and len(r) == 1


def test_the_bearings_only_reference_is_a_pf_given_the_truths_start():
    """The yardstick on bearings-only: a PF whose prior is the truth's start x0 (every run starts there), the same
    filter and name on both starts, so the centred start shares the printed start's reference numbers."""
    b, c = S.build("bot", pcrb_runs=2), S.build("bot_centred", pcrb_runs=2)
    for bench in (b, c):
        f = bench.reference.filt
        assert isinstance(f, S.BootstrapParticleFilter) and f.n_particles == S.BOT_REF_N
        np.testing.assert_array_equal(f.m0, bench.model.x0)
        assert np.max(f.P0) <= 1e-12 and bench.model.truth_init == "fixed"
        assert bench.reference.name == S.BOT_REF_NAME and bench.pcrb > 0
    assert b.reference.bound is None and not b.reference.timed


def test_reference_convergence_runs_independent_replicates_on_the_benchmarks_truths():
    out = S.bot_reference_convergence(runs=2, Ns=(20, 40))
    assert set(out["x"]) == {(20, 0), (20, 1), (40, 0), (40, 1)}
    assert not np.array_equal(out["x"][(20, 0)], out["x"][(20, 1)])      # independent streams
    bench = S.build("bot", pcrb_runs=2)
    from pfrepro.montecarlo import run_monte_carlo
    mc = run_monte_carlo(bench.model, {"PF(10)": S.BootstrapParticleFilter(bench.model, 10)}, 200, 2,
                         S.SEEDS["bot"], progress=False)
    np.testing.assert_array_equal(out["x_true"], mc.x_true)             # the benchmark's first truths
