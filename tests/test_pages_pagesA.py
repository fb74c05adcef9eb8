"""The introduction, the filters chapter, the tutorial and the GPFF chapter as a reader sees them,
checked in their sources (the built pages are checked by tests/browser/check_pages.py).

- every figure is drawn by a function, for the laptop and the phone (``show_figure``), never by
  ``plt.subplots`` / ``plt.show`` in a cell, and no text is set smaller than the layout's;
- the tutorial shows its refusals' messages whole (wrapped, not cut at the page's edge), and its
  visible cells are the reader's code only (numbers are glued in removed cells);
- the introduction shows no cell of code constants; the filters chapter prints no dict;
- the sentences those chapters generate from a count read right for every count.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from pfrepro.prose import count_is, join_and

BOOK = Path(__file__).resolve().parents[1] / "book"
PAGES = ("index.md", "10_filters.md", "15_own_model.md", "20_gpff.md")
_CELL = re.compile(r"```\{code-cell\}[^\n]*\n(?P<body>.*?)\n```", re.S)


def cells(name):
    """(options, source) of every code cell of a chapter (options: the YAML / ``:tags:`` header)."""
    out = []
    for m in _CELL.finditer((BOOK / name).read_text(encoding="utf-8")):
        body = m.group("body")
        head = ""
        y = re.match(r"---\n(.*?)\n---\n", body, re.S)
        if y:
            head, body = y.group(1), body[y.end():]
        t = re.match(r"(:tags:[^\n]*)\n", body)
        if t:
            head, body = t.group(1), body[t.end():]
        out.append((head, body))
    return out


def hidden(head):
    return bool(re.search(r"remove-cell|remove-input|hide-input|hide-cell", head))


@pytest.mark.parametrize("name", PAGES)
def test_figures_are_drawn_for_both_widths(name):
    for head, src in cells(name):
        assert "plt.subplots" not in src and "plt.show" not in src, (name, src[:80])
        assert not re.search(r"fontsize\s*=\s*(\d|\"(x-|xx-)?small)", src), (name, src[:80])
        if "caption:" in head and "figure:" in head:     # a figure cell ends with its drawing
            last = src.strip().splitlines()
            assert any(line.startswith("show_figure(") for line in last), (name, src[:80])
            assert "alt=" in src and "alt:" not in head


def test_the_tutorials_visible_cells_are_the_readers_code():
    visible = [src for head, src in cells("15_own_model.md") if not hidden(head)]
    assert len(visible) >= 10
    for src in visible:
        assert not re.search(r"(^|\W)(gl|glue)\(", src), src[:120]


def test_the_tutorials_error_messages_are_shown_whole():
    """The refusals are the point of the tutorial's example: printed wrapped to the page, not in a
    fixed-width column that cuts them at the right edge."""
    src = "\n".join(s for h, s in cells("15_own_model.md") if "refusals" in s or "KalmanFilter(tracker)" in s)
    assert src.count("textwrap.fill(") >= 2 and ":28s}" not in src


def test_the_introduction_shows_no_code_constants():
    for head, src in cells("index.md"):
        assert hidden(head), src[:80]
    text = (BOOK / "index.md").read_text(encoding="utf-8")
    assert "{glue:text}`z_crit" in text and "{glue:text}`rel_tol:" in text


def test_the_filters_chapter_prints_no_dict():
    for head, src in cells("10_filters.md"):
        assert not re.search(r"^print\((mismatch|\{)", src, re.M), src[:80]


@pytest.mark.parametrize("n, words", [(0, "0 are below it"), (1, "1 is below it"), (3, "3 are below it")])
def test_generated_counts_read_for_every_count(n, words):
    """The filters chapter's "of the three, N are below it" and the cost table's counts."""
    assert count_is(n, "below it") == words


def test_the_tutorials_refusal_sentence_names_the_filters():
    assert join_and(["KalmanFilter"]) == "KalmanFilter"
    assert join_and(["A", "B", "C"]) == "A, B and C"
