"""The pfrepro command line: list, run (tiny), scorecard formats, and every bad-argument path."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pfrepro import cli, papers


def run_cli(argv, capsys):
    code = cli.main(argv)
    out, err = capsys.readouterr()
    return code, out, err


# -- registry -----------------------------------------------------------------------------
def test_registry_names_are_unique_and_resolve():
    keys = papers.paper_keys()
    for p in papers.PAPERS:
        assert keys[p.key] is p
        for a in p.aliases:
            assert papers.get_paper(a.upper()) is p          # case-insensitive
        assert p.tables and p.figures
        # every paper: run_all -> record_claims, and tables(results) / figures(results) for the CLI
        assert callable(p.figures_module.tables) and callable(p.figures_module.figures)
        assert callable(p.experiments_module.run_all) and callable(p.verdicts_module.record_claims)
        assert not hasattr(p.figures_module, "reproduce")     # no second path to the claims
        assert p.citation and p.citation != p.key             # from pfrepro.published.PAPERS
    with pytest.raises(KeyError, match="choose from"):
        papers.get_paper("nosuchpaper")


def test_resolve_seeds_never_touches_the_module_table():
    book = {"a": 1, "b": 2, "c": 3}
    assert papers.resolve_seeds(book) == book and papers.resolve_seeds(book) is not book
    assert papers.resolve_seeds(book, 10) == {"a": 10, "b": 11, "c": 12}       # --seed 10: every seed moves
    assert papers.resolve_seeds(book, {"b": 7}) == {"a": 1, "b": 7, "c": 3}
    assert book == {"a": 1, "b": 2, "c": 3}
    with pytest.raises(KeyError, match="unknown seed"):
        papers.resolve_seeds(book, {"z": 1})
    with pytest.raises(ValueError, match=">= 0"):
        papers.resolve_seeds(book, -1)
    with pytest.raises(TypeError):
        papers.resolve_seeds(book, "7")


# -- list ------------------------------------------------------------------------------------
def test_list_shows_papers_tables_figures(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("PFREPRO_CLAIMS_DIR", raising=False)
    code, out, err = run_cli(["list"], capsys)
    assert code == 0 and err == ""
    for p in papers.PAPERS:
        assert p.key in out and all(a in out for a in p.aliases)
    assert "Table 1" in out and "Fig. 4" in out
    assert "no claims found" in out


def test_list_shows_claims_of_a_build(capsys, tmp_path, monkeypatch):
    from pfrepro.claims import ClaimsRegistry

    reg = ClaimsRegistry("ekf_pf_li2012")
    reg.add("c1", "a claim", published=1.0, reproduced=1.02, se=0.1)
    reg.save(tmp_path)
    monkeypatch.setenv("PFREPRO_CLAIMS_DIR", str(tmp_path))
    code, out, _ = run_cli(["list"], capsys)
    assert code == 0 and "[reproduced] c1: a claim" in out


# -- run + scorecard ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def li_run(tmp_path_factory):
    import contextlib
    import io

    out = tmp_path_factory.mktemp("li")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = cli.main(["run", "li2012", "--runs", "2", "--seed", "3", "--out", str(out)])
    (out / "stdout.txt").write_text(buf.getvalue())
    return code, out


def test_run_li2012_writes_tables_figures_claims(li_run):
    code, out = li_run
    assert code == 0
    t1 = pd.read_csv(out / "table1.csv")
    assert list(t1["filter"]) == ["EKF", "PF", "EKF", "PF"]
    assert {"published", "ours", "se", "verdict"} <= set(t1.columns)
    for n in (1, 2, 3, 4):
        png = (out / f"fig{n}.png").read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n"
    claims = json.loads((out / "claims" / "ekf_pf_li2012.json").read_text())
    # the chapter's claims, all of them (pfrepro.verdicts.ekf_pf_li2012), not only the table cells
    assert [c["claim_id"] for c in claims] == [
        "table1-ekf-model1", "table1-pf-model1", "table1-ekf-model2", "table1-pf-model2", "ratio-7x",
        "close-weak-nonlinearity", "figs-pf-better", "figs-pf-better-model2", "sis-degenerates",
        "resampling-limits-degeneracy", "pf-cost", "kf-optimal-linear", "more-particles-less-degeneracy",
        "more-particles-cost", "optimal-proposal-hard", "prior-ignores-y", "ekf-error-truncation"]


def test_run_uses_the_chapter_experiment(li_run):
    """The CSV is exactly the experiment module's table1 on the same runs and seeds."""
    from pfrepro.experiments import ekf_pf_li2012 as E

    _, out = li_run
    res = {w: E.run(w, 2, 3, ("EKF", "PF", "Exact")) for w in (1, 2)}
    direct = E.table1(res)
    t1 = pd.read_csv(out / "table1.csv")
    assert t1["ours"].to_numpy() == pytest.approx(direct["ours"].to_numpy(), rel=1e-12)


def test_run_prints_the_verdict_summary(li_run):
    _, out = li_run
    text = (out / "stdout.txt").read_text()
    assert "verdicts of the 17 claims (the chapter's claims" in text
    assert "table1-ekf-model1" in text and "seed (figures): 4" in text


@pytest.mark.parametrize("fmt", ["table", "csv", "json"])
def test_scorecard_formats(fmt, li_run, capsys):
    _, out = li_run
    code, text, err = run_cli(["scorecard", "--format", fmt, "--dir", str(out / "claims")], capsys)
    assert code == 0 and err == ""
    if fmt == "csv":
        from io import StringIO

        df = pd.read_csv(StringIO(text))
        assert len(df) == 17 and "verdict" in df.columns
    elif fmt == "json":
        rows = json.loads(text)
        assert len(rows) == 17 and all("verdict" in r for r in rows)
        # every number exactly as saved (pandas' to_json had kept 10 digits), a missing one null
        saved = json.loads((out / "claims" / "ekf_pf_li2012.json").read_text())
        for r, s in zip(rows, saved):
            assert r["reproduced"] == s["reproduced"] and r["se"] == s["se"] and r["diff"] == s["diff"]
    else:
        assert "table1-pf-model2" in text and "verdict" in text


# -- bad arguments: one line on stderr, exit code 2, no traceback ---------------------------
def _bad_paths(tmp_path):
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    return [
        [],                                                   # no command
        ["frobnicate"],                                       # unknown command
        ["run"],                                              # no paper
        ["run", "nosuchpaper"],                               # unknown paper
        ["run", "li2012", "--runs", "0"],                     # runs < 2
        ["run", "li2012", "--runs", "1"],                     # one run: no pairs to compare
        ["run", "li2012", "--runs", "-3"],
        ["run", "li2012", "--runs", "many"],
        ["run", "li2012", "--jobs", "0"],
        ["run", "li2012", "--seed", "-1"],
        ["run", "li2012", "--seed", "x"],
        ["run", "li2012", "--out", str(a_file)],              # --out is a file
        ["run", "li2012", "--out", str(a_file / "sub")],      # --out under a file
        ["run", "li2012", "--bogus"],                         # unknown option
        ["scorecard", "--format", "xml"],
        ["scorecard", "--dir", str(tmp_path / "missing")],
        ["scorecard", "--dir", str(tmp_path)],                # a directory without claims
    ]


def test_every_bad_argument_exits_2_with_one_line(capsys, tmp_path):
    for argv in _bad_paths(tmp_path):
        code, out, err = run_cli(argv, capsys)
        assert code == 2, argv
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("pfrepro: error:"), (argv, err)
        assert "Traceback" not in err and out == "", argv


def test_out_of_another_paper_is_refused(tmp_path, capsys):
    """A reused --out would mix two papers' table1.csv / fig1.png: refused in one line, exit 2,
    before any work; rerunning the same paper into its own --out is allowed."""
    (tmp_path / "claims").mkdir()
    (tmp_path / "claims" / "gpff_zhang2016.json").write_text("[]")
    code, out, err = run_cli(["run", "li2012", "--runs", "2", "--out", str(tmp_path)], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "another paper (gpff_zhang2016)" in err and "choose another --out" in err
    assert not (tmp_path / "table1.csv").exists()
    (tmp_path / "claims" / "gpff_zhang2016.json").unlink()
    (tmp_path / "claims" / "ekf_pf_li2012.json").write_text("[]")        # the same paper: rerun in place
    code, out, err = run_cli(["run", "li2012", "--runs", "2", "--out", str(tmp_path)], capsys)
    assert code == 0, err


def test_bad_paper_message_names_the_choices(capsys):
    code, _, err = run_cli(["run", "nosuchpaper"], capsys)
    assert code == 2 and "li2012" in err and "gpff" in err


def test_python_dash_m_entry_point(tmp_path):
    env_path = str(Path(cli.__file__).parents[1])
    env = {"PYTHONPATH": env_path, "PATH": "/usr/bin:/bin"}
    bad = subprocess.run([sys.executable, "-m", "pfrepro", "run", "li2012", "--runs", "0"],
                         capture_output=True, text=True, env=env, cwd=tmp_path, timeout=120)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
    assert "Traceback" not in bad.stderr


def test_run_with_jobs_matches_serial(li_run, tmp_path):
    """--jobs 2 runs the experiments on a process pool (the engine's executor): same numbers."""
    _, serial = li_run
    code = cli.main(["run", "li2012", "--runs", "2", "--seed", "3", "--jobs", "2", "--out", str(tmp_path)])
    assert code == 0
    a, b = pd.read_csv(serial / "table1.csv"), pd.read_csv(tmp_path / "table1.csv")
    # bit-identical, the grid filter's "exact" column included (issue 21: it used to differ in
    # the last bits with the batch size)
    np.testing.assert_array_equal(a["ours"].to_numpy(), b["ours"].to_numpy())
    np.testing.assert_array_equal(a["exact"].to_numpy(), b["exact"].to_numpy())


# -- the dual PF and IMM-PF papers: registered, listed, runnable on one run -------------------
def test_list_shows_dpf_and_immpf(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("PFREPRO_CLAIMS_DIR", raising=False)
    code, out, _ = run_cli(["list"], capsys)
    assert code == 0
    for key, alias, label in (("dpf_hou2008", "hou2008", "Figs. 7-9"), ("immpfor_zhou2017", "zhou2017", "Fig. 5")):
        assert key in out and alias in out and label in out
    assert papers.get_paper("dpf").chapter == "book/50_dpf.md"
    assert papers.get_paper("IMMPF").chapter == "book/60_immpf.md"


def test_immpf_table1_frame_matches_the_experiment():
    from pfrepro.experiments import immpfor_zhou2017 as E
    from pfrepro.figures import immpfor_zhou2017 as F

    main = E.run(F.PF_NAMES, runs=2, seed=7)
    tab = F.table1_frame(main)
    t1 = E.table1(main, ["IMMPF", "IMMPFOR"])
    assert tab.loc[["IMMPF", "IMMPFOR"], "ours mean"].to_numpy() == pytest.approx(t1["mean"].to_numpy(), rel=1e-12)
    assert "IMM-EKF" not in tab.index          # rows of filters that were not run are left out
    assert tab.loc["IMMPF", "paper peak"] > 0


# -- --jobs 1 and --jobs 2 write the same bytes -------------------------------------------------
def test_every_output_file_is_byte_identical_for_jobs_1_and_2(tmp_path, capsys):
    """Issue 21: the grid filter's numbers differed in the last bits with the batch size, so
    `--jobs 2` wrote other "exact" numbers than `--jobs 1`. Every results file (tables, figures,
    claims) must be the same bytes, with the real clock (measured times go to timings.csv, which
    li2012 does not write), and with 4 runs on 2 workers: chunks of one run."""
    outs = []
    for jobs in (1, 2):
        out = tmp_path / f"jobs{jobs}"
        code = cli.main(["run", "li2012", "--runs", "4", "--seed", "7", "--jobs", str(jobs), "--out", str(out)])
        assert code == 0
        outs.append(out)
    capsys.readouterr()
    files = sorted(p.relative_to(outs[0]) for p in outs[0].rglob("*") if p.is_file())
    assert {p.relative_to(outs[1]) for p in outs[1].rglob("*") if p.is_file()} == set(files)
    assert any(f.suffix == ".png" for f in files) and any(f.suffix == ".csv" for f in files)
    assert cli.TIMINGS_FILE not in {str(f) for f in files}
    for f in files:
        assert (outs[0] / f).read_bytes() == (outs[1] / f).read_bytes(), f"{f} differs between --jobs 1 and 2"


# -- measured times: a file of their own ------------------------------------------------------------
def test_split_timings_moves_the_declared_columns():
    t1 = pd.DataFrame({"MSE": [1.0, 2.0], "time [s]": [0.1, 0.2], "ratio": [1.0, 2.0]},
                      index=pd.Index(["EKF", "PF"], name="filter"))
    t2 = pd.DataFrame({"x": [3.0]}, index=pd.MultiIndex.from_tuples([("pos", "PF")]))
    tables, times = papers.split_timings({"Table 1": t1, "Table 2": t2}, {"Table 1": ("time [s]", "ratio")})
    assert list(tables["Table 1"].columns) == ["MSE"] and tables["Table 2"] is t2
    assert list(t1.columns) == ["MSE", "time [s]", "ratio"]                 # the caller's frame untouched
    assert list(times.columns) == list(papers.TIMING_COLUMNS)
    assert times.values.tolist() == [["Table 1", "EKF", "time [s]", 0.1], ["Table 1", "EKF", "ratio", 1.0],
                                     ["Table 1", "PF", "time [s]", 0.2], ["Table 1", "PF", "ratio", 2.0]]
    _, t = papers.split_timings({"T": t2.assign(s=[0.5])}, {"T": ("s",)})
    assert t["row"].tolist() == ["pos / PF"]
    with pytest.raises(KeyError, match="no timing column"):
        papers.split_timings({"Table 1": t1}, {"Table 1": ("seconds",)})
    with pytest.raises(KeyError, match="which the paper does not have"):
        papers.split_timings({"Table 1": t1}, {"Table 9": ("time [s]",)})


def test_declared_timing_columns_are_the_papers_measured_times():
    """Every declared column is a measured time that the paper's table code writes (a renamed
    column would otherwise stay in the table and make two runs' files differ)."""
    import inspect

    declared = {p.key: dict(p.timing_columns) for p in papers.PAPERS if p.timing_columns}
    assert set(declared) == {"gpff_zhang2016", "cmspf_ning2011"}
    for p in papers.PAPERS:
        src = inspect.getsource(p.figures_module) + inspect.getsource(p.experiments_module)
        for label, cols in dict(p.timing_columns).items():
            assert label in p.tables
            for c in cols:
                assert f'"{c}"' in src and "time" in c, (p.key, label, c)


def test_run_writes_measured_times_to_their_own_file(tmp_path, capsys, monkeypatch):
    """Through the command line: the declared columns leave table1.csv for timings.csv, a figures
    module's timing_figures go to timings_<fig>.png, and the run says which files hold measured times."""
    import types

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pfrepro.claims import ClaimsRegistry

    class Results:
        settings = {"runs": 2}

    def fig(title):
        f, ax = plt.subplots()
        ax.set_title(title)
        return f

    mods = {
        "experiments": types.SimpleNamespace(run_all=lambda **kw: Results(), CHOICES={}),
        "verdicts": types.SimpleNamespace(record_claims=lambda reg, r: reg.add("c1", "a claim", reproduced=1.0)),
        "figures": types.SimpleNamespace(
            TABLES=("Table 1",), FIGURES=("Fig. 1",),
            tables=lambda r: {"Table 1": pd.DataFrame({"rmse": [1.5], "time [s]": [0.25]}, index=["PF"])},
            figures=lambda r: {"Fig. 1": fig("rmse")}, timing_figures=lambda r: {"Fig. 1": fig("time")}),
    }
    for kind, mod in mods.items():
        monkeypatch.setitem(sys.modules, f"pfrepro.{kind}.fake_paper", mod)
    fake = papers.Paper("fake_paper", ("fake",), "book/none.md", citation="Fake (2024)",
                        timing_columns=(("Table 1", ("time [s]",)),))
    monkeypatch.setattr(papers, "get_paper", lambda name: fake)
    monkeypatch.setattr(ClaimsRegistry, "save", lambda self, d: (Path(d).mkdir(parents=True, exist_ok=True),
                                                                Path(d) / "fake_paper.json")[1])
    code, out, err = run_cli(["run", "fake", "--out", str(tmp_path)], capsys)
    assert code == 0, err
    assert pd.read_csv(tmp_path / "table1.csv").columns.tolist() == ["Unnamed: 0", "rmse"]
    times = pd.read_csv(tmp_path / cli.TIMINGS_FILE)
    assert times.values.tolist() == [["Table 1", "PF", "time [s]", 0.25]]
    assert (tmp_path / "fig1.png").exists() and (tmp_path / "timings_fig1.png").exists()
    assert f"{cli.TIMINGS_FILE}  (measured times: differ between runs)" in out
