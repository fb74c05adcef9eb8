"""Metrics on hand-computable arrays; the verdict rule branch by branch; claims round trip; published data."""
from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from pfrepro import published
from pfrepro.claims import VERDICTS, Claim, ClaimsRegistry, claims_dir, load_all_claims, verdict
from pfrepro.metrics import (mc_summary, mse, mse_per_component, mse_per_component_over_time, rmse,
                             rmse_over_time)

# runs = 2, T = 2, dim_x = 2; squared errors run 0: [[1, 0], [0, 4]], run 1: [[9, 0], [0, 0]]
X_TRUE = np.zeros((2, 2, 2))
X_EST = np.array([[[1.0, 0.0], [0.0, -2.0]], [[3.0, 0.0], [0.0, 0.0]]])


def test_mse_eq56():
    np.testing.assert_allclose(mse(X_TRUE, X_EST), [5 / 4, 9 / 4], rtol=1e-15)
    # errors, not values: shifting both arguments changes nothing
    np.testing.assert_allclose(mse(X_TRUE + 7.0, X_EST + 7.0), [5 / 4, 9 / 4], rtol=1e-14)


def test_mse_per_component_over_time_eq61():
    np.testing.assert_allclose(mse_per_component_over_time(X_TRUE, X_EST), [[5.0, 0.0], [0.0, 2.0]], rtol=1e-15)


def test_mse_per_component():
    np.testing.assert_allclose(mse_per_component(X_TRUE, X_EST), [[0.5, 2.0], [4.5, 0.0]], rtol=1e-15)


def test_rmse_and_rmse_over_time():
    np.testing.assert_allclose(rmse(X_TRUE, X_EST), [math.sqrt(2.5), math.sqrt(4.5)], rtol=1e-15)
    np.testing.assert_allclose(rmse_over_time(X_TRUE, X_EST), [math.sqrt(5.0), math.sqrt(2.0)], rtol=1e-15)


def test_metric_shape_errors():
    for fn in (mse, mse_per_component_over_time, mse_per_component, rmse, rmse_over_time):
        with pytest.raises(ValueError, match=r"must both be \(runs, T, dim_x\)"):
            fn(X_TRUE, X_EST[:, :1])
        with pytest.raises(ValueError, match=r"must both be \(runs, T, dim_x\)"):
            fn(X_TRUE[..., 0], X_EST[..., 0])


def test_mc_summary():
    s = mc_summary([1.0, 2.0, 3.0, 4.0])
    assert s.mean == 2.5 and s.n == 4
    np.testing.assert_allclose(s.std, math.sqrt(5 / 3), rtol=1e-15)
    np.testing.assert_allclose(s.se, math.sqrt(5 / 3) / 2, rtol=1e-15)
    lo, hi = s.interval()
    np.testing.assert_allclose([lo, hi], [2.5 - 1.96 * s.se, 2.5 + 1.96 * s.se], rtol=1e-15)
    np.testing.assert_allclose(s.interval(1.0), (2.5 - s.se, 2.5 + s.se), rtol=1e-15)
    assert mc_summary(np.ones((2, 3))).n == 6  # flattened
    one = mc_summary([3.0])
    assert one.mean == 3.0 and math.isnan(one.std) and math.isnan(one.se)
    with pytest.raises(ValueError, match="no values"):
        mc_summary([])


# ------------------------------------------------------------------ verdict rule -----------------
@pytest.mark.parametrize("kwargs, expected", [
    # numeric: inside 2 standard errors (no relative tolerance)
    (dict(published=10.0, reproduced=11.0, se=0.6, rel_tol=None), "reproduced"),
    (dict(published=10.0, reproduced=11.0, se=0.5, rel_tol=None), "reproduced"),      # exactly 2 se
    (dict(published=10.0, reproduced=11.0, se=0.49, rel_tol=None), "not reproduced"),
    # numeric: inside the relative tolerance (default 10 %)
    (dict(published=10.0, reproduced=10.9), "reproduced"),
    (dict(published=10.0, reproduced=9.0), "reproduced"),                              # exactly 10 %
    (dict(published=-10.0, reproduced=-10.9), "reproduced"),                           # |published|
    (dict(published=10.0, reproduced=11.5), "not reproduced"),
    (dict(published=10.0, reproduced=11.5, rel_tol=0.2), "reproduced"),
    # numbers disagree: the qualitative statement decides between the two lower verdicts
    (dict(published=10.0, reproduced=20.0, se=1.0, qualitative=True), "qualitatively reproduced"),
    (dict(published=10.0, reproduced=20.0, se=1.0, qualitative=False), "not reproduced"),
    (dict(published=10.0, reproduced=20.0, se=1.0, qualitative=None), "not reproduced"),
    # a zero, negative or non-finite se gives no interval
    (dict(published=10.0, reproduced=10.5, se=0.0, rel_tol=None), "not reproduced"),
    (dict(published=10.0, reproduced=10.5, se=-1.0, rel_tol=None), "not reproduced"),
    (dict(published=10.0, reproduced=10.5, se=float("nan"), rel_tol=None), "not reproduced"),
    # no published number: purely qualitative
    (dict(qualitative=True), "reproduced"),
    (dict(qualitative=False), "not reproduced"),
    (dict(), "not checkable"),
    (dict(reproduced=3.0, se=0.1), "not checkable"),
    (dict(published=3.0), "not checkable"),
    (dict(published=float("nan"), reproduced=3.0), "not checkable"),
    (dict(published=3.0, reproduced=float("inf"), qualitative=True), "reproduced"),
    # numpy scalars are numbers
    (dict(published=np.float32(10.0), reproduced=np.float64(10.5)), "reproduced"),
    (dict(published=np.int64(10), reproduced=np.float32(12.0), qualitative=np.bool_(True)),
     "qualitatively reproduced"),
])
def test_verdict_branches(kwargs, expected):
    assert verdict(**kwargs) == expected
    assert expected in VERDICTS


def test_claim_verdict_property():
    c = Claim("p", "c1", "text", published=1.0, reproduced=1.05)
    assert c.verdict == "reproduced" and c.as_row()["verdict"] == "reproduced"


# ------------------------------------------------------------------ registry round trip ----------
def test_registry_save_load_round_trip(tmp_path):
    reg = ClaimsRegistry("paper_a")
    reg.add("c1", "MSE table", published=1.0, reproduced=np.float64(1.05), se=np.float32(0.01), source="Table 1")
    reg.add("c2", "ordering holds", qualitative=np.bool_(True))
    reg.add("c3", "number off, trend holds", published=2.0, reproduced=3.0, se=float("nan"), qualitative=True)
    reg.add("c4", "nothing to compare")
    with pytest.raises(ValueError, match="already recorded"):
        reg.add("c1", "again")
    path = reg.save(tmp_path)
    assert path == tmp_path / "paper_a.json"
    ClaimsRegistry("paper_b").save(tmp_path)  # an empty chapter
    reg_c = ClaimsRegistry("paper_c")
    reg_c.add("x", "fails", published=1.0, reproduced=5.0, se=0.1)
    reg_c.save(tmp_path)

    # a stale verdict written in the file is ignored: verdicts are recomputed on load
    rows = json.loads(path.read_text())
    rows[3]["verdict"] = "reproduced"
    path.write_text(json.dumps(rows))

    df = load_all_claims(tmp_path)
    assert list(df["paper"]) == ["paper_a"] * 4 + ["paper_c"]
    assert list(df["verdict"]) == ["reproduced", "reproduced", "qualitatively reproduced", "not checkable",
                                   "not reproduced"]
    assert df.loc[0, "se"] == pytest.approx(0.01, rel=1e-6) and df.loc[0, "source"] == "Table 1"
    assert df.loc[2, "se"] is None or pd.isna(df.loc[2, "se"])  # NaN saved as null
    pd.testing.assert_frame_equal(df[df.paper == "paper_a"].reset_index(drop=True),
                                  reg.to_frame().reset_index(drop=True), check_dtype=False)


def test_empty_claims_dir_and_env_var(tmp_path, monkeypatch):
    df = load_all_claims(tmp_path)
    assert df.empty and "verdict" in df.columns and "claim_id" in df.columns
    monkeypatch.setenv("PFREPRO_CLAIMS_DIR", str(tmp_path / "claims"))
    assert claims_dir() == tmp_path / "claims"
    reg = ClaimsRegistry("paper_env")
    reg.add("c", "t", qualitative=False)
    assert reg.save() == tmp_path / "claims" / "paper_env.json"
    assert list(load_all_claims()["verdict"]) == ["not reproduced"]


# ------------------------------------------------------------------ published numbers ------------
def test_published_unknown_paper():
    with pytest.raises(KeyError, match="unknown paper 'nobody2099'"):
        published.load("nobody2099")
    with pytest.raises(KeyError, match="unknown paper"):
        published.value("nobody2099", "Table 1", "a", "b")


@pytest.mark.parametrize("paper", sorted(published.PAPERS))
def test_published_known_papers_load_or_say_missing(paper):
    try:
        df = published.load(paper)
    except FileNotFoundError as err:
        assert "no published numbers recorded" in str(err)
        return
    assert list(df.columns) == ["paper", "table", "row", "column", "value", "note"]
    assert (df["paper"] == paper).all() and len(df) > 0
    assert pd.api.types.is_numeric_dtype(df["value"])


@pytest.fixture
def fake_paper(tmp_path, monkeypatch):
    d = tmp_path / "data" / "published"
    d.mkdir(parents=True)
    (d / "fake2000.csv").write_text(
        "# comment line\n"
        "table,row,column,value,note\n"
        "Table 1,PF,MSE,1.5,\n"
        "Table 1,PF,time,0.2,seconds\n"
        "Table 1,UKF,MSE,2.5,\n"
        "Table 1,UKF,time,0.01,\n"
        "Fig. 2,N=100,RMSE,3.0,read off the plot\n", encoding="utf-8")
    monkeypatch.setitem(published.PAPERS, "fake2000", "a test paper")
    monkeypatch.setattr(published.resources, "files", lambda pkg: tmp_path)
    published.load.cache_clear()
    yield "fake2000"
    published.load.cache_clear()


def test_published_table_and_value(fake_paper):
    assert published.value(fake_paper, "Table 1", "UKF", "MSE") == 2.5
    t = published.table(fake_paper, "Table 1")
    assert list(t.index) == ["PF", "UKF"] and list(t.columns) == ["MSE", "time"]
    assert t.loc["PF", "time"] == 0.2
    with pytest.raises(KeyError, match="no published table 'Table 9'"):
        published.table(fake_paper, "Table 9")
    with pytest.raises(KeyError, match="no unique entry"):
        published.value(fake_paper, "Table 1", "EKF", "MSE")


def test_ordering_claims_on_paired_differences():
    from pfrepro.claims import ClaimsRegistry, ordering_holds, verdict
    from pfrepro.stats import paired_difference

    a = np.array([1.0, 2.0, 3.0, 4.0])
    d, se = paired_difference(a + 1.0, a)  # constant difference: se 0
    assert (d, se) == (1.0, 0.0)
    assert ordering_holds(1.0, 0.4) is True and ordering_holds(-1.0, 0.4) is False
    assert ordering_holds(0.5, 0.4) is None
    assert verdict(diff=0.5, diff_se=0.4) == "inconclusive"
    assert verdict(diff=1.0, diff_se=0.4) == "reproduced"
    assert verdict(diff=-1.0, diff_se=0.4) == "not reproduced"
    assert verdict(published=10.0, reproduced=20.0, se=1.0, diff=1.0, diff_se=0.1) == "qualitatively reproduced"
    assert verdict(published=10.0, reproduced=20.0, se=1.0, diff=0.1, diff_se=0.1) == "inconclusive"
    assert verdict(published=10.0, reproduced=10.5, se=1.0, diff=0.1, diff_se=0.1) == "reproduced"
    reg = ClaimsRegistry("x")
    with pytest.raises(ValueError, match="either qualitative or diff"):
        reg.add("c", "t", qualitative=True, diff=1.0, diff_se=0.1)


def test_published_se_widens_the_interval():
    # |11 - 10| = 1 > 2 * 0.4 but <= 2 * sqrt(0.4^2 + 0.3^2) = 1.0
    assert verdict(published=10.0, reproduced=11.0, se=0.4, rel_tol=None) == "not reproduced"
    assert verdict(published=10.0, reproduced=11.0, se=0.4, rel_tol=None, published_se=0.3) == "reproduced"
    assert verdict(published=10.0, reproduced=11.0, se=0.4, rel_tol=None, published_se=0.29) == "not reproduced"
    # the published SE alone also gives an interval (our se missing or zero)
    assert verdict(published=10.0, reproduced=11.0, se=None, rel_tol=None, published_se=0.5) == "reproduced"
    assert verdict(published=10.0, reproduced=11.0, se=0.0, rel_tol=None, published_se=0.49) == "not reproduced"
    c = Claim("p", "c", "t", published=10.0, reproduced=11.0, se=0.4, rel_tol=None, published_se=0.3)
    assert c.verdict == "reproduced"


def test_count_basis_decides_on_the_count_only():
    # the published time ratio is context: a count that holds reproduces even far from it
    assert verdict(published=0.3, reproduced=2.0, qualitative=True, basis="count") == "reproduced"
    assert verdict(published=2.0, reproduced=2.0, qualitative=False, basis="count") == "not reproduced"
    assert verdict(published=2.0, reproduced=2.0, basis="count") == "inconclusive"
    assert verdict(diff=0.1, diff_se=1.0, basis="count") == "inconclusive"
    with pytest.raises(ValueError, match="basis"):
        verdict(qualitative=True, basis="time")


def test_readings_and_weakest_ordering():
    from pfrepro.claims import readings_hold, weakest_ordering

    assert verdict(readings={"a": True, "b": True}) == "reproduced"
    assert verdict(readings={"a": False, "b": False}) == "not reproduced"
    assert verdict(readings={"a": True, "b": False}) == "inconclusive"
    assert verdict(readings={"a": True, "b": None}) == "inconclusive"
    assert verdict(published=10.0, reproduced=10.1, readings={"a": True, "b": False}) == "reproduced"
    assert readings_hold({"x": np.bool_(True)}) is True
    with pytest.raises(ValueError, match="either qualitative"):
        verdict(qualitative=True, readings={"a": True})
    # all hold -> the weakest holds; one contradicted -> contradicted; else undecided
    assert weakest_ordering([(3.0, 1.0), (5.0, 1.0)]) == (3.0, 1.0)
    assert weakest_ordering([(3.0, 1.0), (-5.0, 1.0), (0.1, 1.0)]) == (-5.0, 1.0)
    assert weakest_ordering([(3.0, 0.0), (1.0, 1.0)]) == (1.0, 1.0)  # se 0: z = +inf
    with pytest.raises(ValueError):
        weakest_ordering([])


def test_claims_table(tmp_path):
    from pfrepro.claims import claims_table

    reg = ClaimsRegistry("paper_x")
    reg.add("num", "a number", published=10.0, reproduced=10.5, se=0.2, published_se=0.1, note="n1")
    reg.add("ord", "A beats B", diff=0.02, diff_se=0.03)
    reg.add("cost", "A costs less", reproduced=0.5, published=0.3, qualitative=True, basis="count")
    reg.add("read", "a conclusion", readings={"R = 10": True, "R = 100": False})
    t = claims_table(reg)
    assert list(t.columns) == ["id", "claim", "ours", "published", "judged", "verdict", "test"]
    assert t["verdict"].tolist() == ["reproduced", "inconclusive (too few runs)", "reproduced",
                                    "inconclusive (depends on the reading)"]
    # what was judged: a cost claim's numbers (0.5 vs 0.3) are context, its ordering decides
    assert t["judged"].tolist() == ["value", "ordering (paired)", "ordering, on counts (numbers: context)",
                                    "statement under every reading"]
    assert t.loc[0, "ours"] == "10.50 ± 0.20" and t.loc[0, "published"] == "10.00 ± 0.10"
    assert "√(se²+se_pub²)" in t.loc[0, "test"] and "n1" in t.loc[0, "test"]
    assert t.loc[1, "ours"] == "Δ 0.020 ± 0.030" and "z = 0.7" in t.loc[1, "test"]
    assert "cost count" in t.loc[2, "test"]
    assert "R = 10 → holds" in t.loc[3, "test"] and "R = 100 → fails" in t.loc[3, "test"]
    # the same table from saved claims (the scorecard's path), with the paper column
    reg.save(tmp_path)
    t2 = claims_table(load_all_claims(tmp_path), paper=True)
    assert t2.drop(columns="paper").equals(t)
    assert (t2["paper"] == "paper_x").all()


def test_claims_table_says_what_was_judged():
    """An ordering claim that shows a number pair far apart (9.74 vs 3.48) says that the ordering
    was judged, not the values; every kind of claim gets its word."""
    from pfrepro.claims import Claim, claims_table

    def judged(**kw):
        return Claim("p", "c", "text", **kw).judged()

    assert judged(published=3.48, reproduced=9.74, basis="count", readings={"a": True, "b": True}) == \
        "ordering, on counts under every reading (numbers: context)"
    assert judged(basis="count", qualitative=True) == "ordering, on counts"
    assert judged(published=1.0, reproduced=1.05, se=0.1) == "value"
    assert judged(published=1.0, reproduced=3.0, se=0.1, qualitative=True) == "value, else ordering"
    assert judged(published=1.0, reproduced=3.0, se=0.1, diff=1.0, diff_se=0.1) == "value, else ordering"
    assert judged(published=1.0, reproduced=1.0, se=0.1, reading_values={"r": [1.0, 0.1]}) == \
        "value under every reading"
    assert judged(diff=1.0, diff_se=0.1, readings={"a": True}) == "ordering under every reading"
    assert judged(readings={"a": True}) == "statement under every reading"
    assert judged(qualitative=True) == "statement"
    assert judged(qualitative=True, reproduced=2.0) == "statement, the number as context"
    assert judged(published=1.0, reproduced=2.0, not_checkable="scenario unknown") == "not checkable"
    assert judged() == "–"
    # the row of the scorecard: the pair is shown, the verdict rests on the ordering, and the row says so
    c = Claim("p", "cost", "A's cost grows more slowly", published=3.48, reproduced=9.74, basis="count",
              qualitative=True)
    row = claims_table([c]).iloc[0]
    assert (row["ours"], row["published"], row["verdict"]) == ("9.74", "3.48", "reproduced")
    assert row["judged"].startswith("ordering")


def test_published_se_helpers():
    assert published.se_from_std(3.0, 100) == 0.3
    with pytest.raises(ValueError):
        published.se_from_std(3.0, 1)
    t = published.table("cmspf_ning2011", "Table 1")
    rows = [str(i) for i in range(1, 21)]
    v = t.loc[rows, "N=10 PF"].to_numpy(float)
    assert published.per_run_se("cmspf_ning2011", "Table 1", "N=10 PF", range(1, 21)) == pytest.approx(
        v.std(ddof=1) / math.sqrt(20), rel=1e-15)
    # row 22 is the printed variance of rows 1-20: the two readings of the spread agree
    assert published.per_run_se("cmspf_ning2011", "Table 1", "N=10 PF", range(1, 21)) == pytest.approx(
        math.sqrt(t.loc["22", "N=10 PF"] / 20), rel=1e-3)


def test_paired_difference_refuses_unequal_run_sets():
    """The book-wide common-runs rule (claims.common_runs): every paired difference goes through it."""
    import pandas as pd
    from pfrepro.stats import CommonRunsError, common_runs, paired_difference
    a = pd.Series([1.0, 2.0, 4.0], index=pd.RangeIndex(1, 4, name="run"))
    b = pd.Series([0.5, 1.5, 3.0], index=pd.RangeIndex(1, 4, name="run"))
    assert paired_difference(a, b)[0] == pytest.approx(2.0 / 3.0)
    with pytest.raises(CommonRunsError):           # runs 2-4 against runs 1-3: same size, other runs
        paired_difference(a, pd.Series(b.to_numpy(), index=pd.RangeIndex(2, 5, name="run")))
    with pytest.raises(CommonRunsError):           # 40 runs against 100
        paired_difference(np.ones(100), np.zeros(40))
    with pytest.raises(CommonRunsError):           # one value broadcast against many runs
        paired_difference(np.arange(5.0), np.array([1.0]))
    x, y = common_runs([1, 2], [3, 4])
    assert x.dtype == float and y.shape == (2,)
