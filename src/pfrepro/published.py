"""The papers' published numbers, kept as data.

One CSV per paper in ``pfrepro/data/published/<paper>.csv`` with columns
``table, row, column, value, note`` (``table`` is the paper's own id, e.g.
"Table 1" or "Fig. 3"). Chapters read them here to put each reproduced table
beside the published one; nothing in the book types a published number.

Published uncertainty. Where a paper prints a spread (a standard deviation over its
runs) or the per-run rows themselves, the standard error of its mean is computed here,
not typed: :func:`se_from_std` (printed std over ``runs`` runs) and :func:`per_run_se`
(sample std, divisor n - 1, of the printed per-run rows, over sqrt(n)). The claims rule
combines it with ours (``pfrepro.claims.verdict``, ``published_se``).
"""
from __future__ import annotations

from functools import lru_cache
from importlib import resources

import pandas as pd

__all__ = ["PAPERS", "REPORT_KEYS", "CLAIM_SOURCES", "load", "value", "table", "se_from_std", "per_run_se"]

#: paper keys used throughout the package and the book
PAPERS = {
    "gpff_zhang2016": "Zhang, Zhou, Feng (2016), Gaussian particle flow filter",
    "dpf_hou2008": "Hou, Yin (2008), dual particle filter",
    "ekf_pf_li2012": "Li, Li, Fang, Bai (2012), EKF and PF in target tracking",
    "cmspf_ning2011": "Ning, Chen, Zhao, He, Shi (2011), chaos map sampling PF",
    "immpfor_zhou2017": "Zhou, Sun, Chu, Cui (2017), IMM-PF optimised resampling",
}

#: Claim registries of this report's own chapters that are not papers and have no published numbers.
#: The scorecard lists their claims in a section of their own, after the papers, and counts only PAPERS.
REPORT_KEYS = {
    "synthesis": "Synthesis: the papers' methods at equal cost (this report, not a paper)",
}

#: Every key a claims registry may use, the papers first, then the report's own chapters.
CLAIM_SOURCES = {**PAPERS, **REPORT_KEYS}


@lru_cache(maxsize=None)
def load(paper: str) -> pd.DataFrame:
    """All published numbers of ``paper`` as a DataFrame (table, row, column, value, note)."""
    if paper not in PAPERS:
        raise KeyError(f"unknown paper {paper!r}; known: {sorted(PAPERS)}")
    path = resources.files("pfrepro") / "data" / "published" / f"{paper}.csv"
    if not path.is_file():
        raise FileNotFoundError(f"no published numbers recorded for {paper} ({path})")
    with path.open("r", encoding="utf-8") as fh:
        df = pd.read_csv(fh, comment="#", dtype={"table": str, "row": str, "column": str})
    df.insert(0, "paper", paper)
    return df


def table(paper: str, table_id: str) -> pd.DataFrame:
    """One published table pivoted to rows x columns."""
    df = load(paper)
    sub = df[df["table"] == table_id]
    if sub.empty:
        raise KeyError(f"{paper} has no published table {table_id!r}; has {sorted(df['table'].unique())}")
    order_r = list(dict.fromkeys(sub["row"]))
    order_c = list(dict.fromkeys(sub["column"]))
    return sub.pivot(index="row", columns="column", values="value").loc[order_r, order_c]


def value(paper: str, table_id: str, row: str, column: str) -> float:
    """A single published number."""
    df = load(paper)
    hit = df[(df["table"] == table_id) & (df["row"] == row) & (df["column"] == column)]
    if len(hit) != 1:
        raise KeyError(f"{paper} {table_id}: no unique entry for row={row!r}, column={column!r}")
    return float(hit["value"].iloc[0])


def se_from_std(std, runs: int) -> float:
    """Standard error of a published mean from its printed standard deviation over ``runs`` runs."""
    import math

    std, runs = float(std), int(runs)
    if runs < 2 or not math.isfinite(std) or std < 0:
        raise ValueError(f"se_from_std needs a finite std >= 0 and runs >= 2, got {std!r}, {runs!r}")
    return std / math.sqrt(runs)


def per_run_se(paper: str, table_id: str, column: str, rows) -> float:
    """Standard error of the mean of the printed per-run rows ``rows`` of one column.

    ``std(rows, ddof=1) / sqrt(len(rows))``: what the paper's own runs say about the
    uncertainty of its mean (e.g. rows 1-20 of Ning et al.'s Tables 1 and 3).
    """
    import numpy as np

    t = table(paper, table_id)
    rows = [str(r) for r in rows]
    v = t.loc[rows, column].to_numpy(float)
    if v.size < 2 or not np.all(np.isfinite(v)):
        raise ValueError(f"{paper} {table_id} {column!r}: need >= 2 finite per-run rows, got {v.size}")
    return float(v.std(ddof=1) / np.sqrt(v.size))
