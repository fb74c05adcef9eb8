"""Verdict words link to their definition: the scorecard's verdict scale (``(verdict-scale)=``).

In the claims tables and cards (``bookinfo.anchored_claims`` of ``claims_table``), in the
findings lists (``findings.findings_html``), and from every page that shows them.
"""
import re
from pathlib import Path

import pytest
import yaml

from pfrepro import bookinfo, findings
from conftest import three_claims_registry
from pfrepro.claims import VERDICT_HREF, VERDICTS, claims_table, verdict_html

ROOT = Path(__file__).resolve().parents[1]


def _reg():
    return three_claims_registry()


@pytest.mark.parametrize("word", VERDICTS)
def test_every_verdict_word_links_to_the_scale(word):
    out = verdict_html(word)
    assert out == (f'<a class="pf-verdict-link pf-verdict-{word.replace(" ", "-")}" href="{VERDICT_HREF}">'
                   f"{word}</a>")
    # the findings' class (no wrap, no underline) on request
    assert verdict_html(word, cls="pf-verdict").startswith('<a class="pf-verdict pf-verdict-')


def test_the_longest_verdict_word_is_linked_and_the_cause_follows_as_text():
    # "qualitatively reproduced" is not "reproduced" with a prefix, nor "not reproduced"
    assert ">qualitatively reproduced</a>" in verdict_html("qualitatively reproduced")
    assert ">not reproduced</a>" in verdict_html("not reproduced")
    out = verdict_html("inconclusive (too few runs: 140 would decide) <b>")
    assert out.startswith('<a class="pf-verdict-link pf-verdict-inconclusive"')
    assert out.endswith("</a> (too few runs: 140 would decide) &lt;b&gt;")
    # a custom escaper for the rest (the tables keep their numbers on one line)
    assert verdict_html("inconclusive (x)", escape=str.upper).endswith("</a> (X)")
    # no verdict word at the start: escaped text, no link
    assert verdict_html("reproducedness <x>") == "reproducedness &lt;x&gt;"
    assert verdict_html("–") == "–"
    with pytest.raises(TypeError, match="text"):
        verdict_html(None)


def test_claims_table_html_links_each_verdict():
    out = bookinfo.anchored_claims(claims_table(_reg()), "ekf_pf_li2012").data
    links = re.findall(r'<td data-label="verdict"[^>]*><a class="pf-verdict-link [^"]+" href="([^"]+)">([^<]+)</a>', out)
    assert [w for _, w in links] == ["reproduced", "not reproduced", "inconclusive"], out
    assert {h for h, _ in links} == {VERDICT_HREF}
    # the ids keep their anchors, the other cells stay escaped text
    assert 'id="claim-ekf_pf_li2012-cell"' in out
    assert "The EKF&#x27;s RMSE" in out or "The EKF's RMSE" in out


def test_the_plain_table_has_no_html():
    # the DataFrame (CLI, CSV) keeps plain verdict text; only the book's HTML links it
    assert list(claims_table(_reg())["verdict"])[:2] == ["reproduced", "not reproduced"]


def test_findings_link_verdicts_to_the_scale():
    out = findings.findings_html(_reg(), ("ratio", "cell"), "Use the PF.")
    assert findings.RULE_HREF == VERDICT_HREF == "99_scorecard.html#verdict-scale"
    assert out.count(f'href="{VERDICT_HREF}"') == 3     # two verdict words and "what the verdicts mean"
    assert f'<a class="pf-verdict pf-verdict-not-reproduced" href="{VERDICT_HREF}"><strong>not reproduced</strong></a>' in out
    with pytest.raises(ValueError, match="verdict"):
        findings.verdict_link("sort of reproduced")


def test_the_relative_link_works_from_every_page_that_shows_verdicts():
    # VERDICT_HREF is relative: every chapter, the introduction and the scorecard are in one folder
    toc = yaml.safe_load((ROOT / "_toc.yml").read_text(encoding="utf-8"))
    files = [toc["root"]] + [c["file"] for c in toc["chapters"]]
    scorecard = next(f for f in files if Path(f).name == Path(VERDICT_HREF.split("#")[0]).stem)
    pages = [f for f in files if "/api/" not in f"/{f}/"]
    assert all(Path(f).parent == Path(scorecard).parent for f in pages), pages


def test_the_scorecard_defines_the_verdict_scale():
    text = (ROOT / "book" / "99_scorecard.md").read_text(encoding="utf-8")
    label = VERDICT_HREF.split("#")[1]
    assert re.search(rf"^\({re.escape(label)}\)=\s*$", text, re.M), f"no ({label})= label in the scorecard"
    section = text[text.index(f"({label})="):]
    # each verdict word is explained there
    for word in VERDICTS:
        assert re.search(rf"^{re.escape(word)}\s*$", section, re.M | re.I), word
