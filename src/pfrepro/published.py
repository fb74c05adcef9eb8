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

Printed digits. The paper's numbers are shown exactly as printed (``30.1709``, never
``30.171``; ``4.6440`` keeps its trailing zero): the ``value`` column is read as text,
kept as the *printed string* (:func:`printed`, :func:`printed_table`), and parsed to a
float (Python's correctly rounded ``float(text)``) for computing. Tables show a
published cell through :func:`printed` / :func:`printed_table`, or format a column of
published floats with :func:`formatter` (a float is mapped back to the unique printed
string of the paper's data file that parses to it). Claims carry the printed string in
``published_text`` (:meth:`pfrepro.claims.ClaimsRegistry.add`), which the claims table
shows in its ``published`` column.
"""
from __future__ import annotations

from functools import lru_cache
from importlib import resources

import pandas as pd

__all__ = ["PAPERS", "REPORT_KEYS", "CLAIM_SOURCES", "load", "value", "table", "se_from_std", "per_run_se",
           "load_printed", "printed", "printed_table", "formatter", "printed_for"]

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
def load_printed(paper: str) -> pd.DataFrame:
    """All published numbers of ``paper`` with the value column as printed text.

    Columns ``paper, table, row, column, value, note``; ``value`` holds the string of the
    data file unchanged (``"30.1709"``, ``"4.6440"``), stripped of surrounding blanks.
    Every value must parse as a number (``ValueError`` naming the cell otherwise).
    """
    if paper not in PAPERS:
        raise KeyError(f"unknown paper {paper!r}; known: {sorted(PAPERS)}")
    path = resources.files("pfrepro") / "data" / "published" / f"{paper}.csv"
    if not path.is_file():
        raise FileNotFoundError(f"no published numbers recorded for {paper} ({path})")
    with path.open("r", encoding="utf-8") as fh:
        df = pd.read_csv(fh, comment="#", dtype=str, keep_default_na=False)
    df["value"] = df["value"].str.strip()
    for r in df.itertuples():
        try:
            float(r.value)
        except ValueError:
            raise ValueError(f"{paper} {r.table} row={r.row!r} column={r.column!r}: "
                             f"published value {r.value!r} is not a number") from None
    df.insert(0, "paper", paper)
    return df


@lru_cache(maxsize=None)
def load(paper: str) -> pd.DataFrame:
    """All published numbers of ``paper`` as a DataFrame (table, row, column, value, note).

    ``value`` is the float of the printed text (``float(text)``, correctly rounded); the
    text itself is :func:`load_printed`'s.
    """
    df = load_printed(paper).copy()
    df["value"] = df["value"].map(float).astype(float)
    df["note"] = df["note"].replace("", float("nan"))
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
    return float(printed(paper, table_id, row, column))


def printed(paper: str, table_id: str, row: str, column: str) -> str:
    """A single published number exactly as the paper prints it (the data file's text).

    ``printed("ekf_pf_li2012", "Table 1", "EKF", "Model 1") == "30.1709"``;
    ``float(printed(...)) == value(...)``.
    """
    df = load_printed(paper)
    hit = df[(df["table"] == table_id) & (df["row"] == str(row)) & (df["column"] == str(column))]
    if len(hit) != 1:
        raise KeyError(f"{paper} {table_id}: no unique entry for row={row!r}, column={column!r}")
    return str(hit["value"].iloc[0])


def printed_table(paper: str, table_id: str) -> pd.DataFrame:
    """One published table pivoted to rows x columns like :func:`table`, cells as printed strings."""
    df = load_printed(paper)
    sub = df[df["table"] == table_id]
    if sub.empty:
        raise KeyError(f"{paper} has no published table {table_id!r}; has {sorted(df['table'].unique())}")
    order_r = list(dict.fromkeys(sub["row"]))
    order_c = list(dict.fromkeys(sub["column"]))
    return sub.pivot(index="row", columns="column", values="value").loc[order_r, order_c]


def printed_for(paper: str, number, table_id: str | None = None) -> str | None:
    """The printed string of ``paper``'s data file (optionally of one table) whose value is
    ``number``, or ``None`` if no cell has that value (a derived number, e.g. a ratio of two
    published cells). ``ValueError`` if two cells with that value are printed differently.
    Matching is exact on the float (``float(text) == number``), with a relative slack of
    1e-12 for a number that went through a float32 or a JSON round trip."""
    import math

    if number is None:
        return None
    try:
        x = float(number)
    except (TypeError, ValueError):
        return None
    if not math.isfinite(x):
        return None
    df = load_printed(paper)
    if table_id is not None:
        df = df[df["table"] == table_id]
    texts = {t for t in df["value"] if abs(float(t) - x) <= 1e-12 * max(1.0, abs(x))}
    if len(texts) > 1:
        raise ValueError(f"{paper}: {x!r} is printed as {sorted(texts)} in different cells; "
                         "use printed(paper, table, row, column)")
    return texts.pop() if texts else None


def formatter(paper: str, table_id: str | None = None, *, missing: str = "–"):
    """A cell formatter that shows a published float with the paper's printed digits.

    Returns ``fmt(x) -> str`` for ``DataFrame.style.format`` / ``DataFrame.to_string(formatters=...)``:
    the printed string of the paper's (table's) cell with value ``x`` (:func:`printed_for`),
    ``missing`` for NaN/None. A float that is not a published value raises ``KeyError``, so a
    number computed by us can never be shown as if printed by the paper.
    """
    import math

    def fmt(x) -> str:
        if x is None or (isinstance(x, float) and math.isnan(x)):
            return missing
        if isinstance(x, str):
            if printed_for(paper, float(x), table_id) != x:
                raise KeyError(f"{x!r} is not a value printed in {paper} {table_id or ''}".rstrip())
            return x
        text = printed_for(paper, x, table_id)
        if text is None:
            raise KeyError(f"{x!r} is not a value printed in {paper} {table_id or ''}".rstrip())
        return text

    return fmt


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
