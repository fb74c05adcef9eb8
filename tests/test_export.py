"""Tidy exports of filter and Monte Carlo results, CSV writing, and the book's download links."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pfrepro.export import download_link, filter_result_frame, monte_carlo_frame, write_table
from pfrepro.filters import FilterResult, KalmanFilter
from pfrepro.models import CWPA
from pfrepro.montecarlo import run_monte_carlo


def _result(runs=3, T=4, n=2, with_P=True):
    x = np.arange(runs * T * n, dtype=float).reshape(runs, T, n)
    P = np.broadcast_to(np.diag(np.arange(1.0, n + 1)), (runs, T, n, n)).copy() if with_P else None
    return FilterResult(x, P)


def test_filter_result_frame_layout_and_values():
    r = _result()
    truth = np.zeros((3, 5, 2))            # includes x_0: dropped
    truth[:, 1:] = 0.5
    df = r.to_frame(truth=truth, component_names=["a", "b"])
    assert list(df.columns) == ["run", "k", "component", "estimate", "variance", "truth", "error"]
    assert len(df) == 3 * 4 * 2
    row = df[(df.run == 2) & (df.k == 3) & (df.component == "b")].iloc[0]
    assert row.estimate == r.x[2, 2, 1] and row.truth == 0.5 and row.error == r.x[2, 2, 1] - 0.5
    assert row.variance == 2.0
    assert df.k.min() == 1 and df.k.max() == 4


def test_filter_result_frame_without_P_or_truth():
    df = filter_result_frame(_result(with_P=False), filter_name="KF")
    assert list(df.columns) == ["filter", "run", "k", "component", "estimate"]
    assert (df["filter"] == "KF").all()


def test_filter_result_frame_rejects_bad_shapes():
    with pytest.raises(ValueError, match="truth"):
        _result().to_frame(truth=np.zeros((3, 7, 2)))
    with pytest.raises(ValueError, match="component_names"):
        _result().to_frame(component_names=["only one"])


def test_monte_carlo_frame_and_csv_roundtrip(tmp_path):
    model = CWPA.zhang2016("gaussian")
    mc = run_monte_carlo(model, {"KF": KalmanFilter(model), "KF2": KalmanFilter(model)}, T=5, runs=2, seed=0)
    df = mc.to_frame()
    assert len(df) == 2 * 2 * 5 * model.dim_x and set(df["filter"]) == {"KF", "KF2"}
    kf = df[df["filter"] == "KF"]
    assert kf["estimate"].to_numpy() == pytest.approx(mc.results["KF"].x.ravel())
    assert kf["truth"].to_numpy() == pytest.approx(mc.x_true.ravel())
    assert np.allclose(kf["error"], kf["estimate"] - kf["truth"])
    path = mc.to_csv(tmp_path / "mc.csv", filters=["KF"])
    back = pd.read_csv(path)
    assert len(back) == len(kf) and back["estimate"].to_numpy() == pytest.approx(kf["estimate"].to_numpy())
    with pytest.raises(KeyError, match="no filter"):
        monte_carlo_frame(mc, filters=["UKF"])
    p2 = mc.results["KF"].to_csv(tmp_path / "kf.csv", truth=mc.sim.x)
    assert len(pd.read_csv(p2)) == 2 * 5 * model.dim_x


def test_monte_carlo_frame_flags_every_row_of_a_lost_run(tmp_path):
    """A run that a filter lost (NaN from step 3 of 4 in run 1 of filter A) is flagged on ALL its
    rows, the finite early ones included; the other runs and filter B are not; the flagged runs
    are the ones n_diverged() counts, and the flag survives the CSV."""
    from pfrepro.models.base import Simulation
    from pfrepro.montecarlo import MonteCarloResult

    a = np.zeros((3, 4, 2))
    a[1, 2:, :] = np.nan                                    # run 1 stopped at step 3
    mc = MonteCarloResult(sim=Simulation(np.zeros((3, 5, 2)), np.zeros((3, 4, 1))),
                          results={"A": FilterResult(a, None, {}), "B": FilterResult(np.ones((3, 4, 2)), None, {})},
                          batch_seconds={})
    df = mc.to_frame()
    assert list(df.columns) == ["filter", "run", "k", "component", "estimate", "truth", "error", "diverged"]
    assert df["diverged"].dtype == bool
    lost = df[df["diverged"]]
    assert set(lost["filter"]) == {"A"} and set(lost["run"]) == {1} and len(lost) == 4 * 2
    assert lost["estimate"].notna().sum() == 2 * 2                     # steps 1-2 finite, still flagged
    per_filter = df.groupby("filter")[["run", "diverged"]].apply(lambda g: g.loc[g["diverged"], "run"].nunique())
    assert per_filter.to_dict() == mc.n_diverged() == {"A": 1, "B": 0}
    back = pd.read_csv(mc.to_csv(tmp_path / "mc.csv", filters=["A"]))
    assert back["diverged"].tolist() == df.loc[df["filter"] == "A", "diverged"].tolist()


def test_write_table_index_and_multiindex(tmp_path):
    plain = pd.DataFrame({"a": [1, 2]})
    write_table(plain, tmp_path / "plain.csv")
    assert (tmp_path / "plain.csv").read_text().splitlines()[0] == "a"       # no 0..n-1 index
    named = pd.DataFrame({"a": [1, 2]}, index=pd.Index(["x", "y"], name="row"))
    write_table(named, tmp_path / "named.csv")
    assert (tmp_path / "named.csv").read_text().splitlines()[0] == "row,a"
    multi = pd.DataFrame([[1, 2]], columns=pd.MultiIndex.from_tuples([("N=10", "PF"), ("N=10", "CMS")]))
    write_table(multi, tmp_path / "sub" / "multi.csv")
    assert (tmp_path / "sub" / "multi.csv").read_text().splitlines()[0] == "N=10 | PF,N=10 | CMS"


def test_download_link_writes_files_and_myst_roles(tmp_path):
    df = pd.DataFrame({"filter": ["EKF", "PF"], "rmse": [1.5, np.nan]})
    link = download_link(df, "demo_table", formats=("csv", "json"), label="Table 9", directory=tmp_path)
    assert (tmp_path / "demo_table.csv").is_file()
    rows = json.loads((tmp_path / "demo_table.json").read_text())
    assert rows == [{"filter": "EKF", "rmse": 1.5}, {"filter": "PF", "rmse": None}]
    md = link._repr_markdown_()
    assert md.count("{download}`") == 2 and "Table 9 (CSV)" in md and "Table 9 (JSON)" in md
    assert f"<{(tmp_path / 'demo_table.csv').as_posix()}>" in md


def test_download_link_default_dir_is_relative(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    link = download_link(pd.DataFrame({"a": [1]}), "t1")
    assert "<_downloads_src/t1.csv>" in link.markdown and (tmp_path / "_downloads_src" / "t1.csv").is_file()


@pytest.mark.parametrize("name,formats", [("bad name", ("csv",)), ("../up", ("csv",)), ("ok", ("xlsx",)), ("ok", ())])
def test_download_link_rejects_bad_arguments(name, formats, tmp_path):
    with pytest.raises(ValueError):
        download_link(pd.DataFrame({"a": [1]}), name, formats=formats, directory=tmp_path)
