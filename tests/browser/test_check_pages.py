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
CLEAN = (HEAD + "<main style='width:600px'><p id='top'>Plain text, $5 and $6. <a href='index.html#top'>up</a></p>"
         f"<img src='{PNG_1PX}' alt='dot'><table><tr><th>a</th><td>1</td></tr></table>"
         "<div style='overflow-x:auto'><table style='width:900px'><tr><td>wide but scrolled</td></tr></table></div>"
         "</main></body></html>")
BROKEN = (HEAD + "<main style='width:600px'><p>leak $\\dot x$ here</p>"
          "<img src='missing.png' alt='gone'><a href='index.html#nowhere'>x</a><a href='gone.html'>y</a>"
          "<table style='width:900px'><tr><td>too wide</td></tr></table>"
          "<img src='http://example.com/x.png' alt='remote'>"
          "<div class='math' style='width:600px'><mjx-container style='display:block;overflow-x:auto'>"
          "<mjx-math style='display:inline-block;width:500px'>x</mjx-math>"
          "<span style='display:inline-block;width:900px'>a long tail</span></mjx-container></div>"
          "<script>console.error('boom')</script></main></body></html>")


def _run(tmp_path, html):
    (tmp_path / "index.html").write_text(html, encoding="utf-8")
    res = check_pages.check(tmp_path, [tmp_path / "index.html"], CHROMIUM, 1000, 700, None, False)
    return {k: sum(f["kind"] == k for f in res["index.html"]["fails"]) for k in check_pages.KINDS}


def test_clean_page_passes(tmp_path):
    assert _run(tmp_path, CLEAN) == dict.fromkeys(check_pages.KINDS, 0)


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
