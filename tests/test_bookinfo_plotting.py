"""pfrepro.bookinfo (what the build contains / what built it) and pfrepro.plotting (figure style)."""
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
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
