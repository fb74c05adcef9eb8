"""What a build of the book contains and what built it.

Small helpers for the book's framing pages, so that no statement about the book itself is
typed by hand:

* :func:`papers_in_book` — which papers have a chapter in this build (from ``_toc.yml``);
* :func:`claim_anchor` / :func:`claim_anchor_html` / :func:`claim_href` — one anchor per
  claim in its chapter, ``claim-<paper>-<claim_id>``, and links to it from the scorecard;
* :func:`labelled_table_html`, :func:`card_table`, :func:`choices_display`, :func:`choices_cards` — the
  chapters' text tables, whose rows become cards on a phone, with :func:`reader_text`,
  :func:`plain_math` and :func:`cell_html` writing their formulas and names as a reader reads them;
* :func:`build_info` — package versions, git commit, build date (UTC) and CPU, for the
  archive reader.
"""
from __future__ import annotations

import datetime as _dt
import html
import os
import platform
import re
import subprocess
from importlib import metadata
from pathlib import Path

__all__ = ["book_root", "toc_files", "papers_in_book", "claim_anchor", "claim_anchor_html",
           "claim_href", "anchored_claims", "labelled_table_html", "nowrap_numbers", "reader_text", "plain_math",
           "cell_html", "card_table", "choices_display", "choices_cards", "build_info", "cpu_model"]


def book_root(start: Path | None = None) -> Path:
    """The directory holding ``_toc.yml`` (searched upwards from ``start`` or the cwd)."""
    p = Path(start or Path.cwd()).resolve()
    for d in (p, *p.parents):
        if (d / "_toc.yml").is_file():
            return d
    raise FileNotFoundError(f"no _toc.yml in {p} or above")


def toc_files(root: Path | None = None) -> list[str]:
    """Every ``file:`` / ``root:`` entry of ``_toc.yml``, in book order (no extension)."""
    import yaml

    root = book_root(root)
    toc = yaml.safe_load((root / "_toc.yml").read_text(encoding="utf-8"))
    out: list[str] = []

    def walk(node):
        if isinstance(node, dict):
            for key in ("root", "file"):
                if isinstance(node.get(key), str):
                    out.append(node[key])
            for v in node.values():
                if isinstance(v, (list, dict)):
                    walk(v)
        elif isinstance(node, list):
            for v in node:
                walk(v)

    walk(toc)
    seen = set()
    return [f for f in out if not (f in seen or seen.add(f))]


def papers_in_book(root: Path | None = None, *, report: bool = False) -> dict[str, str]:
    """``{paper key: chapter docname}`` for the papers that have a chapter in this build; with
    ``report=True`` also the report's own claim registries that are not papers
    (:data:`pfrepro.published.REPORT_KEYS`, e.g. ``synthesis``: the scorecard links their claims).

    A chapter covers a paper when its source imports the paper's experiment module
    (``from pfrepro.experiments import <key>`` or ``pfrepro.experiments.<key>``) or opens its
    claims registry (``ClaimsRegistry("<key>")``) or runs it (``get_paper("<key>")``). Order: book order.
    """
    from .published import CLAIM_SOURCES, PAPERS

    keys = CLAIM_SOURCES if report else PAPERS
    root = book_root(root)
    found: dict[str, str] = {}
    for doc in toc_files(root):
        src = next((root / f"{doc}{ext}" for ext in (".md", ".ipynb", ".rst")
                    if (root / f"{doc}{ext}").is_file()), None)
        if src is None:
            continue
        text = src.read_text(encoding="utf-8")
        for key in keys:
            k = re.escape(key)
            pat = (rf"from\s+pfrepro\.experiments\s+import\s+{k}\b|import\s+pfrepro\.experiments\.{k}\b"
                   rf"|from\s+pfrepro\.experiments\.{k}\s+import|ClaimsRegistry\(\s*[\"']{k}[\"']"
                   rf"|get_paper\(\s*[\"']{k}[\"']")
            if key not in found and re.search(pat, text):
                found[key] = doc
    return found


def claim_anchor(paper: str, claim_id: str) -> str:
    """HTML id of a claim in its chapter: ``claim-<paper>-<claim_id>`` (safe characters only)."""
    return "claim-" + re.sub(r"[^A-Za-z0-9_-]+", "-", f"{paper}-{claim_id}").strip("-").lower()


def claim_anchor_html(paper: str, claim_id: str, text: str | None = None) -> str:
    """``<span id="claim-...">text</span>``: put it in the claim's row of a chapter's verdict table."""
    return f'<span id="{claim_anchor(paper, claim_id)}">{html.escape(claim_id if text is None else text)}</span>'


def claim_href(paper: str, claim_id: str, docname: str, from_doc: str | None = None) -> str:
    """Relative link from page ``from_doc`` to the claim's anchor in chapter ``docname``."""
    target = Path(docname + ".html")
    if from_doc is not None:
        target = Path(os.path.relpath(target, Path(from_doc).parent))
    return f"{target.as_posix()}#{claim_anchor(paper, claim_id)}"


def anchored_claims(table, paper: str, id_col: str | None = None, *, float_format: str = "{:.4g}",
                    classes: str = "pf-claims pf-text"):
    """A chapter's verdict table as HTML with an anchor on every claim (for the scorecard's links).

    ``table``: a DataFrame with one row per claim and a column of claim ids (``id`` or
    ``claim_id``, or ``id_col``), e.g. ``pfrepro.claims.claims_table(reg)``. Each id cell becomes
    ``<span id="claim-<paper>-<id>">id</span>``; a ``verdict`` column's verdict word becomes a link
    to its definition (:func:`pfrepro.claims.verdict_html`); every other cell is escaped text
    (floats with ``float_format``, missing values as "–"). Returns an ``IPython.display.HTML``.
    """
    import math

    from IPython.display import HTML

    if id_col is None:
        id_col = next((c for c in ("id", "claim_id") if c in table.columns), None)
        if id_col is None:
            raise ValueError(f"anchored_claims: no 'id' or 'claim_id' column in {list(table.columns)}")
    elif id_col not in table.columns:
        raise ValueError(f"anchored_claims: id_col {id_col!r} not in {list(table.columns)}")

    def cell(v):
        if v is None or (isinstance(v, float) and math.isnan(v)):
            return "–"
        if isinstance(v, float):
            return html.escape(float_format.format(v))
        return html.escape(str(v))

    t = table.reset_index(drop=True).copy()
    ids = [str(i) for i in t[id_col]]
    for col in t.columns:
        t[col] = [cell(v) for v in t[col]]
    t[id_col] = [claim_anchor_html(paper, i) for i in ids]
    if "verdict" in table.columns:  # the verdict word links to its definition (the scorecard's scale)
        from .claims import verdict_html
        def keep_numbers(text):
            return nowrap_numbers(html.escape(text))
        t["verdict"] = [verdict_html(v, escape=keep_numbers) if isinstance(v, str) else cell(v)
                        for v in table.reset_index(drop=True)["verdict"]]
    return HTML(labelled_table_html(t, classes=classes))


# a number as a reader reads it: sign, digits, decimals, exponent, percent (kept on one line)
_NUMBER = re.compile(r"(?<![\w.&#])[-+−]?\d+(?:[.,]\d+)*(?:[eE][-+−]?\d+)?%?(?!\w)")


def nowrap_numbers(text: str) -> str:
    """Escaped HTML text with every number in ``<span class="pf-num">`` (never broken inside) and a
    no-break space after "±", so "0.0038 ± 0.0011" may wrap before the "±" but nowhere else."""
    text = _NUMBER.sub(lambda m: f'<span class="pf-num">{m.group(0)}</span>', text)
    return text.replace("± ", "±&nbsp;")


#: characters after which a table cell may wrap inside a token ("pf_resampling=<wbr>multinomial",
#: "published/<wbr>measured"): a long token breaks there, never inside a run of letters
_BREAK_AFTER = re.compile(r"([_=/])(?=[^\s<])")


def breakable_text(body: str) -> str:
    """HTML ``body`` with a ``<wbr>`` (a line-break opportunity) after every ``_``, ``=`` or ``/``
    inside a token, in the text between tags only (tags and their attributes are left alone)."""
    return re.sub(r">([^<]*)<", lambda m: ">" + _BREAK_AFTER.sub(r"\1<wbr>", m.group(1)) + "<", f">{body}<")[1:-1]


def labelled_table_html(table, *, classes: str = "pf-claims pf-text") -> str:
    """A DataFrame of HTML cells as a ``<table>`` whose cells carry their column name.

    Every ``<td>`` gets ``data-label="<column>"``, so below the phone breakpoint the stylesheet
    (``book/_static/pfrepro.css``) shows each row as a stacked card of "column: value" lines
    instead of columns too narrow to read; numbers in plain cells are wrapped by
    :func:`nowrap_numbers` (cells that already hold HTML tags are left as they are), and every
    cell may wrap inside a long token only after ``_``, ``=`` or ``/`` (``breakable_text``:
    claim ids such as "t2_x_PF(500)", readings such as "pf_resampling=multinomial"), never
    inside a word or a number.
    """
    cols = [str(c) for c in table.columns]
    head = "".join(f'<th scope="col">{html.escape(c)}</th>' for c in cols)
    rows = []
    for rec in table.itertuples(index=False):
        cells = []
        for c, v in zip(cols, rec):
            v = str(v)
            body = breakable_text(v if "<" in v else nowrap_numbers(v))
            cells.append(f'<td data-label="{html.escape(c)}" class="pf-col-{re.sub(r"[^a-z0-9]+", "-", c.lower())}">{body}</td>')
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return (f'<table class="{html.escape(classes)}"><thead><tr>{head}</tr></thead>'
            f'<tbody>{"".join(rows)}</tbody></table>')


# ---- the chapters' text tables: formulas as a reader reads them, rows as cards on a phone ------------

#: Unicode subscripts for the characters of a plain-text index ("z_k" -> "zₖ", "r_l" -> "rₗ")
_SUBSCRIPT = dict(zip("0123456789+-=()aehijklmnoprstuvxβγρφχ", "₀₁₂₃₄₅₆₇₈₉₊₋₌₍₎ₐₑₕᵢⱼₖₗₘₙₒₚᵣₛₜᵤᵥₓᵦᵧᵨᵩᵪ"))
#: Unicode superscripts for the characters of a plain-text exponent ("x^i" -> "xⁱ")
_SUPERSCRIPT = str.maketrans("0123456789i+-nT", "⁰¹²³⁴⁵⁶⁷⁸⁹ⁱ⁺⁻ⁿᵀ")
#: the index characters :func:`reader_text` writes as subscripts (Latin letters and digits only)
_READER_INDEX = "0123456789k+-=()aeioruvxnmpsthlj"
#: a symbol with a plain-text index for :func:`plain_math`: one letter (Latin or Greek, with an optional
#: accent) and "_" + a short index or a braced one ("z_k", "x̂_{k-1}", "z_1:k-1", "α_0")
_INDEXED = re.compile(r"(?<![\w.])([A-Za-zα-ωϕ][\u0302\u0303]?)_(\{[^{}]{1,12}\}|[0-9a-z][0-9a-z+\-]{0,2}(?::[0-9a-z+\-]{1,5})?)(?![\w(])")
#: a snake_case identifier left in the text once the symbols are written (a function, choice or reading name)
_SNAKE = re.compile(r"(?<![\w./:@-])[a-z][a-z0-9]*(?:_[a-z0-9]+)+(?![\w/@]|\.\w)")


def reader_text(text: str) -> str:
    """Plain-text formulas and names as a reader reads them: ``x_k`` -> ``xₖ``, ``x_{k-1}`` ->
    ``xₖ₋₁``, ``x_(k-1)`` -> ``xₖ₋₁``, ``y_1:k`` -> ``y₁:ₖ``, ``x_k^i`` -> ``xₖⁱ``, ``sigma_w2`` ->
    ``sigma w2`` (a name with underscores reads as words). Only for display: the claims and
    choices keep their text. (:func:`plain_math` writes the same subscripts but leaves names for
    :func:`cell_html` to set as code.)"""
    def sub(m):
        body = m.group(2) or m.group(3) or m.group(4)
        if all(ch in _READER_INDEX + ":|" for ch in body):
            return m.group(1).replace("~", "\u0303") + "".join(_SUBSCRIPT.get(ch, ch) for ch in body)
        return m.group(0)

    # one-letter symbols with a subscript: x_k, x_{k-1}, x_(k-1), y_1:k, B_k
    out = re.sub(r"(?<![A-Za-z0-9_])([A-Za-zσηαβθ](?:\u0302|~)?)_(?:\{([^{}]+)\}|\(([^()]+)\)|([0-9k]+(?::[0-9k]+)?|th))(?![A-Za-z_])", sub, text)
    out = re.sub(r"\^(\{[^{}]+\}|[0-9iTn])", lambda m: m.group(1).strip("{}").translate(_SUPERSCRIPT)
                 if all(c in "0123456789i+-nT" for c in m.group(1).strip("{}")) else m.group(0), out)
    # remaining snake_case names read as words
    return re.sub(r"\b([A-Za-z][A-Za-z0-9]*(?:_[A-Za-z0-9]+)+)\b", lambda m: m.group(1).replace("_", " "), out)


def plain_math(text: str) -> str:
    """Text with plain-text indices written as Unicode subscripts ("p(z_k | θ, x̂_{k-1})" ->
    "p(zₖ | θ, x̂ₖ₋₁)", "[r_l, r_u]" -> "[rₗ, rᵤ]"): the tables' formulas read as formulas, not as
    code names. An index with a character Unicode has no subscript for is left as it is."""
    def sub(m):
        idx = m.group(2).strip("{}")
        if all(ch in _SUBSCRIPT or ch == ":" for ch in idx):
            return m.group(1) + "".join(_SUBSCRIPT.get(ch, ch) for ch in idx)
        return m.group(0)

    return _INDEXED.sub(sub, str(text))


def cell_html(text, code_names: bool = True) -> str:
    """One table cell as HTML: :func:`plain_math`, escaped, and the code names left (``run_all``,
    ``n_th``) set as code, the way the prose shows them."""
    # a quoted word ("'small': 100 ft") in typographic quotes: it reads as a quotation, not as Python
    text = re.sub(r"'([^'\n]{1,40})'", "\u2018\\1\u2019", plain_math(text))
    body = html.escape(text)
    return _SNAKE.sub(lambda m: f"<code>{m.group(0)}</code>", body) if code_names else body


def card_table(df, css_class: str, text: bool = True):
    """``df`` as an HTML table (:func:`labelled_table_html`) whose cells carry their column name, so
    that on a phone the book's stylesheet (``book/_static/pfrepro-pages.css``, class ``pf-cards``) shows
    each row as a card of "column: value" lines instead of columns one word wide; every cell through
    :func:`cell_html`, a missing value as "—". ``css_class``: the page's own class for the table (its
    column widths); ``text``: left-align every cell (a table of words). Returns an
    ``IPython.display.HTML``."""
    import math

    import pandas as pd
    from IPython.display import HTML

    if not isinstance(df, pd.DataFrame):
        raise TypeError(f"card_table needs a DataFrame, got {type(df).__name__}")
    cells = df.astype(object).map(lambda v: "—" if v is None or (isinstance(v, float) and math.isnan(v)) else cell_html(v))
    return HTML(labelled_table_html(cells, classes=f"{'pf-text ' if text else ''}pf-cards {css_class}"))


def choices_display(choices, css_class: str, reg=None, plan_label=None, collapsed: bool = True):
    """The free-choices table as the chapter shows it (:func:`pfrepro.choices.choices_table`): choice names
    in words ("liu_west" -> "liu west"), a power-plan row ``plan_<claim id>`` named by its claim and
    linked to the claim's row of the claims table when ``reg`` (the registry) has that claim; other
    ``plan_*`` rows through ``plan_label(name)`` when given; cells as in :func:`card_table` (``css_class``:
    the page's class for the table; the rows are cards on a phone). ``collapsed``: inside a
    ``<details>`` element, closed, whose summary counts the rows (a long table is opened, not scrolled past)."""
    from IPython.display import HTML

    from .choices import choices_table

    t = choices_table(choices)
    by = {c.claim_id: c for c in reg.claims} if reg is not None else {}

    def name(n):
        if n.startswith("plan_") and n[5:] in by:
            c = by[n[5:]]
            return (f'<a href="#{claim_anchor(reg.paper, c.claim_id)}">runs for: {html.escape(c.text)}</a>')
        if n.startswith("plan_") and plan_label is not None:
            return html.escape(plan_label(n))
        return html.escape(n.replace("_", " "))

    cells = t.astype(object).map(cell_html)
    cells["choice"] = [name(n) for n in t["choice"]]
    table = labelled_table_html(cells.rename(columns={"paper": "in the paper"}), classes=f"pf-text pf-cards {css_class}")
    if not collapsed:
        return HTML(table)
    n = len(t)
    return HTML(f'<details class="pf-choices"><summary>The {n} free choices, each with its value, status, reason '
                f"and the paper's line (open the table)</summary>{table}</details>")


def choices_cards(choices):
    """The chapter's assumptions table (:func:`pfrepro.choices.choices_table`) as HTML whose rows
    become cards on a phone (:func:`labelled_table_html`, class ``pf-choices``: on a laptop a table
    with a wide "reason" column, on a phone one card per choice) instead of a five-column table
    wrapping one word per line; every cell through :func:`reader_text`. Returns an
    ``IPython.display.HTML``."""
    from IPython.display import HTML

    from .choices import choices_table

    t = choices_table(choices)
    return HTML(labelled_table_html(t.map(lambda v: html.escape(reader_text(str(v)))),
                                    classes="pf-claims pf-text pf-choices"))


def cpu_model() -> str:
    """CPU model name (``/proc/cpuinfo`` on Linux, else ``platform.processor()``)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def _git(root: Path, *args: str) -> str | None:
    try:
        out = subprocess.run(["git", *args], cwd=root, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 and out.stdout.strip() else None


DEFAULT_PACKAGES = ("pfrepro", "numpy", "scipy", "pandas", "matplotlib", "filterpy", "jupyter-book",
                    "sphinx", "myst-nb")


def build_info(packages=DEFAULT_PACKAGES, root: Path | None = None) -> dict[str, str]:
    """What built this book: versions, commit, date (UTC), CPU, Python, OS."""
    try:
        root = book_root(root)
    except FileNotFoundError:
        root = Path.cwd()
    info: dict[str, str] = {}
    commit = _git(root, "rev-parse", "HEAD")
    if commit:
        dirty = _git(root, "status", "--porcelain", "--untracked-files=no")
        info["git commit"] = commit + (" (with uncommitted changes)" if dirty else "")
    else:
        info["git commit"] = "not available (not built from a git checkout)"
    info["build date (UTC)"] = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M")
    info["CPU"] = f"{cpu_model()}, {os.cpu_count()} logical cores"
    info["Python"] = platform.python_version()
    info["OS"] = platform.platform(terse=True)
    for pkg in packages:
        try:
            info[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            if pkg == "pfrepro":  # run from the source tree (PYTHONPATH=src), not installed
                from . import __version__
                info[pkg] = f"{__version__} (source tree)"
            else:
                info[pkg] = "not installed"
    return info
