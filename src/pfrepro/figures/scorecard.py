"""The scorecard page (``book/99_scorecard.md``): its figure, its count tables and its status sentence.

The scorecard reads every claim the chapters saved (:func:`pfrepro.claims.load_all_claims`);
this module only shapes what the page shows from that claims frame, so the page's figure is
drawn for the laptop and the phone (:func:`pfrepro.plotting.show_figure`) and its generated
sentence has a test.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from . import new_figure

__all__ = ["VERDICT_COLORS", "paper_label", "verdict_counts", "verdict_bars", "cause_counts", "status_sentence"]

#: the colour of each verdict in the scorecard's bars (green to red, grey for not checkable)
VERDICT_COLORS = {"reproduced": "#2e7d32", "qualitatively reproduced": "#9ccc65",
                  "not reproduced": "#c62828", "not checkable": "#9e9e9e", "inconclusive": "#f9a825"}


def paper_label(key: str) -> str:
    """A paper key in reader words: ``"ekf_pf_li2012"`` -> ``"Li et al. (2012)"``,
    ``"dpf_hou2008"`` -> ``"Hou and Yin (2008)"``, the synthesis -> ``"Synthesis (this report)"``;
    ``"all claims"`` and unknown keys are returned as they are."""
    from ..published import PAPERS, REPORT_KEYS

    if key in REPORT_KEYS:
        return "Synthesis (this report)"
    src = PAPERS.get(key)
    if src is None or "(" not in src:
        return key
    authors = [a.strip() for a in src.split("(")[0].strip().rstrip(",").split(",") if a.strip()]
    year = src.split("(")[1].split(")")[0]
    if len(authors) == 1:
        return f"{authors[0]} ({year})"
    if len(authors) == 2:
        return f"{authors[0]} and {authors[1]} ({year})"
    return f"{authors[0]} et al. ({year})"


def verdict_counts(claims: pd.DataFrame, order) -> pd.DataFrame:
    """Claims per paper and verdict: one row per key of ``order`` (papers in book order), one column
    per verdict of ``pfrepro.claims.VERDICTS``, ``total``, and a last row ``all claims``.
    ``claims`` is :func:`pfrepro.claims.load_all_claims`'s frame (it may be empty)."""
    from ..claims import VERDICTS

    order = list(order)
    if len(claims):
        counts = (pd.crosstab(claims["paper"], claims["verdict"])
                  .reindex(index=order, columns=list(VERDICTS), fill_value=0))
    else:
        counts = pd.DataFrame(0, index=pd.Index(order), columns=list(VERDICTS))
    counts["total"] = counts.sum(axis=1)
    counts.loc["all claims"] = counts.sum(axis=0)
    counts.index.name = "paper"
    return counts.astype(int)


def verdict_bars(counts: pd.DataFrame):
    """Horizontal stacked bars, one per paper, of :func:`verdict_counts`'s table (without its
    ``all claims`` row): the claims split into their verdicts, each segment labelled with its count
    where it is wide enough to hold it. Made with :func:`pfrepro.figures.new_figure`; the legend sits
    above the bars in two columns (one on the phone)."""
    import matplotlib.pyplot as plt

    from ..claims import VERDICTS
    from ..plotting import current_layout

    rows = [p for p in counts.index if p != "all claims"]
    c = counts.loc[rows, list(VERDICTS)]
    layout = current_layout()
    phone = layout is not None and layout.max_cols == 1
    # on the phone as tall as the layout allows (panel height 0.9 x width): the bars stay thick
    fig, ax = new_figure(figsize=(6.0, 5.4) if phone else (7.5, 1.6 + 0.55 * max(1, len(rows))))
    left = np.zeros(len(rows))
    for v in VERDICTS:
        ax.barh(range(len(rows)), c[v].to_numpy(), left=left, color=VERDICT_COLORS[v], label=v,
                edgecolor="white", linewidth=0.6)
        left += c[v].to_numpy()
    # on the phone the first author and the year (the column is narrow), else the authors
    labels = [paper_label(p).replace(" (this report)", "") for p in rows]
    if phone:
        labels = [f"{lab.split()[0]} {lab.split('(')[-1].rstrip(')')}" if "(" in lab else lab for lab in labels]
    ax.set_yticks(range(len(rows)), labels)
    ax.invert_yaxis()
    ax.set_xlabel("claims")
    ax.spines[["top", "right"]].set_visible(False)
    fig.tight_layout()
    # above the bars, where it covers nothing; made after the layout, so the panel keeps its
    # size and the saved PNG (bbox_inches="tight") grows to hold it
    # (anchored to the figure, not the axes: the labels take the left of a phone's narrow figure)
    top = ax.get_position().y1 + 0.02
    ax.legend(loc="lower left" if phone else "lower center", bbox_to_anchor=(0.0 if phone else 0.5, top),
              bbox_transform=fig.transFigure, ncol=1 if phone else 2, frameon=False, handlelength=1.2)
    # the count in a segment only where it fits (measured on the drawn axes)
    fig.canvas.draw()
    box = ax.get_window_extent()
    x0, x1 = ax.get_xlim()
    inch_per_claim = box.width / fig.dpi / (x1 - x0)
    size_in = plt.rcParams["font.size"] / 72
    left = np.zeros(len(rows))
    for v in VERDICTS:
        n = c[v].to_numpy()
        for i, (lo, k) in enumerate(zip(left, n)):
            if k and k * inch_per_claim >= (0.62 * len(str(k)) + 0.8) * size_in:
                ax.text(lo + k / 2, i, str(k), ha="center", va="center",
                        color="white" if v in ("reproduced", "not reproduced") else "black")
        left += n
    return fig


def cause_counts(claims: pd.DataFrame, order) -> pd.DataFrame:
    """The inconclusive claims per paper and cause (:func:`pfrepro.claims.causes_table`), papers in
    ``order`` and in words (:func:`paper_label`), without the causes no claim has; a column
    ``paper`` instead of an index."""
    from ..claims import as_claims, causes_table

    by = causes_table(as_claims(claims))
    by = by.reindex([p for p in list(order) + ["all claims"] if p in by.index])
    by = by.loc[:, (by != 0).any(axis=0)]
    by.index = [paper_label(p) for p in by.index]
    return by.rename_axis("paper").reset_index()


def status_sentence(n_paper_claims: int, n_papers_found: int, n_papers: int, n_report: int) -> str:
    """What this build's scorecard holds, e.g. "166 claims from 5 of the 5 papers, and 15 claims of
    the synthesis chapter" (the count of claims saved by the chapters of the build)."""
    from ..prose import plural

    for name, v in (("n_paper_claims", n_paper_claims), ("n_papers_found", n_papers_found),
                    ("n_papers", n_papers), ("n_report", n_report)):
        if not isinstance(v, (int, np.integer)) or v < 0:
            raise ValueError(f"status_sentence: {name} must be a count (int >= 0), got {v!r}")
    if n_papers_found > n_papers:
        raise ValueError(f"status_sentence: n_papers_found ({n_papers_found}) > n_papers ({n_papers})")
    if n_paper_claims + n_report == 0:
        return "no chapter has saved any claims yet, so the tables below are empty"
    if n_papers_found == n_papers:
        of = f"all {n_papers} papers" if n_papers > 1 else "the book's one paper"
    else:
        of = f"{n_papers_found} of the {plural(n_papers, 'paper')}"
    head = f"{plural(n_paper_claims, 'claim')} from {of}"
    return head + (f", and {plural(n_report, 'claim')} of the synthesis chapter" if n_report else "")
