"""What a build of the book contains and what built it.

Small helpers for the book's framing pages, so that no statement about the book itself is
typed by hand:

* :func:`papers_in_book` — which papers have a chapter in this build (from ``_toc.yml``);
* :func:`claim_anchor` / :func:`claim_anchor_html` / :func:`claim_href` — one anchor per
  claim in its chapter, ``claim-<paper>-<claim_id>``, and links to it from the scorecard;
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
           "claim_href", "anchored_claims", "labelled_table_html", "nowrap_numbers", "build_info", "cpu_model"]


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
