"""pfrepro.findings: the findings block each chapter opens with, and the introduction's summary."""
import pytest

from pfrepro import findings
from conftest import three_claims_registry
from pfrepro.claims import ClaimsRegistry


def _reg():
    return three_claims_registry()


def test_findings_html_lists_main_claims_with_links_counts_and_takeaway():
    out = findings.findings_html(_reg(), ("ratio", "cell"), "Use the PF <here>.")
    # main claims in the order given, each verdict word linked to the rule, each row linked
    assert out.index("more than 7 times") < out.index("EKF RMSE on model 1")
    assert out.count(f'href="{findings.RULE_HREF}"') == 3          # two verdict words and the counts' link
    assert 'href="#claim-ekf_pf_li2012-ratio"' in out and 'href="#claim-ekf_pf_li2012-cell"' in out
    assert "<strong>not reproduced</strong>" in out and "<strong>reproduced</strong>" in out
    assert "ours 13.00 ± 0.50 against the paper's 13.2" in out
    # counts of every claim, not only the main ones; the takeaway is escaped
    assert "Of 3 claims, 1 is reproduced" in out and "1 is inconclusive" in out
    assert "Use the PF &lt;here&gt;." in out


def test_findings_html_refuses_an_unknown_main_claim():
    with pytest.raises(KeyError, match="nope"):
        findings.findings_html(_reg(), ("cell", "nope"), "x")


def test_saved_findings_feed_the_introduction(tmp_path):
    claims = tmp_path / "claims"
    findings.save_findings(_reg(), ("ratio",), "Take the PF.", claims)
    book = tmp_path / "book"
    book.mkdir()
    (tmp_path / "_toc.yml").write_text("format: jb-book\nroot: book/index\nchapters:\n"
                                       "  - file: book/30_li\n  - file: book/70_syn\n")
    (book / "index.md").write_text("# intro\n")
    (book / "30_li.md").write_text('R, reg = get_paper("ekf_pf_li2012").run()\n')
    (book / "70_syn.md").write_text('reg = ClaimsRegistry("synthesis")\n')
    saved = findings.load_findings(claims)
    assert saved["ekf_pf_li2012"]["counts"] == {"reproduced": 1, "not reproduced": 1, "inconclusive": 1}
    assert saved["ekf_pf_li2012"]["main"][0]["verdict"] == "not reproduced"
    out = findings.book_findings_html(claims, root=book)
    assert 'href="30_li.html"' in out and "Take the PF." in out and "Of 3 claims" in out
    assert "Across the papers" not in out                     # the synthesis saved nothing yet
    syn = ClaimsRegistry("synthesis")
    syn.add("s", "a statement", qualitative=True)
    findings.save_findings(syn, ("s",), "Use method M.", claims)
    out = findings.book_findings_html(claims, root=book)
    assert "Across the papers" in out and 'href="70_syn.html"' in out and "Use method M." in out


def test_intro_coverage_words():
    all_five = {k: "book/x" for k in ("gpff_zhang2016", "dpf_hou2008", "ekf_pf_li2012", "cmspf_ning2011",
                                      "immpfor_zhou2017")}
    out = findings.intro_coverage(all_five)
    assert out["intro_papers"] == "the five particle-filtering papers"
    assert out["intro_years"] == "between 2008 and 2017"
    assert out["intro_missing"].startswith("Every paper")
    out = findings.intro_coverage({"gpff_zhang2016": "book/x"})
    assert out["intro_papers"] == "one of five particle-filtering papers" and out["intro_years"] == "in 2016"
    assert out["intro_missing"].startswith("Four of the five papers are not covered")
