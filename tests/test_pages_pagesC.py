"""The DPF (``book/50_dpf.md``) and IMM (``book/60_immpf.md``) chapters as a reader sees them.

Figures drawn for the width they are read at (every text at least the layout's size, legends that
fit the phone's width, drawing functions rather than drawn figures), tables of at most eight columns
with formulas as formulas and reading names in words, and the sentences whose words follow a
number, each checked by flipping the number.
"""
from __future__ import annotations

import re

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402

from pfrepro import bookinfo as B  # noqa: E402
from pfrepro.figures import dpf_hou2008 as F  # noqa: E402
from pfrepro.figures import immpfor_zhou2017 as FI  # noqa: E402
from pfrepro.plotting import DESKTOP, PHONE, BOOK_DPI, figure_layout, responsive  # noqa: E402
from pfrepro.verdicts import dpf_hou2008 as V  # noqa: E402
from pfrepro.verdicts import immpfor_zhou2017 as VI  # noqa: E402

#: the phone PNG may be this much wider than the layout's width (bbox padding) before its text shrinks
WIDTH_SLACK = 1.08


def _png_width(png: bytes) -> int:
    return int.from_bytes(png[16:20], "big")   # the IHDR chunk's width


def assert_readable(r):
    """Both drawings of a responsive figure: text at the layout's size, the phone PNG at the phone's width."""
    assert r.desktop_min_pt >= DESKTOP.min_pt - 1e-9, r.desktop_min_pt
    assert r.phone_min_pt >= PHONE.min_pt - 1e-9, r.phone_min_pt
    assert _png_width(r.phone_png) <= PHONE.width_in * BOOK_DPI * WIDTH_SLACK, _png_width(r.phone_png)
    assert _png_width(r.desktop_png) <= DESKTOP.width_in * BOOK_DPI * WIDTH_SLACK, _png_width(r.desktop_png)


# -- figures -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("draw", [F.fig1, F.fig3, lambda: F.fig2(np.linspace(0.2, 0.0, 50))])
def test_dpf_figures_without_runs_are_readable_on_both_widths(draw):
    assert_readable(responsive(draw, alt="x"))


def test_fig3_names_both_filters_and_the_measurement():
    import matplotlib.pyplot as plt

    fig = F.fig3()
    texts = " ".join(t.get_text() for t in fig.axes[0].texts)
    assert "state filter" in texts and "parameter filter" in texts and texts.count("$z_k$") == 2
    plt.close(fig)


def test_legend_columns_follow_the_width():
    from pfrepro.figures import legend_columns

    assert F.legend_columns is legend_columns   # the old name of the DPF module, kept importable
    long = ["exact posterior mean", "IMMPFOR (eq 23)", "Liu–West", "DEKF"]
    with figure_layout(PHONE):
        assert legend_columns(long, 4) == 1
        assert legend_columns(["CV", "CT", "CA"], 3) == 3
    with figure_layout(DESKTOP):
        assert legend_columns(long, 4) >= 2
    with pytest.raises(ValueError):
        legend_columns(long, 0)


def test_no_figure_code_sets_a_font_size_or_calls_subplots():
    """A font size below the layout's, or a figure the layout cannot reflow, would be drawn too small."""
    import inspect

    for mod in (F, FI):
        src = inspect.getsource(mod)
        assert not re.search(r"fontsize\s*=|\"x?-?small\"", src), mod.__name__
        assert "plt.subplots" not in src, mod.__name__


def test_chapter_figures_are_drawing_functions_with_alt_text():
    """The chapters glue drawing functions (``glue_figure`` refuses a drawn figure): every key has one,
    and a text alternative."""
    from types import SimpleNamespace

    R = SimpleNamespace(main=None, fig5=None)
    imm = FI.chapter_figures(R)
    assert set(imm) == set(FI.CHAPTER_FIGURE_ALTS) and all(callable(v) for v in imm.values())
    assert set(F.CHAPTER_FIGURE_ALTS) == {"dpf_fig1", "dpf_fig3", "dpf_fig4", "dpf_fig5", "dpf_sweeps51", "dpf_fig2",
                                          "dpf_fig_exact", "dpf_fig6", "dpf_fig789", "dpf_integration"}
    assert all(len(a) > 40 for a in [*F.CHAPTER_FIGURE_ALTS.values(), *FI.CHAPTER_FIGURE_ALTS.values()])


def test_captions_match_the_drawings():
    """The d-sweep caption names markers, not colours the curves do not have; the integration caption and
    text name the reference the table is computed against; Fig. 5's caption does not say "top"/"bottom"
    (the phone stacks the four panels)."""
    from pathlib import Path

    book = Path(__file__).resolve().parents[1] / "book"
    imm = (book / "60_immpf.md").read_text(encoding="utf-8")
    dpf = (book / "50_dpf.md").read_text(encoding="utf-8")
    assert "Orange" not in imm and "(orange)" not in imm and "green" not in imm.lower()
    assert "64-substep truth" not in dpf and dpf.count("1024") == 2
    fig5_caption = dpf.split(":name: fig-dpf-5")[1].split("```")[0]
    assert "Top" not in fig5_caption and "Bottom" not in fig5_caption


# -- tables --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("text, want", [
    ("p(z_{1:k} | x̃_k, θ)", "p(z₁:ₖ | x̃ₖ, θ)"),
    ("[r_l, r_u]", "[rₗ, rᵤ]"),
    ("E[x_k | θ, z_1:k-1]", "E[xₖ | θ, z₁:ₖ₋₁]"),
    ("α_0 = β_0 = 1", "α₀ = β₀ = 1"),
    ("models_q", "models_q"),           # a name, not a formula: left for cell_html to set as code
])
def test_plain_math(text, want):
    assert B.plain_math(text) == want


def test_cell_html_escapes_and_sets_code_names_as_code():
    assert B.cell_html("a < b, run_all") == "a &lt; b, <code>run_all</code>"
    assert B.cell_html("[r_l, r_u]") == "[rₗ, rᵤ]"


def test_card_table_carries_column_names_and_refuses_other_input():
    html = B.card_table(pd.DataFrame({"where": ["step 3(e)"], "printed": ["r_i"]}), "pf-dpf-errata").data
    assert 'data-label="where"' in html and "pf-dpf-errata" in html and "r_i" not in html
    with pytest.raises(TypeError):
        B.card_table([1, 2], "x")


def test_card_tables_live_in_bookinfo_and_share_one_card_class():
    """The table helpers' home is ``pfrepro.bookinfo`` (the old names in the figure modules are the same
    functions), every card table carries ``pf-cards``, and the stylesheet writes the phone's card rules
    once, for that class, not once per page."""
    from pathlib import Path

    from pfrepro.figures import immpfor_zhou2017

    for name in ("plain_math", "cell_html", "card_table", "choices_display"):
        assert getattr(F, name) is getattr(B, name) and name not in F.__all__ and name in B.__all__
    assert immpfor_zhou2017.card_table is B.card_table
    for html in (B.card_table(pd.DataFrame({"a": ["x"]}), "pf-dpf-cards", text=False).data,
                 B.choices_display(FI.E.CHOICES, "pf-imm-choices", collapsed=False).data):
        assert re.search(r'<table class="[^"]*\bpf-cards\b', html)
    css = (Path(__file__).resolve().parents[1] / "book" / "_static" / "pfrepro-pages.css").read_text(encoding="utf-8")
    assert css.count('content: attr(data-label) ": "') == 1
    assert "table.pf-cards td::before" in css


def test_choices_display_links_power_plans_to_their_claims():
    from pfrepro.experiments import dpf_hou2008 as E

    html = B.choices_display(E.CHOICES, "pf-dpf-choices").data
    text = re.sub(r"<[^>]+>", " ", html)
    assert "liu west" in text and "liu_west" not in text
    # without the registry a plan row keeps its words; no snake_case id outside code elements
    outside_code = re.sub(r"<code>.*?</code>", "", re.sub(r'href="[^"]*"', "", html))
    assert not re.search(r"(?<![\w-])[a-z][a-z0-9]*(?:_[a-z0-9]+){2,}", outside_code.replace("plan_", "plan "))


def test_imm_held_table_has_no_python_repr():
    t = FI.held_table()
    assert not any("{" in str(v) or "':" in str(v) for v in t["value"])
    assert "main 20170501" in t["value"].iloc[0]


def test_imm_plan_label():
    assert FI.plan_label("plan_3") == "power plan 3"
    assert FI.plan_label("plan_readings") == "runs of the readings"


def test_imm_tables_have_at_most_eight_columns_and_readings_in_words():
    from test_verdicts_immpfor_zhou2017 import fixture

    R = fixture(0.3)
    rd = FI.readings_table(R)
    assert rd.shape[1] <= 8
    assert not any("_" in r for r in rd["reading"]), list(rd["reading"])
    assert FI.robustness_table(R).shape[1] <= 8


# -- generated sentences -------------------------------------------------------------------------------
def _st(d, se=1.0):
    return {("order", "x"): (d, se), ("order", "theta"): (d, se)}


def test_not_held_sentence_follows_the_z():
    held = {("main", "m"): _st(5.0), ("T51", 50): _st(4.0)}
    s = V.not_held_sentence_51(held)
    assert "for $x$ it is shown under every counted row" in s and "not shown" not in s
    flipped = {("main", "m"): _st(5.0), ("T51", 50): _st(-3.0), ("cap", "none"): _st(-9.0)}   # no cap: excluded
    s = V.not_held_sentence_51(flipped)
    assert "not shown under horizon T = 50 ($z$ = -3.0)" in s and "no cap" not in s and "none" not in s
    assert "T51" not in s


@pytest.mark.parametrize("choice, value, words", [
    ("cap", "none", "no cap"), ("T51", 50, "horizon T = 50"), ("dekf", "q0=0.01", "DEKF q₀ = 0.01 P_θ0"),
    ("dekf", "unprojected", "DEKF, θ̂ not projected"), ("main", "x", "the main reading")])
def test_reading_label_51(choice, value, words):
    assert V.reading_label_51(choice, value) == words


def test_d_sentence_never_says_d_equals_none():
    s = VI.d_sentence({True: [], False: [1.0, 3.0], None: [0.1]})
    assert "better than the IMMPF at no value of $d$" in s and "worse at $d$ = 1 and 3" in s
    assert "none" not in s
    flipped = VI.d_sentence({True: [0.1, 0.3], False: [], None: []})
    assert "better than the IMMPF at $d$ = 0.1 and 0.3" in flipped and "worse at no value of $d$" in flipped


@pytest.mark.parametrize("tag, words", [
    ("models_q=q x4", "the filters' process noise × 4"), ("n_th=N", "resampling at every step (Nₜₕ = N)"),
    ("d=0.3", "d = 0.3"), ("own d=1", "own parent only, d = 1"), ("some_choice=2", "some choice = 2")])
def test_reading_words(tag, words):
    assert VI.reading_words(tag) == words


@pytest.mark.parametrize("diff, words", [((-0.009, 0.003), "more accurate"), ((0.009, 0.003), "less accurate"),
                                         ((-0.001, 0.003), "not distinguishable")])
def test_lw_theta_phrase_follows_the_sign(diff, words):
    assert words in V.lw_theta_phrase(diff)


@pytest.mark.parametrize("k, n, words", [(0, 16, "none of the 16"), (1, 16, "1 of the 16"), (16, 16, "all 16"),
                                         (1, 1, "the one")])
def test_k_of(k, n, words):
    assert VI.k_of(k, n) == words


def test_k_of_refuses_impossible_counts():
    with pytest.raises(ValueError):
        VI.k_of(3, 2)


def test_choices_display_folds_the_long_table_and_counts_its_rows():
    from pfrepro.experiments import dpf_hou2008 as E

    html = B.choices_display(E.CHOICES, "pf-dpf-choices").data
    assert html.startswith('<details class="pf-choices"><summary>The ' + str(len(E.CHOICES)) + " free choices")
    assert not B.choices_display(E.CHOICES, "pf-dpf-choices", collapsed=False).data.startswith("<details")


def test_causes_phrase():
    assert VI.causes_phrase(["too few runs", "depends on the reading", "too few runs"]) == \
        "2 (too few runs) and 1 (depends on the reading)"
    assert VI.causes_phrase([]) == "none"
