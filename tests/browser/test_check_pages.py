"""Self-test of the browser check on hand-made pages (skipped without chromium).

The check of the real book runs after the build (``.ci/run``, phase ``browser``); here we
make sure each of its failure kinds fires on a page that has the defect and stays silent on
one that does not.
"""
from __future__ import annotations

import importlib.util
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
CLEAN = (HEAD + "<main style='max-width:600px'><p id='top'>Plain text, $5 and $6. <a href='index.html#top'>up</a></p>"
         f"<img src='{PNG_1PX}' alt='dot'><table><tr><th>a</th><td>1</td></tr></table>"
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
            "<td style='width:150px;overflow-wrap:break-word'>pf_resampling=<wbr>systematic</td></tr></table>")
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
    _only(_run(tmp_path, _page("<table><tr><td>x_1, …, x_T are kept whole</td></tr></table>")))
    _only(_run(tmp_path, _page("<table><tr><td>swept (<span>2</span> ... <span>64</span> substeps)</td></tr></table>")))
    body = ("<table><tr><td style='max-width:80px;overflow:hidden;white-space:nowrap;text-overflow:ellipsis'>"
            "a reason far too long for this cell</td></tr></table>")
    assert _run(tmp_path, _page(body))["ellipsis"] == 1


def test_small_figure_text_fails(tmp_path):
    wide = _png(3000)
    body = f"<img src='{wide}' style='width:300px' alt='fig'>"
    _only(_run(tmp_path, _page(body)), figtext=1)
    # on a phone a tap-to-enlarge link to the full-size image is an answer; on a laptop it is not
    linked = f"<a href='{wide}'><img src='{wide}' style='width:300px' alt='fig'></a>"
    _only(_run(tmp_path, _page(linked), 400))
    _only(_run(tmp_path, _page(linked), 1000), figtext=1)
    # a figure shown near its natural size passes
    _only(_run(tmp_path, _page(f"<img src='{_png(500)}' style='width:400px' alt='fig'>")))


def test_raw_rst_in_api_pages_fails(tmp_path):
    body = ("<p>Use ``ClaimsRegistry`` and :class:`Claim` here.</p>"
            "<dl class='field-list'><dt>Parameters</dt><dd><p><strong>x</strong> (<em>ndarray (runs, T, dim_x) of the "
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
