"""One legend below a figure's panels (``pfrepro.figures.legend_below``), for every figure of the book.

Checked for both ways a figure is laid out (``layout="constrained"`` and ``tight_layout``) and both
widths it is drawn for: the legend is under every panel, each label once, in no more columns than
fit the layout's width (one on a phone), and the panels keep the size they have without it.
"""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from pfrepro.figures import legend_below, legend_columns, new_figure  # noqa: E402
from pfrepro.plotting import BOOK_DPI, DESKTOP, PHONE, figure_layout, responsive  # noqa: E402

LAYOUTS = {"desktop": DESKTOP, "phone": PHONE}
ENGINES = {"constrained": {"layout": "constrained"}, "tight": {}}
#: labels long enough that four of them do not fit side by side on a laptop (nor two on a phone)
LONG = ["exact posterior mean (grid)", "bootstrap PF, 500 particles", "GPFF, flow step 0.01", "EKF on the previous estimate"]


def _draw(engine: str, labels=LONG, repeat: bool = True, legend: bool = True, **kw):
    """Two panels (four places on a 2 x 2 request) whose curves share their labels; the legend if asked."""
    fig, axes = new_figure(2, 2, figsize=(10, 6), **ENGINES[engine])
    for i, ax in enumerate(axes.flat):
        for j, lab in enumerate(labels if repeat or i == 0 else []):
            ax.plot([0, 1], [j, j + i], label=lab)
        ax.plot([0, 1], [1, 0], label="_hidden")
        ax.set_xlabel("time step k"); ax.set_title(f"({'abcd'[i]})")
    leg = legend_below(fig, axes, **kw) if legend else None
    fig.canvas.draw()
    return fig, axes, leg


def _inches(fig, bbox):
    return np.array([bbox.x0, bbox.y0, bbox.x1, bbox.y1]) / fig.dpi


@pytest.fixture(params=list(LAYOUTS))
def layout(request):
    with figure_layout(LAYOUTS[request.param]) as lay:
        yield lay


@pytest.mark.parametrize("engine", list(ENGINES))
def test_legend_is_below_every_panel_and_lists_each_label_once(layout, engine):
    fig, axes, leg = _draw(engine, ncol=4)
    r = fig.canvas.get_renderer()
    top = _inches(fig, leg.get_window_extent(r))[3]
    lowest = min(_inches(fig, ax.get_tightbbox(r))[1] for ax in fig.axes)   # tick labels and axis labels too
    assert top <= lowest + 1e-6, (top, lowest)
    assert [t.get_text() for t in leg.get_texts()] == LONG          # four panels, each label once, "_hidden" left out
    assert fig.legends == [leg] and all(ax.get_legend() is None for ax in fig.axes)
    plt.close(fig)


@pytest.mark.parametrize("engine", list(ENGINES))
def test_columns_fit_the_layout_width_and_the_phone_gets_one(layout, engine):
    fig, _, leg = _draw(engine, ncol=4)
    box = _inches(fig, leg.get_window_extent(fig.canvas.get_renderer()))
    if layout is PHONE:
        assert leg._ncols == 1             # (one label may be wider than the phone: one column is the fewest)
    else:
        assert box[2] - box[0] <= layout.width_in, (box, layout)
        assert 1 < leg._ncols < 4          # four long labels do not fit side by side in 6.5 in; two do
        assert leg._ncols == legend_columns(LONG, 4)
    plt.close(fig)
    # short labels: as many columns as asked on a laptop, still one on a phone
    fig, _, leg = _draw(engine, labels=["CV", "CT", "CA"], ncol=3)
    assert leg._ncols == (1 if layout is PHONE else 3)
    plt.close(fig)


@pytest.mark.parametrize("engine", list(ENGINES))
def test_a_narrow_figure_keeps_its_legend_within_its_own_width(engine):
    """A figure narrower than the layout (4.3 in of 6.5): the legend is fitted to the figure, not to
    the layout, so the PNG does not widen beyond its panels (and shrink on the page)."""
    with figure_layout(DESKTOP):
        fig, ax = new_figure(figsize=(4.3, 3.5), **ENGINES[engine])
        for lab in ("max |Δ altitude| (ft)", "max |Δ velocity| (ft/s)", "filters: 4 substeps"):
            ax.plot([0, 1], [0, 1], label=lab)
        leg = legend_below(fig, ax, ncol=3)
        fig.canvas.draw()
        box = _inches(fig, leg.get_window_extent(fig.canvas.get_renderer()))
        assert box[2] - box[0] <= 4.3 and leg._ncols < 3
        plt.close(fig)


@pytest.mark.parametrize("engine", list(ENGINES))
def test_panels_keep_their_size(layout, engine):
    sizes = []
    for legend in (False, True):
        fig, _, _ = _draw(engine, legend=legend, ncol=4)
        if not legend and engine == "tight":
            fig.tight_layout(); fig.canvas.draw()
        r = fig.canvas.get_renderer()
        sizes.append([np.diff(_inches(fig, ax.get_window_extent(r)).reshape(2, 2), axis=0) for ax in fig.axes])
        plt.close(fig)
    np.testing.assert_allclose(sizes[1], sizes[0], atol=0.01)    # inches


def test_entries_of_given_axes_or_given_handles():
    with figure_layout(DESKTOP):
        fig, axes = new_figure(1, 2, figsize=(10, 4), layout="constrained")
        a, = axes[0].plot([0, 1], label="left")
        axes[1].plot([0, 1], label="right")
        assert [t.get_text() for t in legend_below(fig, axes[0]).get_texts()] == ["left"]
        plt.close(fig)
        fig, axes = new_figure(1, 2, figsize=(10, 4))
        leg = legend_below(fig, axes, handles=[a, a], labels=["one", "one"])
        assert [t.get_text() for t in leg.get_texts()] == ["one"]
        assert legend_below(fig, axes) is None          # no labelled artist: no legend
        plt.close(fig)


def test_bad_arguments_are_refused_with_their_name():
    fig, ax = plt.subplots()
    ax.plot([0, 1], label="a")
    with pytest.raises(ValueError, match="handles and labels"):
        legend_below(fig, ax, labels=["a"])
    with pytest.raises(ValueError, match="as many labels"):
        legend_below(fig, ax, handles=ax.lines, labels=["a", "b"])
    with pytest.raises(ValueError, match="ncol"):
        legend_below(fig, ax, ncol=0)
    with figure_layout(PHONE), pytest.raises(ValueError, match="ncol"):
        legend_below(fig, ax, ncol=0)               # refused on the phone too, where one column is drawn anyway
    with pytest.raises(ValueError, match="width_in"):
        legend_columns(["a"], 2, width_in=0)
    plt.close(fig)


def test_legend_columns_measure_the_drawn_width():
    """Wider space, more columns; mathematics counts at its drawn width, not its source length."""
    assert legend_columns(LONG, 4, width_in=20) == 4
    assert legend_columns(LONG, 4, width_in=2) == 1
    assert legend_columns(LONG, None, width_in=20) == 4                 # None: as many as fit
    tex = [r"$\hat x_{k-1|k-1}$", r"$\tilde w_k^i$", r"$B_k$"]
    assert legend_columns(tex, 3, width_in=3) == 3


@pytest.mark.parametrize("engine", list(ENGINES))
def test_a_figure_with_a_long_legend_meets_the_figure_contract(engine):
    """Both drawings: text at the layout's size, the PNG no wider than the layout (so nothing shrinks)."""
    def draw():
        return _draw(engine, ncol=4)[0]

    r = responsive(draw, alt="four panels with one legend")
    assert r.desktop_min_pt >= DESKTOP.min_pt and r.phone_min_pt >= PHONE.min_pt
    for png, lay in ((r.desktop_png, DESKTOP), (r.phone_png, PHONE)):
        assert int.from_bytes(png[16:20], "big") <= lay.width_in * BOOK_DPI * 1.08
