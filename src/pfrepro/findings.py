"""What a chapter found, said first: the findings block at the top of every paper chapter and
the book's summary in the introduction, generated from the claims (never typed).

A chapter calls :func:`chapter_findings` right after :meth:`pfrepro.papers.Paper.run`. It glues
an HTML block -- one line per main claim (its text, the verdict word linked to its definition
on the scorecard's verdict scale,
ours against the printed number, a link to the claim's row in the chapter's claims table), the
count of every verdict, and the one thing a practitioner should take away -- and saves the same
summary to ``<claims dir>/findings/<paper>.json``. The introduction is read after the chapters
(``book/index.md``) and gathers those files with :func:`book_findings_html`.
"""
from __future__ import annotations

import html
import json
from pathlib import Path

from .claims import VERDICT_HREF, VERDICTS, Claim, ClaimsRegistry, _pm, cause_text, claims_dir, verdict_html
from .prose import verdict_sentence

__all__ = ["findings_html", "chapter_findings", "cause_sentence", "save_findings", "load_findings", "book_findings_html",
           "intro_coverage", "RULE_HREF", "verdict_link"]

#: Where the verdict words are defined (the scorecard's verdict scale), the same target as the
#: claims tables' verdict links, :data:`pfrepro.claims.VERDICT_HREF`.
RULE_HREF = VERDICT_HREF


def verdict_link(verdict: str) -> str:
    """The verdict word as a link to its definition, styled like the claims tables' verdicts."""
    if verdict not in VERDICTS:
        raise ValueError(f"verdict_link: verdict must be one of {VERDICTS}, got {verdict!r}")
    return verdict_html(verdict, cls="pf-verdict").replace(f">{html.escape(verdict)}</a>",
                                                           f"><strong>{html.escape(verdict)}</strong></a>")


def _claim_line(paper: str, c: Claim) -> str:
    from .bookinfo import claim_anchor

    parts = [f"{html.escape(c.text)}: {verdict_link(c.verdict)}"]
    why = cause_text(c, as_html=True)   # reading names as code, the rest escaped
    if why:
        parts.append(f" ({why})")
    if c.published_text or c.published is not None:
        printed = c.published_text or _pm(c.published, c.published_se)
        if c.reproduced is not None:
            parts.append(f" (ours {html.escape(_pm(c.reproduced, c.se))} against the paper's "
                         f"{html.escape(str(printed))})")
    return (f'<li>{"".join(parts)} <a class="pf-claim-link" href="#{claim_anchor(paper, c.claim_id)}">'
            "see the claim</a></li>")


def findings_html(reg: ClaimsRegistry, main_claims, takeaway: str) -> str:
    """The findings block of a chapter: the main claims with their verdicts, the counts, the takeaway.

    ``main_claims``: claim ids of ``reg``, in the order to show (``KeyError`` for an id ``reg``
    does not have); ``takeaway``: one sentence (HTML-escaped here).
    """
    by_id = {c.claim_id: c for c in reg.claims}
    missing = [i for i in main_claims if i not in by_id]
    if missing:
        raise KeyError(f"main claims not recorded by {reg.paper}: {missing}")
    items = "".join(_claim_line(reg.paper, by_id[i]) for i in main_claims)
    counts = verdict_sentence([c.verdict for c in reg.claims], noun="claim")
    causes = cause_sentence(reg.claims)
    if causes:
        counts += f"; {causes}"
    return ('<div class="pf-findings">'
            f'<ul class="pf-findings-main">{items}</ul>'
            f'<p class="pf-findings-counts">{html.escape(counts)} '
            f'(<a href="{RULE_HREF}">what the verdicts mean</a>).</p>'
            f'<p class="pf-findings-takeaway"><strong>For a practitioner:</strong> {html.escape(takeaway)}</p>'
            "</div>")


def cause_sentence(claims) -> str:
    """The inconclusive claims by cause in words, e.g. "of the 5 inconclusive, 3 depend on the reading
    and 2 need more runs" (``""`` when none is inconclusive)."""
    from .claims import CAUSE_COUNT, CAUSE_READING, CAUSE_RUNS, CAUSE_TIE
    from .prose import join_and, plural

    causes = [c.cause for c in claims if c.verdict == "inconclusive"]
    if not causes:
        return ""
    words = {CAUSE_READING: ("depends on the reading", "depend on the reading"),
             CAUSE_RUNS: ("needs more runs", "need more runs"),
             CAUSE_TIE: ("is a tie within its stated margin", "are ties within their stated margins"),
             CAUSE_COUNT: ("is not decided by the cost count", "are not decided by the cost count")}
    parts = []
    for cause, (one, many) in words.items():
        n = causes.count(cause)
        if n:
            parts.append(f"{n} {one if n == 1 else many}")
    return f"of the {plural(len(causes), 'inconclusive claim')}, {join_and(parts)}" if len(causes) > 1 else (
        f"the inconclusive claim {parts[0].split(' ', 1)[1]}")


def save_findings(reg: ClaimsRegistry, main_claims, takeaway: str, directory: Path | None = None) -> Path:
    """Write the chapter's findings for the introduction (``<directory>/findings/<paper>.json``)."""
    d = Path(directory) if directory is not None else claims_dir()
    (d / "findings").mkdir(parents=True, exist_ok=True)
    path = d / "findings" / f"{reg.paper}.json"
    verdicts = [c.verdict for c in reg.claims]
    by_id = {c.claim_id: c for c in reg.claims}
    path.write_text(json.dumps({"paper": reg.paper, "counts": {v: verdicts.count(v) for v in dict.fromkeys(verdicts)},
                                "causes": cause_sentence(reg.claims),
                                "main": [{"claim_id": i, "text": by_id[i].text, "verdict": by_id[i].verdict,
                                          "cause": cause_text(by_id[i])}
                                         for i in main_claims],
                                "takeaway": takeaway}, indent=1), encoding="utf-8")
    return path


def chapter_findings(name: str, reg: ClaimsRegistry, verdicts_module, results) -> str:
    """Glue a chapter's findings block under ``name`` (``{glue:}`name```) and save it for the
    introduction; ``verdicts_module`` is the paper's :mod:`pfrepro.verdicts` module (its
    ``MAIN_CLAIMS`` and ``takeaway(reg, results)``). Returns the HTML."""
    from IPython.display import HTML
    from myst_nb import glue

    takeaway = verdicts_module.takeaway(reg, results)
    out = findings_html(reg, verdicts_module.MAIN_CLAIMS, takeaway)
    glue(name, HTML(out), display=False)
    save_findings(reg, verdicts_module.MAIN_CLAIMS, takeaway)
    return out


def load_findings(directory: Path | None = None) -> dict:
    """Every saved findings summary, ``{paper: summary}`` in file-name order."""
    d = (Path(directory) if directory is not None else claims_dir()) / "findings"
    return {p.stem: json.loads(p.read_text(encoding="utf-8")) for p in sorted(d.glob("*.json"))}


def book_findings_html(directory: Path | None = None, root: Path | None = None) -> str:
    """The introduction's opening: one line per paper chapter of this build (the counts of its
    verdicts, its takeaway, a link to the chapter), then the synthesis's answer.

    ``directory``: the claims directory (default :func:`pfrepro.claims.claims_dir`); ``root``: where
    to look for ``_toc.yml`` (default: upwards from the working directory).
    """
    from .bookinfo import papers_in_book
    from .published import PAPERS, REPORT_KEYS

    found = load_findings(directory)
    chapters = papers_in_book(root, report=True)   # {key: chapter docname}, book order
    rows = []
    for key, chapter in chapters.items():
        if key in REPORT_KEYS:
            continue
        f = found.get(key)
        href = Path(chapter).stem + ".html"
        title = html.escape(PAPERS.get(key, key))
        if f is None:
            rows.append(f'<li><a href="{href}">{title}</a>: no findings were saved in this build.</li>')
            continue
        counts = verdict_sentence(f["counts"], noun="claim")
        if f.get("causes"):
            counts += f"; {f['causes']}"
        rows.append(f'<li><a href="{href}">{title}</a>. {html.escape(counts)}. '
                    f'{html.escape(f["takeaway"])}</li>')
    out = f'<ul class="pf-findings-book">{"".join(rows)}</ul>'
    for key in REPORT_KEYS:
        f = found.get(key)
        if f is not None and key in chapters:
            out += (f'<p class="pf-findings-takeaway"><strong>Across the papers</strong> '
                    f'(<a href="{Path(chapters[key]).stem}.html">{html.escape(REPORT_KEYS[key].split(":")[0])}</a>): '
                    f'{html.escape(f["takeaway"])}</p>')
    return out


_WORDS = dict(enumerate("zero one two three four five six seven eight nine ten".split()))


def intro_coverage(covered: dict | None = None) -> dict:
    """The introduction's words about what this build covers, from ``_toc.yml`` (no count typed).

    ``covered``: ``{paper key: chapter}`` (default :func:`pfrepro.bookinfo.papers_in_book`).
    Returns ``intro_papers`` ("the five particle-filtering papers" or "three of five ..."),
    ``intro_years`` ("between 2008 and 2017") and ``intro_missing`` (a :class:`pfrepro.prose.Md`
    sentence naming the papers without a chapter, or saying there are none).
    """
    import re

    from .bookinfo import papers_in_book
    from .prose import Md
    from .published import PAPERS

    covered = papers_in_book() if covered is None else covered
    missing = [k for k in PAPERS if k not in covered]
    years = [int(y) for k in covered for y in re.findall(r"\((\d{4})\)", PAPERS[k])]
    n_cov, n_all = len(covered), len(PAPERS)
    word = lambda n: _WORDS.get(n, str(n))  # noqa: E731
    return {
        "intro_papers": (f"the {word(n_all)} particle-filtering papers" if n_cov == n_all else
                         f"{word(n_cov)} of {word(n_all)} particle-filtering papers"),
        "intro_years": (f"between {min(years)} and {max(years)}" if len(set(years)) > 1 else
                        f"in {years[0]}" if years else ""),
        "intro_missing": Md("Every paper of the project has a chapter in this build." if not missing else
                            f"{word(len(missing)).capitalize()} of the {word(n_all)} papers "
                            f"{'is' if len(missing) == 1 else 'are'} not covered in this build: "
                            + "; ".join(f"*{PAPERS[k]}*" for k in missing)
                            + ". They will get chapters of the same form; until then they appear in no table of this book."),
    }
