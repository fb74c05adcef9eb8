"""Exports: tidy pandas frames of filter and Monte Carlo results, CSV files, and the book's
download links.

* :func:`filter_result_frame` / :func:`monte_carlo_frame` turn results into long ("tidy")
  frames, one row per (run, time step, state component); ``FilterResult.to_frame`` and
  ``MonteCarloResult.to_frame`` call them.
* :func:`write_table` writes a table as CSV (index kept when it carries information).
* :func:`download_link` saves a chapter's table next to the chapter and returns a MyST
  ``{download}`` link to it, which Sphinx copies into the built HTML (``_build/html/_downloads/``),
  so the link works offline.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["filter_result_frame", "monte_carlo_frame", "write_table", "download_link", "DownloadLink",
           "DOWNLOAD_DIR"]

#: folder, relative to the chapter's working directory (``book/``), that download files go to
DOWNLOAD_DIR = "_downloads_src"


def _components(dim: int, names=None) -> list:
    if names is None:
        return list(range(dim))
    names = list(names)
    if len(names) != dim:
        raise ValueError(f"component_names has {len(names)} names, the state has {dim} components")
    return names


def filter_result_frame(result, truth=None, component_names=None, filter_name=None) -> pd.DataFrame:
    """A :class:`~pfrepro.filters.FilterResult` as a tidy frame.

    Parameters
    ----------
    result : FilterResult
        Estimates ``x`` of shape (runs, T, dim_x) (``P`` optional).
    truth : array_like, optional
        True states aligned with the estimates, (runs, T, dim_x) (``sim.x[:, 1:]``) or
        (runs, T + 1, dim_x) (``sim.x``, the initial state is dropped).
    component_names : sequence of str, optional
        Names of the state components (default 0, 1, ...).
    filter_name : str, optional
        Adds a ``filter`` column.

    Returns
    -------
    pandas.DataFrame
        Columns ``run, k, component, estimate`` (k = 1..T), plus ``variance`` (the diagonal
        of ``P``) when the filter gives covariances, ``truth`` and ``error`` when
        ``truth`` is given, and ``filter`` when ``filter_name`` is given.
    """
    x = np.asarray(result.x, dtype=float)
    if x.ndim != 3:
        raise ValueError(f"result.x must be (runs, T, dim_x), got shape {x.shape}")
    runs, T, n = x.shape
    comps = _components(n, component_names)
    run_idx, k_idx, c_idx = np.meshgrid(np.arange(runs), np.arange(1, T + 1), np.arange(n), indexing="ij")
    data = {"run": run_idx.ravel(), "k": k_idx.ravel(), "component": np.asarray(comps, dtype=object)[c_idx.ravel()]
            if component_names is not None else c_idx.ravel(), "estimate": x.ravel()}
    if result.P is not None:
        P = np.asarray(result.P)
        if P.dtype.kind not in "fiu" or P.shape != (runs, T, n, n):
            raise ValueError(f"result.P must be covariances of shape (runs, T, dim_x, dim_x) = {(runs, T, n, n)} "
                             f"(or None), got {P.dtype} of shape {P.shape}")
        data["variance"] = np.diagonal(P.astype(float), axis1=-2, axis2=-1).ravel()
    if truth is not None:
        t = np.asarray(truth, dtype=float)
        if t.shape == (runs, T + 1, n):
            t = t[:, 1:]
        if t.shape != x.shape:
            raise ValueError(f"truth must be (runs, T, dim_x) = {x.shape} or include x_0, got {t.shape}")
        data["truth"] = t.ravel()
        data["error"] = (x - t).ravel()
    df = pd.DataFrame(data)
    if filter_name is not None:
        df.insert(0, "filter", filter_name)
    return df


def monte_carlo_frame(mc, component_names=None, filters=None) -> pd.DataFrame:
    """A :class:`~pfrepro.montecarlo.MonteCarloResult` as one tidy frame of every filter.

    Columns ``filter, run, k, component, estimate, truth, error, diverged`` (+ ``variance``
    where the filter gives covariances); ``filters`` selects and orders the filters (default
    all). ``diverged`` is True on every row of a run the filter lost (a non-finite estimate at
    any step, as counted by ``mc.n_diverged()``), so a lost run cannot pass unseen into a mean
    of the finite rows.
    """
    names = list(mc.results) if filters is None else list(filters)
    unknown = [n for n in names if n not in mc.results]
    if unknown:
        raise KeyError(f"no filter(s) {unknown} in this result; it has {list(mc.results)}")
    frames = []
    for n in names:
        df = filter_result_frame(mc.results[n], mc.x_true, component_names, filter_name=n)
        x = np.asarray(mc.results[n].x, dtype=float)
        lost = ~np.all(np.isfinite(x.reshape(x.shape[0], -1)), axis=1)            # (runs,)
        df["diverged"] = lost[df["run"].to_numpy()]
        frames.append(df)
    return pd.concat(frames, ignore_index=True)


def _keep_index(df: pd.DataFrame) -> bool:
    idx = df.index
    return not (isinstance(idx, pd.RangeIndex) and idx.name is None and idx.start == 0 and idx.step == 1)


def write_table(df: pd.DataFrame, path) -> Path:
    """Write ``df`` as UTF-8 CSV to ``path`` (parents created); the index is kept if it is not 0..n-1.

    Multi-level column labels are joined with " | " so the file has one header line.
    """
    if not isinstance(df, pd.DataFrame):
        if isinstance(df, pd.Series):
            df = df.to_frame()
        else:
            raise TypeError(f"write_table needs a pandas DataFrame (or Series) as df, got {type(df).__name__}; "
                            "wrap an array with pandas.DataFrame(...) and name its columns")
    if str(path).strip() == "":
        raise ValueError("path is empty: give a file name")
    path = Path(path)
    if path.is_dir():
        raise IsADirectoryError(f"path {str(path)!r} is a directory: give a file name, e.g. {str(path / 'table.csv')!r}")
    path.parent.mkdir(parents=True, exist_ok=True)
    out = df.copy()
    if isinstance(out.columns, pd.MultiIndex):
        out.columns = [" | ".join(str(c) for c in col if str(c) != "") for col in out.columns]
    out.to_csv(path, index=_keep_index(out), encoding="utf-8")
    return path


def _json_records(df: pd.DataFrame) -> str:
    return json.dumps(json.loads(df.to_json(orient="records")), indent=1, ensure_ascii=False)


class DownloadLink:
    """What :func:`download_link` returns: shown as MyST markdown in a notebook (``{download}`` roles).

    The chapter cell that displays it needs the cell metadata
    ``mystnb: {markdown_format: myst}`` so that MyST-NB parses the roles (and Sphinx
    copies the files into the HTML build); in plain Jupyter it shows as text.
    """

    def __init__(self, paths: list[Path], labels: list[str], rel: list[str]):
        self.paths, self.labels, self.rel = paths, labels, rel

    @property
    def markdown(self) -> str:
        """The MyST line of download links (one ``{download}`` role per format)."""
        links = " · ".join(f"{{download}}`{label} <{rel}>`" for label, rel in zip(self.labels, self.rel))
        return f"Download: {links}"

    def _repr_markdown_(self) -> str:
        return self.markdown

    def __repr__(self) -> str:
        return self.markdown


def download_link(df: pd.DataFrame, name: str, formats=("csv",), *, label: str | None = None,
                  directory=None) -> DownloadLink:
    """Save ``df`` next to the chapter and return a download link for the book.

    Parameters
    ----------
    df : pandas.DataFrame
        The table as shown (or its full-precision version).
    name : str
        File stem, unique in the book, e.g. ``"ekf_pf_li2012_table1"`` (letters, digits, ``_-.``).
    formats : sequence of {"csv", "json"}
        Which files to write (JSON: one record per row).
    label : str, optional
        Link text stem (default ``name``).
    directory : path, optional
        Where to write (default :data:`DOWNLOAD_DIR` under the working directory, which for a
        chapter is ``book/``). The link is relative to the working directory.

    Returns
    -------
    DownloadLink
        Displays as ``Download: table (CSV) · table (JSON)``; in the book each is a
        ``{download}`` link to a copy of the file in ``_build/html/_downloads/``.
    """
    if not re.fullmatch(r"[A-Za-z0-9_.-]+", str(name)):
        raise ValueError(f"name must be letters, digits, '_', '-' or '.', got {name!r}")
    bad = [f for f in formats if f not in ("csv", "json")]
    if bad or not formats:
        raise ValueError(f"formats must be a non-empty subset of ('csv', 'json'), got {formats!r}")
    d = Path(directory) if directory is not None else Path(DOWNLOAD_DIR)
    d.mkdir(parents=True, exist_ok=True)
    paths, labels, rel = [], [], []
    for fmt in formats:
        path = d / f"{name}.{fmt}"
        if fmt == "csv":
            write_table(df, path)
        else:
            path.write_text(_json_records(df.reset_index() if _keep_index(df) else df) + "\n", encoding="utf-8")
        paths.append(path)
        labels.append(f"{label or name} ({fmt.upper()})")
        rel.append(path.as_posix())
    return DownloadLink(paths, labels, rel)
