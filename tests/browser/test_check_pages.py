"""Self-test of the browser check on hand-made pages (skipped without chromium).

The check of the real book runs after the build (``.ci/run``, phase ``browser``); here we
make sure each of its failure kinds fires on a page that has the defect and stays silent on
one that does not.
"""
from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

_spec = importlib.util.spec_from_file_location("check_pages", Path(__file__).with_name("check_pages.py"))
check_pages = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(check_pages)

CHROMIUM = check_pages.find_chromium()
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed")

PNG_1PX = ("data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42"
           "mNk+M9QDwADhgGAWjR9awAAAABJRU5ErkJggg==")
HEAD = "<!doctype html><html><head><meta charset='utf-8'><title>t</title></head><body>"
# the visible cue of a box that scrolls sideways (as in book/_static/pfrepro.css)
CUE = ("background: linear-gradient(to right, #fff 30%, transparent) left center / 2em 100% no-repeat local,"
       " radial-gradient(farthest-side at 0 50%, rgba(0,0,0,.3), transparent) left center / 1em 100% no-repeat scroll")
# an image made for the width it is read at (pfrepro.plotting's responsive-figure contract)
FIG_ATTRS = "data-dpi='150' data-min-pt='10.5' data-phone-min-pt='12.0'"
CLEAN = (HEAD + "<main style='max-width:600px'><p id='top'>Plain text, $5 and $6. <a href='index.html#top'>up</a></p>"
         f"<img src='{PNG_1PX}' alt='dot' {FIG_ATTRS}><table><tr><th>a</th><td>1</td></tr></table>"
         f"<div class='cell_output'><div class='output' style='overflow-x:auto;{CUE}'>"
         "<table style='width:900px'><tr><td>wide but scrolled</td></tr></table></div></div>"
         "</main></body></html>")
BROKEN = (HEAD + "<main style='width:600px'><p>leak $\\dot x$ here</p>"
          "<img src='missing.png' alt='gone'><a href='index.html#nowhere'>x</a><a href='gone.html'>y</a>"
          "<table style='width:900px'><tr><td>too wide</td></tr></table>"
          "<img src='http://example.com/x.png' alt='remote'>"
          "<div class='math' style='width:600px'><mjx-container style='display:block;overflow-x:auto'>"
          "<mjx-math style='display:inline-block;width:500px'>x</mjx-math>"
          "<span style='display:inline-block;width:900px'>a long tail</span></mjx-container></div>"
          "<script>console.error('boom')</script></main></body></html>")


_BROWSER = []


@pytest.fixture(scope="module", autouse=True)
def _one_browser():
    """One headless Chromium for the whole file (a page per test, a fresh tab per page)."""
    b = check_pages.Browser(CHROMIUM, 1000, 700)
    _BROWSER.append(b)
    yield
    _BROWSER.clear()
    b.close()


def _run(tmp_path, html, width=1000, name="index.html"):
    page = tmp_path / name
    page.parent.mkdir(parents=True, exist_ok=True)
    page.write_text(html, encoding="utf-8")
    (tmp_path / "index.html").touch()
    res = check_pages.check(tmp_path, [page], CHROMIUM, width, 700, None, False,
                            browser=_BROWSER[0] if _BROWSER else None)
    return {k: sum(f["kind"] == k for f in res[name]["fails"]) for k in check_pages.KINDS}


def _only(counts, **expected):
    """The page fails exactly the expected kinds (and no other)."""
    got = {k: n for k, n in counts.items() if n}
    assert got == expected, got


@pytest.mark.parametrize("width", check_pages.WIDTHS)
def test_clean_page_passes(tmp_path, width):
    assert _run(tmp_path, CLEAN, width) == dict.fromkeys(check_pages.KINDS, 0)


def test_each_defect_is_caught(tmp_path):
    n = _run(tmp_path, BROKEN)
    assert n["console"] >= 2          # console.error + the missing file logged by the browser
    assert n["network"] >= 1          # the http image was requested and blocked
    assert n["image"] == 2            # missing file + blocked remote image
    assert n["table"] == 1
    assert n["tex"] == 1
    assert n["link"] == 2            # missing anchor + missing page
    assert n["equation"] == 1        # an equation that scrolls sideways in a box of its own


def test_no_build_is_a_clear_error(tmp_path, capsys):
    assert check_pages.main(["--root", str(tmp_path / "nothing")]) == 2
    assert "no built book" in capsys.readouterr().err


def _png(width: int, height: int = 1) -> str:
    """A blank PNG of the given size as a data URI (natural size for the figure-text rule)."""
    import base64
    import struct
    import zlib

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))
    raw = b"".join(b"\0" + b"\xff" * width for _ in range(height))
    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
    return "data:image/png;base64," + base64.b64encode(png).decode()


def _page(body):
    return HEAD + "<main style='max-width:600px'>" + body + "</main></body></html>"


# ---- one page per rule of the phone viewport / the new table, figure and API rules -----------
def test_wide_element_fails_at_phone_width(tmp_path):
    _only(_run(tmp_path, _page("<div style='width:700px'>a fixed-width block</div>"), 400), wide=1, overflow=2)
    assert _run(tmp_path, _page("<div style='width:700px'>a fixed-width block</div>"), 1000)["wide"] == 0
    # text (a long word in a heading) running past the viewport is caught, not only boxes
    _only(_run(tmp_path, _page("<h1>pfrepro.experiments.immpfor_zhou2017_and_more</h1>"), 400), wide=1, overflow=2)


def test_scroll_box_not_allowed_by_name_fails(tmp_path):
    body = f"<div style='overflow-x:auto;{CUE}'><div style='width:900px'>wide</div></div>"
    _only(_run(tmp_path, _page(body), 400), wide=1)


def test_scroll_box_without_cue_fails(tmp_path):
    body = ("<div class='cell_output'><div class='output' style='overflow-x:auto'>"
            "<table style='width:900px'><tr><td>wide</td></tr></table></div></div>")
    _only(_run(tmp_path, _page(body), 400), wide=1)


def test_text_drawn_over_next_cell_fails(tmp_path):
    body = ("<table style='table-layout:fixed;width:300px'><tr>"
            "<td style='width:60px;white-space:nowrap'>publishedverdict over here</td><td>next</td></tr></table>")
    _only(_run(tmp_path, _page(body)), overlap=1)


def test_number_broken_in_a_table_fails(tmp_path):
    body = ("<table style='table-layout:fixed;width:40px'><tr>"
            "<td style='width:40px;overflow-wrap:anywhere'>0.0038123456789</td></tr></table>")
    _only(_run(tmp_path, _page(body)), number=1)


def test_word_broken_in_a_table_fails(tmp_path):
    body = ("<table style='table-layout:fixed;width:60px'><tr>"
            "<td style='width:60px;overflow-wrap:anywhere'>inconclusive</td></tr></table>")
    _only(_run(tmp_path, _page(body)), word=1)
    # a break the text offers (after "=") is not inside a word
    body = ("<table style='table-layout:fixed;width:150px'><tr>"
            "<td class='pf-internal-ok' style='width:150px;overflow-wrap:break-word'>pf_resampling=<wbr>systematic</td>"
            "</tr></table>")
    _only(_run(tmp_path, _page(body)))
    # Chinese wraps between any two characters: a quoted sentence over two lines is no broken word,
    # while a Latin word beside it still is
    body = ("<table style='table-layout:fixed;width:60px'><tr>"
            "<td style='width:60px'>模型考察多维和非理想初值条件下各滤波器性能</td></tr></table>")
    _only(_run(tmp_path, _page(body)))
    body = ("<table style='table-layout:fixed;width:60px'><tr>"
            "<td style='width:60px;overflow-wrap:anywhere'>非理想初值 inconclusive</td></tr></table>")
    _only(_run(tmp_path, _page(body)), word=1)


def test_ellipsis_in_a_table_fails(tmp_path):
    _only(_run(tmp_path, _page("<table><tr><td>the reason is cut …</td></tr></table>")), ellipsis=1)
    _only(_run(tmp_path, _page("<table><tr><td>pandas cut this reason at fifty charac...</td></tr></table>")), ellipsis=1)
    _only(_run(tmp_path, _page("<table><tr><td>x<sub>1</sub>, …, x<sub>T</sub> are kept whole</td></tr></table>")))
    _only(_run(tmp_path, _page("<table><tr><td>swept (<span>2</span> ... <span>64</span> substeps)</td></tr></table>")))
    body = ("<table><tr><td style='max-width:80px;overflow:hidden;white-space:nowrap;text-overflow:ellipsis'>"
            "a reason far too long for this cell</td></tr></table>")
    assert _run(tmp_path, _page(body))["ellipsis"] == 1


def _fails(tmp_path, html, width=1000, name="index.html", kind=None):
    """The failures of one page (of one kind), as the check reports them."""
    page = tmp_path / name
    page.parent.mkdir(parents=True, exist_ok=True)
    page.write_text(html, encoding="utf-8")
    (tmp_path / "index.html").touch()
    res = check_pages.check(tmp_path, [page], CHROMIUM, width, 700, None, False,
                            browser=_BROWSER[0] if _BROWSER else None)
    return [f for f in res[name]["fails"] if kind is None or f["kind"] == kind]


def _figure(desktop_w, shown, phone_w=None, min_pt=10.5, phone_pt=12.0, attrs=True):
    """A figure as pfrepro.plotting writes it: a <picture> with a phone drawing (if phone_w) and
    the desktop drawing, each a blank PNG of the given natural width."""
    data = f"data-dpi='150' data-min-pt='{min_pt}' data-phone-min-pt='{phone_pt}'" if attrs else ""
    source = f"<source media='(max-width: 720px)' srcset='{_png(phone_w)}'>" if phone_w else ""
    return (f"<div class='pf-figure'><picture>{source}<img class='pf-figure-img' src='{_png(desktop_w)}' "
            f"alt='fig' {data} style='width:{shown};max-width:100%'></picture></div>")


def test_figure_without_the_contract_fails_at_every_width(tmp_path):
    # a plain matplotlib PNG is not made for the width it is read at, whatever its size; the
    # old tap-to-enlarge answer on a phone no longer counts
    plain = f"<p>Body text.</p><img src='{_png(500)}' style='width:400px' alt='fig'>"
    for width in check_pages.WIDTHS:
        got = _fails(tmp_path, _page(plain), width, kind="figtext")
        assert len(got) == 1 and "not made for the width" in got[0]["detail"], got
    wide = _png(3000)
    linked = f"<p>Body text.</p><a href='{wide}'><img src='{wide}' style='width:300px' alt='fig'></a>"
    _only(_run(tmp_path, _page(linked), 400), figtext=1)


def test_figure_text_smaller_than_body_text_fails(tmp_path):
    # 10.5 pt at 150 dpi is 21.9 px at natural size: shown at 800 of 1000 px it is 17.5 px >= 16 px
    wide_main = HEAD + "<main style='max-width:900px'><p>Body text.</p>{}</main></body></html>"
    _only(_run(tmp_path, wide_main.format(_figure(1000, "800px")), 1000))
    # shown at 600 of 1000 px: 13.1 px < 16 px
    got = _fails(tmp_path, wide_main.format(_figure(1000, "600px")), 1000, kind="figtext")
    assert len(got) == 1 and "13.1px" in got[0]["detail"] and "16px" in got[0]["detail"], got
    # the yardstick is the page's own body text, not a fixed 16 px: the 17.5 px that passed
    # under 16 px body text fails under 20 px body text
    page20 = wide_main.replace("<p>", "<p style='font-size:20px'>").format(_figure(1000, "800px"))
    got = _fails(tmp_path, page20, 1000, kind="figtext")
    assert len(got) == 1 and "17.5px" in got[0]["detail"] and "20px" in got[0]["detail"], got


def test_phone_reads_the_phone_drawing(tmp_path):
    # at 400 px the <picture> picks the phone drawing (480 px natural, 12 pt): 25 px * 384/480 = 20 px
    both = "<p>Body text.</p>" + _figure(1000, "100%", phone_w=480)
    _only(_run(tmp_path, _page(both), 400))
    # with no phone drawing the desktop one is squeezed to 384 of 1000 px: 8.4 px < 16 px
    got = _fails(tmp_path, _page("<p>Body text.</p>" + _figure(1000, "100%")), 400, kind="figtext")
    assert len(got) == 1 and "desktop drawing" in got[0]["detail"], got
    # the phone drawing's own smallest text is what counts there (6 pt: 10 px on screen)
    got = _fails(tmp_path, _page("<p>Body text.</p>" + _figure(1000, "100%", phone_w=480, phone_pt=6.0)), 400,
                 kind="figtext")
    assert len(got) == 1 and "phone drawing" in got[0]["detail"], got
    # and on a laptop the desktop drawing is read (the phone drawing's 6 pt does not matter)
    page = HEAD + "<main style='max-width:900px'><p>Body text.</p>{}</main></body></html>"
    _only(_run(tmp_path, page.format(_figure(1000, "800px", phone_w=480, phone_pt=6.0)), 1000))


def _table(ncols, cls="", caption=None, cell_style=""):
    head = "".join(f"<th>h{i}</th>" for i in range(ncols))
    row = "".join(f"<td style='{cell_style}'>{i}</td>" for i in range(ncols))
    cap = f"<caption>{caption}</caption>" if caption else ""
    return f"<table class='{cls}'>{cap}<thead><tr>{head}</tr></thead><tbody><tr>{row}</tr></tbody></table>"


def test_table_with_more_than_eight_columns_fails(tmp_path):
    _only(_run(tmp_path, _page(_table(8))))
    got = _fails(tmp_path, _page(_table(9, caption="Errors per filter")), kind="columns")
    assert len(got) == 1 and "9 columns" in got[0]["detail"] and "Errors per filter" in got[0]["what"], got
    # no caption: the first headers name the table
    got = _fails(tmp_path, _page(_table(12)), 400, kind="columns")
    assert len(got) == 1 and "12 columns" in got[0]["detail"] and "h0 | h1" in got[0]["what"], got
    # a cell spanning columns counts for each; a hidden column is not shown
    span = "<table><tr><td colspan='8'>wide</td><td>x</td></tr></table>"
    assert len(_fails(tmp_path, _page(span), kind="columns")) == 1
    hidden = _table(9).replace("<th>h8</th>", "<th style='display:none'>h8</th>").replace(
        "<td style=''>8</td>", "<td style='display:none'>8</td>")
    _only(_run(tmp_path, _page(hidden)))
    # claims tables (cards on a phone) and tables shown as cards at this width are exempt
    _only(_run(tmp_path, _page(_table(9, cls="pf-claims"))))
    _only(_run(tmp_path, _page(_table(9, cell_style="display:block"))))


def test_one_word_per_line_cell_fails(tmp_path):
    narrow = ("<table style='table-layout:fixed;width:{w}px;font-size:12px'><tr>"
              "<td style='width:{w}px'>{text}</td></tr></table>")
    got = _fails(tmp_path, _page(narrow.format(w=24, text="one two six")), kind="narrow")
    assert len(got) == 1 and "3 words on 3 lines" in got[0]["detail"], got
    # the same words with room to run on: one line
    _only(_run(tmp_path, _page(narrow.format(w=300, text="one two six"))))
    # two words, one per line, are a short label, not a defect; four words on two lines pass
    _only(_run(tmp_path, _page(narrow.format(w=24, text="one two"))))
    _only(_run(tmp_path, _page(narrow.format(w=55, text="one two six ten"))))
    # numbers and inline markup of another size sit on one line with the words around them
    mixed = "value <span style='font-size:0.7em'>0.5</span> under <sup>every</sup> reading"
    _only(_run(tmp_path, _page(narrow.format(w=400, text=mixed))))
    # a card (a cell shown as a block on a phone) is read the same way
    card = ("<table><tr><td style='display:block;width:24px;font-size:12px' data-label='judged'>"
            "one two six</td></tr></table>")
    got = _fails(tmp_path, _page(card), 400, kind="narrow")
    assert len(got) == 1 and "[judged]" in got[0]["what"], got
    # a token split by <wbr> (a claim id that may wrap after its "_") is one word, not three
    ids = ("<table class='pf-claims' style='table-layout:fixed;width:88px;font-size:12px'><tr>"
           "<td style='width:88px'>or_<wbr>approximates_<wbr>posterior</td></tr></table>")
    _only(_run(tmp_path, _page(ids)))


INTERNAL = {
    "issue number": ["The cap was found (issue 22; see there).", "fixed (#22) last week", "as in #22 above"],
    "module alias": ["the scenario E.SCENARIO decides", "the pairs of E.paired here", "S.table shows it"],
    "None": ["the step d = None here", "significantly better at d = none", "<table><tr><td>None</td></tr></table>"],
    "dict/list repr": ["seeds {'main': 20170501}", "values ['a', 'b'] here"],
    "unrendered glue": ["the ratio {glue:}`r` here", "glue(\"ratio\", r) is shown"],
    "claim id": ["as bot_pf4000_worse shows", "the reading pf_resampling=systematic"],
}


@pytest.mark.parametrize("what", sorted(INTERNAL))
def test_internal_words_in_reader_text_fail(tmp_path, what):
    for text in INTERNAL[what]:
        body = text if text.startswith("<") else f"<p>{text}</p>"
        got = _fails(tmp_path, _page(body), kind="internal")
        assert got and all(what in f["what"] for f in got), (text, got)
        # the hit is shown with its context (the words around it)
        words = [w for w in re.split(r"<[^>]+>|\s+", text) if w]
        assert words[0] in got[0]["detail"] or len(words) == 1, (text, got)


def test_nan_shown_as_a_table_value_fails(tmp_path):
    for cell in ("nan", "NaN", "0.5 ± nan"):
        got = _fails(tmp_path, _page(f"<table><tr><td>{cell}</td></tr></table>"), kind="internal")
        assert len(got) == 1 and "nan" in got[0]["what"], (cell, got)
    _only(_run(tmp_path, _page("<table><tr><td>finance and nanometres</td></tr></table>")))
    # a sentence in a cell that names NaN is not a value
    _only(_run(tmp_path, _page("<table><tr><td>Some runs diverged (NaN from that step on)</td></tr></table>")))


def test_internal_words_where_they_belong_pass(tmp_path):
    body = ("<p>None of the filters diverge; the EKF (E. Wan and F. Gustafsson), e.g. E.g. this.</p>"
            "<p>The code reads <code>E.SCENARIO</code> and <code>bot_pf4000_worse</code>; math "
            "<span class='math'><mjx-container>x_k</mjx-container></span>; built on x86_64.</p>"
            "<pre>glue(\"ratio\", r)  # issue 22\nd = None</pre>"
            "<div class='highlight'><span>{'main': 1}</span></div>"
            "<table class='pf-claims'><tr><td>bot_pf4000_worse</td><td>reproduced</td>"
            "<td>n_th=2: holds; cap=none: fails</td></tr></table>"
            "<p class='pf-internal-ok'>the id bot_pf4000_worse, explained</p>"
            "<p style='display:none'>issue 22 hidden</p>"
            "<p>Equation 3 of <a href='https://example.org/a_b/c_d.pdf'>the paper</a> and section 5.2.</p>")
    _only(_run(tmp_path, _page(body)))
    _only(_run(tmp_path, _page(body), 400))
    # a closed dropdown is read (the reader opens it)
    got = _fails(tmp_path, _page("<details><summary>more</summary><p>see issue 22</p></details>"), kind="internal")
    assert len(got) == 1, got


def test_claims_tables_may_show_ids_but_nothing_else_internal(tmp_path):
    table = "<table class='pf-claims'><tr><td>bot_pf4000_worse</td><td>{}</td></tr></table>"
    _only(_run(tmp_path, _page(table.format("reproduced"))))
    for text, what in (("held at d = None", "None"), ("see issue 22", "issue number"), ("nan", "nan")):
        got = _fails(tmp_path, _page(table.format(text)), kind="internal")
        assert len(got) == 1 and what in got[0]["what"], (text, got)


def test_api_pages_document_python(tmp_path):
    # in the API reference None is a value and snake_case names are parameters: allowed; issue
    # numbers and aliases are not, and signatures are code
    body = ("<dl class='py function'><dt class='sig'><span class='sig-name'>run_mc</span>(n_runs=None)</dt>"
            "<dd><p>Runs <strong>n_runs</strong> (int or None) – runs per reading, default None.</p></dd></dl>")
    _only(_run(tmp_path, _page(body), name="book/api/x.html"))
    got = _fails(tmp_path, _page(body + "<p>Synthesis of the five papers (issue 13).</p>"),
                 name="book/api/x.html", kind="internal")
    assert len(got) == 1 and "issue number" in got[0]["what"], got
    # the same text in a chapter is reader prose
    got = _fails(tmp_path, _page(body), name="book/x.html", kind="internal")
    assert {f["what"].split(" ", 1)[1] for f in got} >= {"None", "claim id"}, got


def test_raw_rst_in_api_pages_fails(tmp_path):
    body = ("<p>Use ``ClaimsRegistry`` and :class:`Claim` here.</p>"
            "<dl class='field-list'><dt>Parameters</dt><dd><p><strong>x</strong> (<em>ndarray (runs, T, dim) of the "
            "states the filter estimated at every step, one per run</em>) – the states</p></dd></dl>")
    _only(_run(tmp_path, _page(body), name="book/api/x.html"), rst=2)
    # the same text outside the API reference is prose, not a docstring
    _only(_run(tmp_path, _page(body), name="book/x.html"))


def test_wide_equation_may_scroll_on_a_phone_only_with_a_cue(tmp_path):
    eq = ("<div class='math'><mjx-container style='display:block;overflow-x:auto;{style}'>"
          "<mjx-math style='display:inline-block;width:900px'>x</mjx-math></mjx-container></div>")
    _only(_run(tmp_path, _page(eq.format(style=CUE)), 400))
    _only(_run(tmp_path, _page(eq.format(style='')), 400), equation=1, wide=1)
    _only(_run(tmp_path, _page(eq.format(style=CUE)), 1000), equation=1)


def test_entry_cut_at_the_contents_panel_edge_fails(tmp_path):
    panel = ("<div class='bd-sidebar-secondary' style='position:fixed;right:0;top:0;width:150px;overflow:hidden'>"
             "<a href='#top' id='top' style='white-space:nowrap'>EvolutionSamplingParticleFilter</a></div>")
    _only(_run(tmp_path, _page(panel)), wide=1)
    wrapped = panel.replace("white-space:nowrap", "overflow-wrap:anywhere")
    _only(_run(tmp_path, _page(wrapped)))


def test_captioned_figure_without_an_image_fails(tmp_path):
    body = "<figure><div><table><tr><td>1</td></tr></table></div><figcaption>Fig. 5: a curve</figcaption></figure>"
    _only(_run(tmp_path, _page(body)), figure=1)
    _only(_run(tmp_path, _page(body.replace("<table>", f"<img src='{PNG_1PX}' alt='c'><table>"))))
