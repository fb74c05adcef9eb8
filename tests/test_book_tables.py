"""How the book's tables and prose typography come out: text columns left, numbers right;
quotation marks that Sphinx's smart quotes turn the right way round."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pfrepro.prose import _frame_html, _styler_html, text_columns

ROOT = Path(__file__).resolve().parents[1]


def test_text_columns_tells_text_from_numbers():
    df = pd.DataFrame({
        "numbers as text": ["0.0038 ± 0.0011", "12 %", "1e-3", "—"],
        "labels": ["PF(500)", "GPFF(100)", "diverged", "KF"],
        "floats": [1.0, 2.0, np.nan, 4.0],
        "reasons, mostly empty": ["", "", "no particles: the count sees 2-4 model calls a step", None],
        "ints": [1, 2, 3, 4],
        "flags": [True, False, True, False],
    })
    assert text_columns(df) == ["labels", "reasons, mostly empty"]
    # a column of mostly numbers with one note stays a number column
    assert text_columns(pd.DataFrame({"x": ["1.2", "3.4", "5.6", "lost"]})) == []


def test_frame_html_left_aligns_text_columns_only():
    df = pd.DataFrame({"n": [1, 2], "why": ["a reason", None], "value": ["1.5 ± 0.2", "2.5 ± 0.1"]},
                      index=["x", "y"])
    html = _frame_html(df)
    rows = re.findall(r"<tr>\s*<th>[xy]</th>(.*?)</tr>", html, flags=re.S)
    assert len(rows) == 2
    for row in rows:
        cells = re.findall(r"<td([^>]*)>", row)
        assert cells == ["", ' class="pf-left"', ""]
    assert "—" in html   # the missing reason is a dash, in the left-aligned cell


def test_styler_html_left_aligns_text_columns_only():
    df = pd.DataFrame({"n": [1.0, 2.0], "why": ["a reason", "another reason"]})
    html = _styler_html(df.style.format({"n": "{:.1f}"}))
    rule = re.search(r"([^{}]*)\{\s*text-align: left;\s*\}", html)
    assert rule is not None
    selectors = rule.group(1)
    assert "_col1" in selectors and "_col0" not in selectors


def test_the_cost_table_reads_its_reasons_from_the_left():
    """The cost table of the filters chapter (book/10_filters.md): family and why are text."""
    bench = pd.read_csv(ROOT / "book" / "data" / "bench_all.csv", index_col="filter")
    assert {"family", "why"} <= set(text_columns(bench))
    assert not {"particles", "count per step"} & set(text_columns(bench))


def _prose_lines(path: Path):
    """The Markdown lines of a chapter outside code cells, directives and inline code."""
    fence = None
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        m = re.match(r"\s*(```+|~~~+)", line)
        if m:
            fence = None if fence and m.group(1).startswith(fence) else (fence or m.group(1))
            continue
        if fence is None:
            yield n, re.sub(r"`[^`]*`", "", line)


@pytest.mark.parametrize("chapter", sorted(p.name for p in (ROOT / "book").glob("*.md")))
def test_smart_quotes_open_and_close_the_right_way(chapter):
    """Sphinx turns "..." into curly quotes by context; next to a dash or a bracket it guesses
    wrong (("—") became (”—“)). Such places must use the curly quotes themselves."""
    from docutils.utils.smartquotes import smartyPants

    bad = []
    for n, line in _prose_lines(ROOT / "book" / chapter):
        if '"' not in line:
            continue
        out = smartyPants(line, attr="qDe")
        if re.search(r"(^|[\s(\[])”|“($|[\s).,;:\]])", out):
            bad.append(f"{chapter}:{n}: {out.strip()[:120]}")
    assert not bad, "\n".join(bad)


def test_the_smart_quote_check_fails_on_the_reversed_case():
    from docutils.utils.smartquotes import smartyPants

    out = smartyPants('divide by ("—").', attr="qDe")
    assert re.search(r"(^|[\s(\[])”|“($|[\s).,;:\]])", out)
    assert not re.search(r"(^|[\s(\[])”|“($|[\s).,;:\]])", smartyPants("divide by (“—”).", attr="qDe"))
