"""The scorecard page and the Li (2012) / Ning (2011) chapters as a reader sees them: generated
sentences follow their numbers, figures are drawn for both widths, tables stay narrow."""
from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest

from pfrepro.figures import scorecard as SC

BOOK = Path(__file__).resolve().parents[1] / "book"


# ---- the scorecard's status sentence ---------------------------------------------------------
def test_status_sentence_follows_its_counts():
    assert SC.status_sentence(166, 5, 5, 15) == "166 claims from all 5 papers, and 15 claims of the synthesis chapter"
    assert SC.status_sentence(166, 4, 5, 15) == "166 claims from 4 of the 5 papers, and 15 claims of the synthesis chapter"
    assert SC.status_sentence(1, 1, 5, 0) == "1 claim from 1 of the 5 papers"
    assert SC.status_sentence(3, 1, 1, 1) == "3 claims from the book's one paper, and 1 claim of the synthesis chapter"
    assert SC.status_sentence(0, 0, 5, 0).startswith("no chapter has saved any claims")
    assert SC.status_sentence(0, 0, 5, 2) == "0 claims from 0 of the 5 papers, and 2 claims of the synthesis chapter"


@pytest.mark.parametrize("args", [(-1, 1, 5, 0), (1, 6, 5, 0), (1.5, 1, 5, 0), (1, 1, 5, None)])
def test_status_sentence_refuses_bad_counts(args):
    with pytest.raises(ValueError, match="status_sentence"):
        SC.status_sentence(*args)


# ---- paper labels in words, not keys ----------------------------------------------------------
def test_paper_labels_are_words():
    assert SC.paper_label("ekf_pf_li2012") == "Li et al. (2012)"
    assert SC.paper_label("dpf_hou2008") == "Hou and Yin (2008)"
    assert SC.paper_label("synthesis") == "Synthesis (this report)"
    assert SC.paper_label("all claims") == "all claims"


def _claims(rows):
    return pd.DataFrame(rows, columns=["paper", "verdict", "cause"])


def test_verdict_counts_and_causes():
    claims = pd.DataFrame({"paper": ["ekf_pf_li2012"] * 3 + ["dpf_hou2008"],
                           "verdict": ["reproduced", "inconclusive", "reproduced", "not reproduced"]})
    c = SC.verdict_counts(claims, ["ekf_pf_li2012", "dpf_hou2008"])
    assert list(c.index) == ["ekf_pf_li2012", "dpf_hou2008", "all claims"]
    assert c.loc["ekf_pf_li2012", "reproduced"] == 2 and c.loc["all claims", "total"] == 4
    assert SC.verdict_counts(claims.iloc[:0], []).loc["all claims", "total"] == 0


def test_verdict_bars_fit_both_widths():
    from pfrepro.plotting import responsive

    claims = pd.DataFrame({"paper": ["ekf_pf_li2012"] * 30 + ["dpf_hou2008"] * 12 + ["synthesis"] * 3,
                           "verdict": (["reproduced"] * 10 + ["inconclusive"] * 20 + ["not reproduced"] * 12
                                       + ["qualitatively reproduced"] * 3)})
    r = responsive(SC.verdict_bars, SC.verdict_counts(claims, ["ekf_pf_li2012", "dpf_hou2008", "synthesis"]),
                   alt="bars")
    assert r.desktop_min_pt >= 10.5 and r.phone_min_pt >= 12


# ---- the scorecard page -------------------------------------------------------------------------
def test_scorecard_defines_every_verdict_word_under_its_label():
    from pfrepro.claims import VERDICTS

    text = (BOOK / "99_scorecard.md").read_text()
    assert "(verdict-scale)=" in text
    scale = text.split("(verdict-scale)=", 1)[1].split("\n## ", 2)[1]
    for word in VERDICTS:
        assert re.search(rf"^{re.escape(word)}\n: ", scale, re.M), f"{word} is not defined"
    for cause in ("depends on the reading", "too few runs", "tie within the stated margin"):
        assert f"*{cause}*" in scale


def test_scorecard_puts_build_internals_last():
    text = (BOOK / "99_scorecard.md").read_text()
    top = text[:text.index("## How this page was built")]
    prose = re.sub(r"```\{code-cell\}.*?```", "", top, flags=re.S)
    for internal in ("Sphinx", "_claims", "load_all_claims", "99_scorecard", "plt.subplots"):
        assert internal not in prose, internal
    assert "plt.subplots" not in text
