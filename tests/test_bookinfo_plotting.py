"""pfrepro.bookinfo (what the build contains / what built it) and pfrepro.plotting (figure style)."""
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest

from pfrepro import bookinfo, plotting


def _book(tmp_path, chapters):
    toc = "format: jb-book\nroot: book/00_intro\nchapters:\n" + "".join(f"  - file: book/{c}\n" for c in chapters)
    (tmp_path / "_toc.yml").write_text(toc)
    (tmp_path / "book").mkdir()
    (tmp_path / "book" / "00_intro.md").write_text("# intro, mentions gpff_zhang2016 in prose only\n")
    return tmp_path


def test_papers_in_book_follow_the_toc(tmp_path):
    root = _book(tmp_path, ["20_a", "30_b", "40_c"])
    (root / "book" / "20_a.md").write_text("from pfrepro.experiments import gpff_zhang2016 as E\n")
    (root / "book" / "30_b.md").write_text("reg = ClaimsRegistry('dpf_hou2008')\n")
    (root / "book" / "40_c.md").write_text("no paper here; cmspf_ning2011 named in prose\n")
    found = bookinfo.papers_in_book(root / "book")
    assert found == {"gpff_zhang2016": "book/20_a", "dpf_hou2008": "book/30_b"}
    assert bookinfo.toc_files(root) == ["book/00_intro", "book/20_a", "book/30_b", "book/40_c"]


def test_papers_in_real_book_match_the_chapters():
    found = bookinfo.papers_in_book(Path(__file__).resolve().parents[1])
    assert {"gpff_zhang2016", "ekf_pf_li2012", "cmspf_ning2011"} <= set(found)
    assert found["gpff_zhang2016"] == "book/20_gpff"


def test_claim_anchor_and_link():
    assert bookinfo.claim_anchor("gpff_zhang2016", "t2_x_PF(500)") == "claim-gpff_zhang2016-t2_x_pf-500"
    assert 'id="claim-p-a_b"' in bookinfo.claim_anchor_html("p", "a_b")
    assert "&lt;" in bookinfo.claim_anchor_html("p", "x", "<b>")
    assert bookinfo.claim_href("p", "c", "book/20_x", "book/99_s") == "20_x.html#claim-p-c"


def test_build_info_has_what_an_archive_reader_needs():
    info = bookinfo.build_info()
    for key in ("git commit", "build date (UTC)", "CPU", "numpy", "scipy", "filterpy", "jupyter-book", "pfrepro"):
        assert info[key]
    assert info["numpy"] == np.__version__


def test_book_style_sets_dpi():
    plotting.use_book_style()
    assert matplotlib.rcParams["figure.dpi"] == plotting.BOOK_DPI >= 150
    fig = plt.figure()
    assert fig.dpi == plotting.BOOK_DPI
    plt.close(fig)


def test_log_ylim_ignores_the_reference():
    fig, ax = plt.subplots()
    ax.set_yscale("log")
    lo, hi = plotting.log_ylim_from(ax, np.array([0.1, 1.0, np.nan]), [5.0, 0.0], pad=2)
    assert (lo, hi) == (0.05, 10.0)
    with pytest.raises(ValueError):
        plotting.log_ylim_from(ax, [0.0, -1.0])
    plt.close(fig)


def test_anchored_claims_escapes_and_anchors():
    import pandas as pd

    t = pd.DataFrame({"claim_id": ["a1", "b<2>"], "text": ["x < y", "ok"], "reproduced": [1.23456, float("nan")]})
    out = bookinfo.anchored_claims(t, "pap").data
    assert 'id="claim-pap-a1"' in out and 'id="claim-pap-b-2"' in out
    assert "x &lt; y" in out and "1.235" in out and "–" in out
    with pytest.raises(ValueError, match="id_col"):
        bookinfo.anchored_claims(t, "pap", id_col="nope")


# ---- figure text readable at the column width ----------------------------------------------
import ast  # noqa: E402
import re  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
_SIZE_WORDS = {"xx-small": 0.579, "x-small": 0.694, "small": 0.833, "medium": 1.0, "large": 1.2,
               "x-large": 1.44, "xx-large": 1.728}


def _figure_scopes():
    """(where, AST) of every figure-making scope: functions of pfrepro.figures, chapter code cells."""
    for path in sorted((ROOT / "src/pfrepro/figures").glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef):
                yield f"{path.name}:{node.name}", node
    for path in sorted((ROOT / "book").glob("*.md")):
        text = path.read_text(encoding="utf-8")
        for i, m in enumerate(re.finditer(r"```\{code-cell\}[^\n]*\n(.*?)```", text, re.S)):
            src = re.sub(r"^---\n.*?\n---\n", "", m.group(1), flags=re.S)
            src = "\n".join(line for line in src.splitlines() if not line.startswith((":", "%", "!")))
            try:
                yield f"{path.name}:cell {i} (line {text[:m.start()].count(chr(10)) + 1})", ast.parse(src)
            except SyntaxError:
                continue


def _num(node):
    try:
        return float(ast.literal_eval(node))
    except (ValueError, TypeError, SyntaxError):
        return None


def _sizes(scope):
    """Literal figure widths (inches) and text sizes (points) set in a scope."""
    widths, fonts = [], []
    base = plotting.BOOK_STYLE["font.size"]
    for node in ast.walk(scope):
        if not isinstance(node, ast.Call):
            continue
        for kw in node.keywords:
            if kw.arg == "figsize" and isinstance(kw.value, ast.Tuple) and kw.value.elts:
                w = _num(kw.value.elts[0])
                if w is not None:
                    widths.append(w)
            elif kw.arg in ("fontsize", "labelsize", "size", "title_fontsize"):
                if isinstance(kw.value, ast.Constant) and isinstance(kw.value.value, str):
                    if kw.value.value in _SIZE_WORDS:
                        fonts.append(base * _SIZE_WORDS[kw.value.value])
                else:
                    v = _num(kw.value)
                    if v is not None and kw.arg != "size" or (v is not None and v < 40):
                        fonts.append(v)
    return widths, fonts


def test_book_style_text_is_at_least_the_minimum():
    sizes = {k: v for k, v in plotting.BOOK_STYLE.items() if k.endswith(("size", "fontsize"))}
    assert min(sizes.values()) >= plotting.MIN_FONT_PT, sizes


def test_rendered_text_size_rule():
    # a 12 in figure at 150 dpi is 1800 px, shown 741 px wide: 8 pt text is 6.9 px
    assert plotting.rendered_text_px(8, 12) == pytest.approx(8 * 741 / (72 * 12))
    # a figure narrower than the column is shown at its natural size
    assert plotting.rendered_text_px(8, 4) == pytest.approx(8 * 150 / 72)
    w = plotting.max_figure_width()
    assert plotting.rendered_text_px(plotting.MIN_FONT_PT, w) == pytest.approx(plotting.MIN_TEXT_PX)


def test_every_figure_text_is_readable_at_the_column_width():
    """No figure of the package or of a chapter sets text below MIN_FONT_PT, or is so wide that
    the smallest text it uses is shown below MIN_TEXT_PX in the text column (the browser check
    measures the same on the built pages from each image's natural and displayed width)."""
    bad = []
    scopes = list(_figure_scopes())
    assert len(scopes) > 50
    for where, scope in scopes:
        widths, fonts = _sizes(scope)
        small = min(fonts + [plotting.MIN_FONT_PT])
        if fonts and small < plotting.MIN_FONT_PT:
            bad.append(f"{where}: text {small:g} pt < {plotting.MIN_FONT_PT:g} pt")
        for w in widths:
            px = plotting.rendered_text_px(min(small, plotting.MIN_FONT_PT), w)
            if px < plotting.MIN_TEXT_PX - 1e-9:
                bad.append(f"{where}: figure {w:g} in wide shows {min(small, plotting.MIN_FONT_PT):g} pt text "
                           f"at {px:.1f} px < {plotting.MIN_TEXT_PX:g} px")
    assert not bad, "\n".join(bad)


def test_browser_check_uses_the_same_limits():
    import importlib.util

    spec = importlib.util.spec_from_file_location("check_pages", ROOT / "tests/browser/check_pages.py")
    cp = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cp)
    assert (cp.BOOK_DPI, cp.MIN_FONT_PT, cp.MIN_TEXT_PX) == (plotting.BOOK_DPI, plotting.MIN_FONT_PT,
                                                           plotting.MIN_TEXT_PX)


def test_method_colours():
    assert plotting.method_color("PF (500)") == plotting.method_color("PF, published") == plotting.METHOD_COLORS["PF"]
    assert plotting.method_color("IMMPFOR (mean lik.)") == plotting.METHOD_COLORS["IMMPFOR"]
    assert plotting.method_color("DEKF") != plotting.method_color("DPF")
    assert plotting.method_color("exact posterior mean") == plotting.REFERENCE_COLOR
    with pytest.raises(KeyError):
        plotting.method_color("guess 0.2")
    # one colour per method: no two methods of different families share a colour
    fam = {k: v for k, v in plotting.METHOD_COLORS.items() if not k.startswith("IMM-")}
    assert len(set(fam.values())) == len(fam)


def test_figure_modules_take_method_colours_from_the_palette():
    """The figure modules name no colour of matplotlib's default cycle ("C0".."C9") for a
    method: method colours come from pfrepro.plotting (one colour per method across the book)."""
    hits = []
    for path in sorted((ROOT / "src/pfrepro/figures").glob("*.py")):
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if re.search(r"[\"']C\d[\"']|[\"']C\d[-:.o]", line):
                hits.append(f"{path.name}:{i}: {line.strip()[:90]}")
    assert not hits, "\n".join(hits)


#: calls that return nothing (no cell output): the chapters' glue helpers
GLUE_NAMES = {"g", "gl", "gmd", "gfig", "glue", "glue_value", "glue_md", "glue_figure", "show_figure"}


def test_figure_cells_end_with_the_figure():
    """A chapter cell captioned as a figure (mystnb.figure) must not end with a table: myst-nb
    would wrap the table in a second figure with the same caption."""
    bad = []
    for path in sorted((ROOT / "book").glob("*.md")):
        text = path.read_text(encoding="utf-8")
        for m in re.finditer(r"```\{code-cell\}[^\n]*\n(---\n.*?\n---\n)?(.*?)```", text, re.S):
            if not m.group(1) or "figure:" not in m.group(1):
                continue
            src = "\n".join(line for line in m.group(2).splitlines() if not line.startswith((":", "%", "!")))
            body = ast.parse(src).body
            last = body[-1] if body else None
            call = last.value if isinstance(last, ast.Expr) and isinstance(last.value, ast.Call) else None
            quiet = call is not None and (
                (isinstance(call.func, ast.Attribute) and call.func.attr in ("show", "tight_layout"))
                or (isinstance(call.func, ast.Name) and call.func.id in GLUE_NAMES))
            if isinstance(last, ast.Expr) and not quiet:
                line = text[:m.start()].count("\n") + 1
                bad.append(f"{path.name}:{line}: figure cell ends with {ast.unparse(last)[:60]!r}")
    assert not bad, "\n".join(bad)


def test_breakable_text_offers_breaks_inside_tokens_only_in_text():
    b = bookinfo.breakable_text
    assert b("pf_resampling=multinomial: 12.57") == "pf_<wbr>resampling=<wbr>multinomial: 12.57"
    assert b("published/measured, N/2") == "published/<wbr>measured, N/<wbr>2"
    # tags and their attributes untouched; a separator at a token's end gets no break
    assert b('<a href="a_b.html#x=y">t2_x</a> a_ b=') == '<a href="a_b.html#x=y">t2_<wbr>x</a> a_ b='
    html = bookinfo.labelled_table_html(pd.DataFrame({"id": ["t2_x_PF(500)"], "test": ["integrator=rk4: 0.5"]}))
    assert "t2_<wbr>x_<wbr>PF(" in html and 'integrator=<wbr>rk4: <span class="pf-num">0.5</span>' in html


# ---- figures drawn for the laptop and for the phone ------------------------------------------

def _three_panels(**share):
    import numpy as np

    from pfrepro.figures import new_figure

    fig, axs = new_figure(1, 3, figsize=(10.2, 3.8), **share)
    for i, ax in enumerate(axs):
        ax.plot(np.arange(5), np.arange(5) * (i + 1), label=f"s{i}")
        ax.set_title(f"panel {i}")
        ax.legend()
    return fig, axs


def test_new_figure_outside_a_layout_is_plain_subplots():
    import matplotlib.pyplot as plt

    fig, axs = _three_panels()
    try:
        assert axs.shape == (3,)
        assert tuple(fig.get_size_inches()) == pytest.approx((10.2, 3.8))
        assert {round(ax.get_position().y0, 6) for ax in axs} == {round(axs[0].get_position().y0, 6)}
    finally:
        plt.close(fig)


@pytest.mark.parametrize("layout, rows", [(plotting.DESKTOP, 2), (plotting.PHONE, 3)])
def test_new_figure_reflows_panels_for_the_layout(layout, rows):
    import matplotlib.pyplot as plt

    with plotting.figure_layout(layout):
        fig, axs = _three_panels(sharey=True)
        try:
            assert axs.shape == (3,)                       # the caller's shape is kept
            assert fig.get_size_inches()[0] <= layout.width_in + 1e-9
            assert len({round(ax.get_position().y0, 6) for ax in axs}) == rows
            assert len({round(ax.get_position().x0, 6) for ax in axs}) == min(3, layout.max_cols)
            assert axs[2].get_title() == "panel 2" and len(fig.axes) == 3  # the empty place is removed
            assert axs[0].get_shared_y_axes().joined(axs[0], axs[2])
            assert plt.rcParams["legend.fontsize"] == layout.min_pt
        finally:
            plt.close(fig)
    assert plt.rcParams["legend.fontsize"] != plotting.PHONE.min_pt   # the style is left behind


def test_row_and_column_sharing_refer_to_the_requested_grid():
    import matplotlib.pyplot as plt

    from pfrepro.figures import new_figure

    with plotting.figure_layout(plotting.PHONE):
        fig, axs = new_figure(2, 2, figsize=(8, 6), sharex="col")
        try:
            assert axs.shape == (2, 2)
            assert axs[0, 0].get_shared_x_axes().joined(axs[0, 0], axs[1, 0])
            assert not axs[0, 0].get_shared_x_axes().joined(axs[0, 0], axs[0, 1])
        finally:
            plt.close(fig)


def test_responsive_figure_measures_its_text_and_makes_a_picture():
    import base64
    import re as _re

    fig = plotting.responsive(lambda: _three_panels()[0], alt="three lines & a <test>")
    assert fig.desktop_min_pt == pytest.approx(plotting.DESKTOP.min_pt)
    assert fig.phone_min_pt == pytest.approx(plotting.PHONE.min_pt)
    html = fig._repr_html_()
    assert f'media="{plotting.PHONE_MEDIA}"' in html and 'alt="three lines &amp; a &lt;test&gt;"' in html
    assert 'data-min-pt="10.50"' in html and 'data-phone-min-pt="12.00"' in html
    srcs = _re.findall(r'(?:srcset|src)="data:image/png;base64,([^"]+)"', html)
    assert [base64.b64decode(s) for s in srcs] == [fig.phone_png, fig.desktop_png]
    # on screen: the laptop drawing in a 745 px column, the phone one in a 350 px column
    for png, pt, col in ((fig.desktop_png, fig.desktop_min_pt, 745), (fig.phone_png, fig.phone_min_pt, 350)):
        width_px = int.from_bytes(png[16:20], "big")      # the PNG header's width
        assert pt * plotting.BOOK_DPI / 72 * min(1, col / width_px) >= 16


def test_responsive_figure_reports_small_text_and_narrows_wide_drawings():
    from pfrepro.figures import new_figure

    def draw():
        fig, ax = new_figure(figsize=(6, 3))
        ax.plot([0, 1], [0, 1], label="outside")
        ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1))
        ax.annotate("small", (0.5, 0.5), fontsize=7)
        return fig

    fig = plotting.responsive(draw, alt="x")
    assert fig.desktop_min_pt == 7 and fig.phone_min_pt == 7     # measured, not assumed
    assert int.from_bytes(fig.phone_png[16:20], "big") <= plotting.PHONE.width_in * plotting.BOOK_DPI * 1.05


def test_responsive_figure_refuses_bad_input():
    import matplotlib.pyplot as plt

    with pytest.raises(ValueError, match="alt"):
        plotting.responsive(lambda: _three_panels()[0], alt=" ")
    with pytest.raises(TypeError, match="function that draws"):
        plotting.responsive(plt.figure(), alt="x")
    with pytest.raises(TypeError, match="must return a matplotlib Figure"):
        plotting.responsive(lambda: 3, alt="x")
    plt.close("all")
