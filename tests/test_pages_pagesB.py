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


# ---- Li et al. (2012): generated sentences ------------------------------------------------------
def _sens(ekf_m1, pf_m1, ekf_m2, pf_m2):
    from pfrepro.experiments import ekf_pf_li2012 as E

    rows = []
    settings = [("P0", 0.1), ("P0", 2.0), ("resampling", "systematic"), ("EKF linearisation", E.FILTER_LABELS["EKF-prev"])]
    for w, ve, vp in ((1, ekf_m1, pf_m1), (2, ekf_m2, pf_m2)):
        for (st, val), a, b in zip(settings, ve, vp):
            rows.append({"model": E.MODEL_LABELS[w], "setting": st, "value": val, "verdict_EKF": a, "verdict_PF": b})
    return pd.DataFrame(rows)


def test_li_sensitivity_cells_sentence_follows_the_verdicts():
    from pfrepro.verdicts import ekf_pf_li2012 as V

    N, R = "not reproduced", "reproduced"
    s = V.sensitivity_cells_sentence(_sens([N, N, N, R], [N] * 4, [N] * 4, [N] * 4))
    assert s == ("on model 1 the EKF cell is not reproduced under every setting but the circulating code's "
                 "linearisation point (reproduced there) and the PF cell not reproduced under every setting; "
                 "on model 2 both cells are not reproduced under every setting")
    s = V.sensitivity_cells_sentence(_sens([R] * 4, [R, N, R, R], [N] * 4, [R] * 4))
    assert s.startswith("on model 1 the EKF cell is reproduced under every setting and the PF cell reproduced "
                        "under every setting but P0 = 2 (not reproduced there)")
    assert s.endswith("on model 2 the EKF cell is not reproduced under every setting and the PF cell reproduced "
                      "under every setting")
    with pytest.raises(ValueError):
        V.sensitivity_cells_sentence(_sens([N] * 4, [N] * 4, [N] * 4, [N] * 4).iloc[:0])


def test_li_sensitivity_change_sentence():
    from pfrepro.verdicts import ekf_pf_li2012 as V

    assert V.sensitivity_change_sentence(0, 18).startswith("In none of the 18 prior and resampling settings does")
    assert V.sensitivity_change_sentence(3, 18).startswith("In 3 of the 18 prior and resampling settings at least one")
    assert V.sensitivity_change_sentence(18, 18).startswith("In every one of the 18")
    with pytest.raises(ValueError):
        V.sensitivity_change_sentence(19, 18)


def test_li_sis_never_phrase_and_ordinal():
    from pfrepro.verdicts import ekf_pf_li2012 as V

    assert V.sis_never_phrase(0, 0, 100) == "it does so in every run of both models"
    assert V.sis_never_phrase(0, 4, 100) == "it never does in 0 of the 100 runs of model 1 and 4 of model 2"
    with pytest.raises(ValueError):
        V.sis_never_phrase(101, 0, 100)
    assert [V._ordinal(n) for n in (1, 2, 3, 4, 11, 12, 13, 21, 22)] == [
        "largest", "2nd largest", "3rd largest", "4th largest", "11th largest", "12th largest", "13th largest",
        "21st largest", "22nd largest"]


def test_li_cells_in_words():
    from pfrepro.verdicts import ekf_pf_li2012 as V

    assert V.cells_in_words([]) == "none"
    assert V.cells_in_words(["table1-pf-model2"]) == "the model 2 PF cell"
    assert V.cells_in_words(["table1-ekf-model1", "table1-pf-model2"]) == "the model 1 EKF and model 2 PF cells"
    with pytest.raises(ValueError):
        V.cells_in_words(["ratio-7x"])


def test_li_table1_shows_eight_columns_at_the_texts_rounding():
    from pfrepro.figures import ekf_pf_li2012 as F

    t1 = pd.DataFrame({"model": ["Model 1", "Model 2"], "filter": ["EKF", "PF"], "published": [30.1709, 1.0479],
                       "ours": [19.6577, 1.3214], "se": [0.9541, 0.0277], "z": [-11.01, 9.65],
                       "verdict": ["not reproduced"] * 2, "exact": [4.609, 1.316], "exact_se": [0.077, 0.028],
                       "published_minus_exact_in_se": [332.5, -9.63]})
    shown = F.table1_shown(t1).data
    assert shown.shape[1] <= 8
    assert list(shown["ours (± se)"]) == ["19.66 ± 0.95", "1.321 ± 0.028"]
    assert list(shown["published"]) == ["30.1709", "1.0479"]


@pytest.mark.parametrize("chapter", ["30_ekf_pf.md", "40_cmspf.md"])
def test_chapter_figures_go_through_show_figure(chapter):
    text = (BOOK / chapter).read_text()
    assert "plt.show()" not in text and "plt.subplots" not in text
    assert "image:\n    alt:" not in text          # the alt text moved to the call
    assert text.count("show_figure(") >= text.count("  figure:\n    caption:")


def test_li_optimum_prose_follows_the_sign():
    from pfrepro.verdicts import ekf_pf_li2012 as V

    p = V.optimum_prose(-8.63, -9.63, -6.75)
    assert p["li_pub_optimum_head"] == "The published PF values are below the optimum."
    assert p["li_pub_optimum_sentence"].startswith(
        "The published PF values lie 8.6 standard errors below them (model 1) and 9.6 standard errors below "
        "(model 2), and on model 2 the published EKF value too (6.8 se below).")
    assert "no filter can do that much better" in p["li_pub_optimum_sentence"]
    p = V.optimum_prose(1.2, 3.0, 4.0)          # the printed values above the optimum: no bound claimed
    assert p["li_pub_optimum_head"] == "The published PF values are not below the optimum."
    assert "3.0 standard errors above" in p["li_pub_optimum_sentence"]
    assert "lies 4.0 se above it" in p["li_pub_optimum_sentence"]
    assert "no filter" not in p["li_pub_optimum_sentence"]
    assert V.optimum_prose(-3.0, 0.5, 0.0)["li_pub_optimum_head"].startswith("A published PF value")
    with pytest.raises(ValueError):
        V.optimum_prose(float("nan"), 0.0, 0.0)


def test_ning_reading_words():
    from pfrepro.verdicts.cmspf_ning2011 import reading_words

    assert reading_words("sigma_v_t3=R 100, sigma_w2=1") == "σ_v² = 100, σ_w² = 1"
    assert reading_words("eta=0.2") == "η = 0.2"
    assert reading_words("N_t23=100") == "N = 100"
    assert reading_words("the main reading") == "the main reading"


def test_reader_text_turns_plain_subscripts_into_symbols():
    from pfrepro.bookinfo import reader_text

    assert reader_text("x_k = x_{k-1}/2 + w_k") == "xₖ = xₖ₋₁/2 + wₖ"
    assert reader_text("Var(x_k | y_1:k)/N") == "Var(xₖ | y₁:ₖ)/N"
    assert reader_text("the resampled x~_k^i") == "the resampled x̃ₖⁱ"
    assert reader_text("plan_ratio_m1") == "plan ratio m1"
    assert reader_text("10 % of N, l.133") == "10 % of N, l.133"


def test_ning_beyond_sentence_counts_not_ids():
    from pfrepro.verdicts.cmspf_ning2011 import beyond_sentence

    s = beyond_sentence(["reproduced"] * 10 + ["not reproduced"] * 4 + ["inconclusive"] * 2)
    assert s == ("Of the 16 claims beyond the single table entries, 10 are reproduced, 0 are qualitatively "
                 "reproduced, 4 are not reproduced and 2 are inconclusive.")
    assert beyond_sentence(["inconclusive"]).startswith("Of the one claim beyond the single table entries, 0 are")
    assert beyond_sentence([]) == "No claim goes beyond the single table entries."
