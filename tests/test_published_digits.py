"""Published numbers exactly as printed: the data files keep the paper's digits as text
(``pfrepro.published.printed``), and every table of the book that shows a published cell shows
that text, not a rounded float. To add a chapter, list its shown tables in ``SHOWN_TABLES`` and
its paper in ``CLAIMS_WITH_PRINTED_DIGITS``."""
import math
from pathlib import Path

import pytest

from pfrepro import published
from pfrepro.claims import ClaimsRegistry, claims_table, load_all_claims

BOOK = Path(__file__).resolve().parents[1] / "book"


# ------------------------------------------------------------------ the API ----------------------
@pytest.fixture
def fake_paper(tmp_path, monkeypatch):
    d = tmp_path / "data" / "published"
    d.mkdir(parents=True)
    (d / "fake2001.csv").write_text(
        "# comment\n"
        "table,row,column,value,note\n"
        "Table 1,PF,RMSE,4.6440,trailing zero printed\n"
        "Table 1,EKF,RMSE,30.1709,\n"
        "Table 1,UKF,RMSE, 2.50 ,blank around\n"
        "Table 2,PF,RMSE,4.644,same value printed otherwise\n", encoding="utf-8")
    monkeypatch.setitem(published.PAPERS, "fake2001", "a test paper")
    monkeypatch.setattr(published.resources, "files", lambda pkg: tmp_path)
    published.load.cache_clear(); published.load_printed.cache_clear()
    yield "fake2001"
    published.load.cache_clear(); published.load_printed.cache_clear()


def test_printed_keeps_the_digits(fake_paper):
    assert published.printed(fake_paper, "Table 1", "PF", "RMSE") == "4.6440"
    assert published.printed(fake_paper, "Table 1", "UKF", "RMSE") == "2.50"
    assert published.value(fake_paper, "Table 1", "PF", "RMSE") == 4.644
    t = published.printed_table(fake_paper, "Table 1")
    assert t.loc["EKF", "RMSE"] == "30.1709" and list(t.index) == ["PF", "EKF", "UKF"]
    df = published.load(fake_paper)
    assert df["value"].dtype == float and df["value"].tolist() == [4.644, 30.1709, 2.5, 4.644]
    with pytest.raises(KeyError):
        published.printed(fake_paper, "Table 1", "PF", "MSE")


def test_formatter_maps_floats_back_to_printed_text(fake_paper):
    fmt = published.formatter(fake_paper, "Table 1")
    assert fmt(published.value(fake_paper, "Table 1", "PF", "RMSE")) == "4.6440"
    assert fmt(30.1709) == "30.1709" and fmt(float("nan")) == "–" and fmt(None) == "–"
    with pytest.raises(KeyError):
        fmt(30.171)  # a rounded value is not a printed one
    with pytest.raises(ValueError, match="printed as"):  # 4.644 printed two ways across tables
        published.formatter(fake_paper)(4.644)
    assert published.printed_for(fake_paper, 7.0) is None


def test_bad_value_is_refused(tmp_path, monkeypatch):
    d = tmp_path / "data" / "published"
    d.mkdir(parents=True)
    (d / "fake2002.csv").write_text("table,row,column,value,note\nTable 1,a,b,n/a,\n", encoding="utf-8")
    monkeypatch.setitem(published.PAPERS, "fake2002", "x")
    monkeypatch.setattr(published.resources, "files", lambda pkg: tmp_path)
    published.load_printed.cache_clear()
    try:
        with pytest.raises(ValueError, match="not a number"):
            published.load_printed("fake2002")
    finally:
        published.load_printed.cache_clear(); published.load.cache_clear()


def test_claims_table_shows_printed_text():
    reg = ClaimsRegistry("p")
    reg.add("a", "x", published=30.1709, published_text="30.1709", reproduced=19.7, se=1.0)
    reg.add("b", "y", published=4.644, published_text="4.6440", reproduced=4.6, se=0.1, published_se=0.123)
    reg.add("c", "z", published=30.1709, reproduced=19.7, se=1.0)  # not given: rounded as before
    t = claims_table(reg)
    assert t["published"].tolist() == ["30.1709", "4.6440 ± 0.12", "30.2"]
    with pytest.raises(ValueError, match="printed form"):
        reg.add("d", "w", published=30.1709, published_text="30.171", reproduced=1.0, se=0.1)


def test_printed_text_survives_save_and_load(tmp_path):
    reg = ClaimsRegistry("p")
    reg.add("a", "x", published=4.644, published_text="4.6440", reproduced=4.6, se=0.1)
    reg.save(tmp_path)
    assert claims_table(load_all_claims(tmp_path))["published"].tolist() == ["4.6440"]


# ------------------------------------------------------------------ the chapters' tables ---------
def _ekf_pf_table1():
    from pfrepro.experiments import ekf_pf_li2012 as E
    from pfrepro.figures import ekf_pf_li2012 as F

    res = {w: E.run(w, 2, 7, ("EKF", "PF"), n_particles=50) for w in (1, 2)}
    shown = F.table1_shown(E.table1(res))
    shown = getattr(shown, "data", shown)   # the chapter shows a Styler; its cells are its data
    return [(r["published"], r["filter"], r["model"]) for _, r in shown.iterrows()]


def _imm_table1():
    from pfrepro.experiments import immpfor_zhou2017 as E
    from pfrepro.figures import immpfor_zhou2017 as F

    small = {n: (fn, {**kw, "N": 20} if fn.startswith("immpf") else kw) for n, (fn, kw) in E.MAIN_BUILDERS.items()}
    tab = F.table1_shown(F.table1_frame(E.run(small, runs=2)))
    return [(tab.loc[r, f"paper {c}"], r, c) for r in tab.index for c in ("peak", "mean")
            if tab.loc[r, f"paper {c}"] != "–"]


def _gpff_tables(which):
    from pfrepro.experiments import gpff_zhang2016 as E
    from pfrepro.figures import gpff_zhang2016 as F

    if which == "Table 1":
        t = F.table1_shown(E.table1(E.run_ung(runs=2, T=3, time_per_run=False)))
        return [(t.loc[f, c], f, d) for f in t.index if t.loc[f, "published mean"] != "–"
                for c, d in (("published mean", "MSE mean"), ("published std", "MSE std"), ("published time (s)", "time (s)"))]
    t = F.table2_shown(E.table2(E.run_bot(runs=2, T=3, time_per_run=False)))
    out = []
    for (comp, f), row in t.iterrows():
        if row["published mean"] == "–" or not isinstance(row.get("published (printed label)"), str):
            continue
        lab = row["published (printed label)"]
        out += [(row["published mean"], f"{lab} mean", f), (row["published std"], f"{lab} std", f),
                (row["published time (s)"], "time (s)", f)]
    return out


def _dpf_51():
    from pfrepro.figures import dpf_hou2008 as F

    row = F.paper_row_51()
    (xd, xe), (td, te) = row[2].split(" / "), row[4].split(" / ")
    return [(xd, "RMSE x", "DPF"), (xe, "RMSE x", "DEKF"), (td, "RMSE theta", "DPF"), (te, "RMSE theta", "DEKF")]


#: paper -> [(published table id, builder)]: the builder makes the table as the chapter shows it
#: (through the same package function) and returns (shown published cell, data row, data column)
SHOWN_TABLES = {
    "ekf_pf_li2012": [("Table 1", _ekf_pf_table1)],
    "immpfor_zhou2017": [("Table 1", _imm_table1)],
    "gpff_zhang2016": [("Table 1", lambda: _gpff_tables("Table 1")), ("Table 2", lambda: _gpff_tables("Table 2"))],
    "dpf_hou2008": [("Sec 5.1", _dpf_51)],
}
#: rows of a data table that a shown table does not hold (settings, not results), by (paper, table)
NOT_RESULTS = {("dpf_hou2008", "Sec 5.1"): {"particles"}}
#: papers whose chapters pass published_text= for every claim on a printed number
CLAIMS_WITH_PRINTED_DIGITS = ["ekf_pf_li2012", "gpff_zhang2016", "cmspf_ning2011", "dpf_hou2008", "immpfor_zhou2017"]


@pytest.mark.parametrize("paper,table_id,build",
                         [(p, t, b) for p, tabs in SHOWN_TABLES.items() for t, b in tabs])
def test_every_published_cell_shown_is_the_printed_one(paper, table_id, build):
    cells = build()
    shown = {(row, col): text for text, row, col in cells}
    for (row, col), text in shown.items():
        assert isinstance(text, str) and text == published.printed(paper, table_id, row, col), (row, col, text)
    data = published.load_printed(paper)
    data = data[(data["table"] == table_id) & ~data["row"].isin(NOT_RESULTS.get((paper, table_id), set()))]
    assert set(shown) == set(zip(data["row"], data["column"])), "every published cell of the table is shown"


@pytest.mark.parametrize("paper", CLAIMS_WITH_PRINTED_DIGITS)
def test_claims_of_the_last_build_show_printed_digits(paper):
    """A claim whose published value is a cell of the data file shows that cell's printed text."""
    path = BOOK / "_claims" / f"{paper}.json"
    if not path.exists():
        pytest.skip("no book build in this checkout")
    claims = load_all_claims(BOOK / "_claims")
    claims = claims[claims["paper"] == paper]
    t = claims_table(claims)
    n = 0
    tables = set(published.load_printed(paper)["table"])
    for pub, cell, source in zip(claims["published"], t["published"], claims["source"]):
        if pub is None or (isinstance(pub, float) and math.isnan(pub)):
            continue
        # the claim's source table when the same value is printed two ways in two tables (5.207 / 5.2070)
        tab = str(source).split(",")[0].strip()
        text = published.printed_for(paper, pub, tab if tab in tables else None)
        if text is not None:
            assert cell.split(" ± ")[0] == text, (pub, cell, text)
            n += 1
    assert n > 0


# ------------------------------------------------------------------ CMS-PF (Ning et al. 2011) ---------
def _cms_frames():
    """The CMS-PF tables the chapter shows with published cells, built by the chapter's functions on
    2 runs (the printed cells do not depend on our runs)."""
    from pfrepro.experiments import cmspf_ning2011 as E

    t1 = E.table1(runs=20)[0]   # the per-run download shows runs 1-20 beside the paper's rows
    t2 = E.table2(runs=2, timing_repeats=1)[0]
    t3 = E.table3(runs=2)[0]
    return t1, t2, t3


def _cms_table1():
    from pfrepro.figures import cmspf_ning2011 as F

    t1 = _cms_frames()[0]
    out = [(r["paper"], str(r["run"]), f"N={r['N']} {r['filter']}")
           for _, r in F.table1_per_run_long(t1).iterrows() if r["paper"] is not None]
    s = F.table1_summary(t1)
    out += [(s.loc[N, f"{f} paper"], "21", f"N={N} {f}") for N in s.index for f in ("PF", "CMS-PF")]
    d = F.divisor_check("Table 1")
    out += [(d.loc[c, "printed variance (row 22)"], "22", c) for c in d.index]
    return out


def _cms_table2():
    from pfrepro.figures import cmspf_ning2011 as F

    tab = F.table2_vs_published(_cms_frames()[1])
    return [(tab.loc[f, col], row, f) for f in F.TABLE2_FILTERS
            for col, row in (("RMSE paper", "RMSE"), ("time/s paper (printed)", "time/s"))]


def _cms_table3():
    from pfrepro.figures import cmspf_ning2011 as F

    t3 = _cms_frames()[2]
    tab = F.table3_vs_published(t3)
    cols = [c for c in tab.index if c in F.E.TABLE3_COLUMNS]
    out = [(tab.loc[c, "paper mean (row 21)"], "21", c) for c in cols]
    out += [(tab.loc[c, "paper variance (row 22)"], "22", c) for c in cols]
    per = F.table3_per_run(t3)["paper (printed)"]
    out += [(per.loc[i, c], str(i), c) for i in per.index for c in per.columns]
    return out


SHOWN_TABLES["cmspf_ning2011"] = [("Table 1", _cms_table1), ("Table 2", _cms_table2), ("Table 3", _cms_table3)]


@pytest.mark.parametrize("table_id,build", SHOWN_TABLES["cmspf_ning2011"])
def test_every_cmspf_published_cell_shown_is_the_printed_one(table_id, build):
    test_every_published_cell_shown_is_the_printed_one("cmspf_ning2011", table_id, build)


def test_cmspf_table2_shows_the_printed_seconds_beside_the_ratios():
    """Table 2's run times appear as the paper printed them (seconds), not only as ratios."""
    from pfrepro.figures import cmspf_ning2011 as F

    tab = F.table2_vs_published(_cms_frames()[1])
    cols = list(tab.columns)
    assert cols.index("time/s paper (printed)") + 1 == cols.index("time ratio to PF, paper")
    assert tab.loc["CMS-PF", "time/s paper (printed)"] == "0.1110" and tab.loc["EKF", "time/s paper (printed)"] == "0.0044"


# ------------------------------------------------------------------ GPFF: every other table with a published value
def test_gpff_reading_table_shows_printed_digits():
    """The GPFF chapter's table of which reading the published numbers point to (``reading_table``) shows
    every published mean it holds with the paper's digits (29.00, 28.50, 1.280; never 29, 28.5, 1.28)."""
    from pfrepro.verdicts import gpff_zhang2016 as V

    paper = "gpff_zhang2016"
    data = published.load_printed(paper)
    cells = data[data["column"].str.endswith("mean") | data["row"].str.endswith("mean")]
    cells = cells[cells["table"].isin(["Table 1", "Table 2"])]
    reg = ClaimsRegistry(paper)
    want = {}
    for i, (tab, row, col) in enumerate(zip(cells["table"], cells["row"], cells["column"])):
        text = published.printed(paper, tab, row, col)
        v = published.value(paper, tab, row, col)
        reg.add(f"c{i}", f"{tab} {row} {col}", published=v, published_text=text, reproduced=v, se=0.01 * v,
                reading_values={"ut=alpha=0.5": (v, 0.01 * v)})
        want[f"c{i}"] = text
    shown = V.reading_table(reg)["published"].to_dict()
    assert shown == want
    assert {"29.00", "28.50", "1.280"} <= set(shown.values())
    assert len(want) == 8 + 24      # Table 1's eight means and Table 2's 24
