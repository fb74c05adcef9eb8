"""No internal words in the book's MyST sources, caught before a build.

The browser check (``tests/browser/check_pages.py``, kind ``internal``) scans the built pages;
this fast test scans the prose of ``book/*.md`` for the defects that are plain in the source:

- issue numbers ("issue 22", "(#22", "#22"),
- the chapters' module aliases (``E.x``, ``S.x``, ``F.x``: ``experiments``, ``stats``, ``figures``),
- the text of a glue call (``glue(`` typed in prose, where ``{glue:text}`` was meant),

in prose only: code cells, fenced code, math, directive option lines, inline code and inline
math are not prose. Code cells whose input the reader sees (no ``remove-input``,
``remove-cell``, ``hide-input`` or ``hide-cell`` tag) must not show glue calls either: gluing a
number is the book's machinery, not something the reader needs to read.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

BOOK = Path(__file__).resolve().parents[1] / "book"
CHAPTERS = sorted(p for p in BOOK.glob("*.md"))

#: (what, pattern) searched in prose
RULES = (
    ("issue number", re.compile(r"\bissues?\s+#?\d+|\(#\d+|(?<![\w&#/])#\d+\b", re.I)),
    ("module alias", re.compile(r"(?<![\w.])[ESF]\.(?!g\.|e\.)[A-Za-z_]\w*")),
    ("glue call", re.compile(r"\bglue\(")),
)
#: directives whose body is not prose (math, code, raw markup) or is a glue key
NON_PROSE = {"code-cell", "code", "code-block", "sourcecode", "math", "eval-rst", "raw", "glue",
             "glue:figure", "glue:any", "glue:math", "literalinclude", "bibliography", "mermaid"}
#: tags under which the reader does not see a code cell's input
HIDDEN_INPUT = {"remove-input", "remove-cell", "hide-input", "hide-cell"}

_FENCE = re.compile(r"^(?P<indent>\s*)(?P<fence>`{3,}|~{3,}|:{3,})\s*(?:\{(?P<name>[^}]+)\})?(?P<rest>.*)$")
_INLINE = re.compile(r"(`+)(?:(?!\1).)+?\1|\$\$.+?\$\$|(?<![\\$])\$(?!\s)[^$\n]+?(?<!\s)\$")


def _strip_inline(line: str) -> str:
    """The line without inline code (``...``, roles' targets) and inline math ($...$)."""
    return _INLINE.sub(" ", line)


def prose_lines(text: str):
    """The prose of a MyST file, and its code cells.

    Yields ``("prose", lineno, line)`` (inline code and math blanked out) and
    ``("cell", lineno, source, tags)`` for every ``{code-cell}``.
    """
    lines = text.splitlines()
    i = 0
    if lines and lines[0].strip() == "---":  # YAML front matter
        i = 1
        while i < len(lines) and lines[i].strip() != "---":
            i += 1
        i += 1
    stack: list[tuple[str, str]] = []  # (fence, directive name) of the open fences
    cell: dict | None = None
    in_math = False
    for no in range(i + 1, len(lines) + 1):
        line = lines[no - 1]
        stripped = line.strip()
        m = _FENCE.match(line)
        top = stack[-1] if stack else None
        # a closing fence: the opening's character, at least as many, nothing after it
        if top and m and not m.group("name") and not m.group("rest").strip() \
                and m.group("fence")[0] == top[0][0] and len(m.group("fence")) >= len(top[0]):
            stack.pop()
            if top[1] == "code-cell" and cell is not None:
                yield ("cell", cell["start"], "\n".join(cell["src"]), cell["tags"])
                cell = None
            continue
        if top and top[1] in NON_PROSE:  # inside code, math, raw markup: not prose
            if top[1] == "code-cell" and cell is not None:
                t = re.match(r"^:tags:\s*\[(.*)\]\s*$", stripped)
                if t and not cell["src"]:
                    cell["tags"] = {x.strip().strip("'\"") for x in t.group(1).split(",")}
                elif cell["src"] or not re.match(r"^:[\w-]+:", stripped):
                    cell["src"].append(line)
            continue
        if m and (m.group("name") or m.group("fence")[0] != ":"):
            # ```{name} opens a directive; a bare ``` or ~~~ opens a code block
            name = m.group("name").strip() if m.group("name") else "code"
            stack.append((m.group("fence"), name))
            if name == "code-cell":
                cell = {"start": no, "src": [], "tags": set()}
            elif name not in NON_PROSE:
                yield ("prose", no, _strip_inline(m.group("rest")))  # a directive's title is prose
            continue
        if stripped.startswith("$$"):  # display math: $$ ... $$ on one line or over several
            if not (len(stripped) > 2 and stripped.endswith("$$") and not in_math):
                in_math = not in_math
            continue
        if in_math or stripped.startswith(("%", "<!--")):  # math, MyST or HTML comments
            continue
        if stack and re.match(r"^:[\w-]+:", stripped):  # a directive's option line
            continue
        yield ("prose", no, _strip_inline(line))


def scan(text: str) -> list[tuple[int, str, str]]:
    """Every internal word in the prose of a MyST text: (line, what, 60 characters of context)."""
    hits = []
    for item in prose_lines(text):
        if item[0] == "prose":
            _, no, line = item
            for what, rx in RULES:
                for m in rx.finditer(line):
                    s = max(0, m.start() - 30)
                    hits.append((no, what, line[s:s + 60].strip()))
        else:
            _, no, src, tags = item
            if not tags & HIDDEN_INPUT and re.search(r"(?<![\w.])_?glue\(", src):
                first = next(ln for ln in src.splitlines() if re.search(r"_?glue\(", ln))
                hits.append((no, "glue call in a code cell the reader sees", first.strip()[:60]))
    return hits


@pytest.mark.parametrize("path", CHAPTERS, ids=lambda p: p.name)
def test_no_internal_words_in_prose(path):
    hits = scan(path.read_text(encoding="utf-8"))
    assert not hits, f"{path.name}: internal words in reader prose:\n" + "\n".join(
        f"  line {no}: {what}: {ctx!r}" for no, what, ctx in hits)


# ---- the scanner itself -------------------------------------------------------------------------
SAMPLE = '''---
jupytext:
  text_representation: {extension: .md}
---

# A chapter (issue 7 in the title is caught)

The cap was found (issue 22; see there), fixed in #31, and E.SCENARIO decides; {glue:text}`ok`.
A glue("ratio", r) typed in prose is caught; `E.paired` in inline code and $E.x$ in math are not.

```{code-cell} ipython3
:tags: [remove-cell]
glue("hidden", 1)   # issue 22: E.SCENARIO in code is fine
```

```{code-cell} ipython3
F.fig1(R)
glue("shown", 2)
```

```{note}
:class: dropdown
A note's body is prose: S.table here.
```

```{math}
:label: eq-issue-5
E.x = issue 5
```

$$
F.T \\quad \\#3
$$

```python
E.paired(x)   # a code block
```
'''


def test_scanner_finds_what_the_reader_would_see():
    hits = scan(SAMPLE)
    got = [(no, what) for no, what, _ in hits]
    assert got == [(6, "issue number"), (8, "issue number"), (8, "issue number"), (8, "module alias"),
                   (9, "glue call"), (16, "glue call in a code cell the reader sees"), (23, "module alias")], hits
    # the context is shown with the hit
    assert "found (issue 22" in hits[1][2]


def test_scanner_is_quiet_on_clean_prose():
    clean = ("# Title\n\nThe EKF of Wan (E. Wan, F. Gustafsson), e.g. eq (5) and Fig. 3, with "
             "{glue:text}`runs` runs, `S.table` in code and $F.x$ in math.\n\nNone of them is internal.\n")
    assert scan(clean) == []
