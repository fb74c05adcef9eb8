"""The chapters' prose helpers: glue values, phrases and figures, and counts with their grammar.

Every number in a chapter's prose comes from code through myst-nb's ``glue``; these are the
one set of helpers every chapter imports (instead of a ``g``/``gl``/``gmd`` of its own):

* :func:`glue_value` -- a number or string for ``{glue:text}`` (numpy scalars as Python
  numbers, so format specs such as ``:.3f`` apply);
* :func:`glue_md` -- a data-dependent phrase for ``{glue:md}``;
* :func:`glue_figure` -- a figure for ``{glue:figure}`` (closed after gluing, so it is shown once);
* :func:`plural`, :func:`count_is`, :func:`verdict_sentence` -- generated sentences that agree
  in number ("1 is reproduced", "3 are reproduced").
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np

__all__ = ["glue_value", "glue_md", "glue_all", "Md", "glue_figure", "plural", "count_is", "join_and", "verdict_sentence", "VERDICT_ORDER",
           "MISSING", "use_book_tables", "text_columns"]

#: how a table shows a missing value (NaN), a dash with its meaning on hover, never "NaN"
MISSING = "—"
_MISSING_HTML = '<span class="pf-missing" title="no value: not computed, not published or not applicable">—</span>'


def _nowrap_cells(html: str) -> str:
    """Numbers in plain table cells kept on one line (never "3.20e-" / "14"); "nan" cells a dash."""
    import re

    from .bookinfo import nowrap_numbers

    html = re.sub(r"(<td[^>]*>)\s*(?:nan|NaN|None|&lt;NA&gt;)\s*(</td>)", lambda m: m.group(1) + MISSING + m.group(2), html)
    return re.sub(r"(<td[^>]*>)([^<]*)(</td>)", lambda m: m.group(1) + nowrap_numbers(m.group(2)) + m.group(3), html)


#: a run of two letters (any script) left after the numbers are taken out: the cell is text
_WORD = r"[^\W\d_]{2,}"


def text_columns(df) -> list:
    """The columns of ``df`` that hold text (names, reasons, verdicts), not numbers.

    A column is text when it is not of a numeric dtype and more than half of its non-empty
    cells still hold a word of two or more letters once every number is taken out
    ("PF(500)", "diverged" and a reason in words are text; "0.0038 ± 0.0011", "12 %", "1e-3"
    and "—" are not). The book's tables left-align these columns and right-align the rest
    (numbers line up on their last digit, prose reads from the left).

    Parameters
    ----------
    df : pandas.DataFrame
        The table.

    Returns
    -------
    list
        The labels of the text columns, in the table's order.
    """
    import re

    import pandas as pd

    from .bookinfo import _NUMBER

    out = []
    for col in df.columns:
        s = df[col]
        if isinstance(s, pd.DataFrame) or pd.api.types.is_numeric_dtype(s) or pd.api.types.is_bool_dtype(s):
            continue
        cells = [str(v).strip() for v in s if not (v is None or (isinstance(v, float) and np.isnan(v)))]
        cells = [v for v in cells if v and v not in (MISSING, "–", "-", "nan", "NaN", "None")]
        if cells and 2 * sum(bool(re.search(_WORD, _NUMBER.sub(" ", v))) for v in cells) > len(cells):
            out.append(col)
    return out


def _left_align_cells(html: str, positions: set) -> str:
    """``class="pf-left"`` on the ``<td>`` cells at column ``positions`` of every body row."""
    import re

    if not positions:
        return html

    def row(m):
        i = -1

        def td(t):
            nonlocal i
            i += 1
            return '<td class="pf-left">' if i in positions else t.group(0)

        return re.sub(r"<td>", td, m.group(0))

    return re.sub(r"<tr>.*?</tr>", row, html, flags=re.S)


def _frame_html(df) -> str:
    """A DataFrame as the book shows it: whole cells (no "..." cut), missing values as a dash,
    numbers never broken, text columns left-aligned (:func:`text_columns`)."""
    import pandas as pd

    left = set(text_columns(df))
    positions = {j for j, c in enumerate(df.columns) if c in left}
    with pd.option_context("display.max_colwidth", None):
        return _nowrap_cells(_left_align_cells(df.to_html(na_rep=MISSING, border=0), positions))


def _styler_html(styler) -> str:
    """A pandas Styler as the book shows it: numbers never broken, text columns left-aligned."""
    cols = text_columns(styler.data)
    if cols:
        try:
            styler = styler.set_properties(subset=cols, **{"text-align": "left"})
        except (KeyError, ValueError, TypeError):  # pragma: no cover - an unusual column index: keep the table as is
            pass
    return _nowrap_cells(styler.to_html())


def use_book_tables() -> None:
    """Show every DataFrame of the running notebook the book's way.

    Missing values (NaN) appear as "—" instead of "NaN" (a chapter says why next to its
    table), no cell is cut to ``display.max_colwidth`` with "...", numbers are never broken
    over two lines (``span.pf-num``) and text columns are left-aligned (:func:`text_columns`);
    Styler tables get the same dash, unbroken numbers and alignment. Called by :func:`pfrepro.plotting.use_book_style`, which every chapter runs
    first; outside IPython it only sets the pandas options.
    """
    import pandas as pd

    pd.set_option("styler.format.na_rep", MISSING)
    pd.set_option("display.max_colwidth", None)
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython is a dependency of the book
        return
    ip = get_ipython()
    if ip is not None:
        from pandas.io.formats.style import Styler

        html = ip.display_formatter.formatters["text/html"]
        html.for_type(pd.DataFrame, _frame_html)
        html.for_type(Styler, _styler_html)


#: the verdict scale, in the order sentences list it
VERDICT_ORDER = ("reproduced", "qualitatively reproduced", "not reproduced", "inconclusive", "not checkable")


def glue_value(name: str, value, display: bool = False) -> None:
    """Glue ``value`` under ``name`` for ``{glue:text}`` (numpy scalars become Python numbers).

    Parameters
    ----------
    name : str
        The glue key.
    value : object
        A number, string or other object myst-nb can glue.
    display : bool
        Also show the value where the cell runs (default False).

    Notes
    -----
    Returns nothing, so a call that ends a cell adds no output to the page.
    """
    from myst_nb import glue

    if isinstance(value, np.generic):
        value = value.item()
    glue(name, value, display=display)


def glue_md(name: str, text: str) -> None:
    """Glue a Markdown phrase under ``name`` for ``{glue:md}`` (returns nothing: no cell output)."""
    from IPython.display import Markdown
    from myst_nb import glue

    glue(name, Markdown(text), display=False)


class Md(str):
    """A generated Markdown phrase: :func:`glue_all` glues it for ``{glue:md}`` (a plain ``str`` is text)."""


def glue_all(values) -> None:
    """Glue every ``name -> value`` of ``values``: :class:`Md` phrases with :func:`glue_md`, the rest
    with :func:`glue_value`. For the dict a :mod:`pfrepro.verdicts` module's ``prose(reg, results)``
    returns, so that the numbers and words around a chapter's verdicts are computed (and tested)
    in the package, and the chapter only glues them."""
    for name, value in values.items():
        if isinstance(value, Md):
            glue_md(name, str(value))
        else:
            glue_value(name, value)


def glue_figure(name: str, draw, *args, alt: str, **kwargs) -> None:
    """Glue a figure under ``name`` for ``{glue:figure}``, drawn for the laptop and the phone.

    ``draw(*args, **kwargs)`` returns the matplotlib figure; it is called once per layout
    (:func:`pfrepro.plotting.responsive`, which needs ``alt``, the figure's text alternative).
    A figure already drawn cannot be reflowed for a phone, so a ``Figure`` is refused.
    """
    from matplotlib.figure import Figure
    from myst_nb import glue

    from .plotting import responsive

    if isinstance(draw, Figure):
        raise TypeError(f"glue_figure({name!r}, ...) needs the function that draws the figure "
                        "(it is drawn once for the laptop and once for the phone), not a drawn Figure")
    glue(name, responsive(draw, *args, alt=alt, **kwargs), display=False)


def plural(n: int, one: str, many: str | None = None) -> str:
    """``"1 claim"``, ``"2 claims"``: the count with the right form of the noun."""
    many = many if many is not None else one + "s"
    return f"{n} {one if n == 1 else many}"


def join_and(items) -> str:
    """``"a"``, ``"a and b"``, ``"a, b and c"``: a list in running text (``ValueError`` if empty)."""
    items = [str(i) for i in items]
    if not items:
        raise ValueError("join_and needs at least one item")
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def count_is(n: int, predicate: str) -> str:
    """``"1 is reproduced"``, ``"0 are reproduced"``, ``"3 are reproduced"``."""
    return f"{n} {'is' if n == 1 else 'are'} {predicate}"


def verdict_sentence(verdicts: Iterable[str] | Mapping[str, int], noun: str = "claim",
                     order: Iterable[str] = VERDICT_ORDER, always: Iterable[str] = VERDICT_ORDER[:4]) -> str:
    """One sentence counting verdicts, in number agreement.

    Parameters
    ----------
    verdicts : iterable of str or mapping
        The verdict of every claim, or a mapping verdict -> count.
    noun : str
        What is counted (singular), e.g. ``"claim"`` or ``"recorded claim"``.
    order : iterable of str
        The verdicts to list, in order (any other verdict follows).
    always : iterable of str
        Verdicts listed even with no claim ("0 are inconclusive"); the others only when some
        claim has them.

    Returns
    -------
    str
        E.g. "Of 12 claims, 1 is reproduced, 3 are qualitatively reproduced, 0 are not
        reproduced and 8 are inconclusive".
    """
    if isinstance(verdicts, Mapping):
        counts = {str(k): int(v) for k, v in verdicts.items()}
    else:
        counts = {}
        for v in verdicts:
            counts[str(v)] = counts.get(str(v), 0) + 1
    total = sum(counts.values())
    order, always = list(order), set(always)
    parts = [count_is(counts.get(v, 0), v) for v in order if v in always or counts.get(v, 0)]
    parts += [count_is(n, v) for v, n in counts.items() if v not in order and n]
    return f"Of {plural(total, noun)}, {join_and(parts)}"
