"""Layout helpers the chapter figure modules share: which drawing is being made (laptop or phone),
one legend below a figure's panels (:func:`legend_below`, exported by :mod:`pfrepro.figures`),
panel letters and plain log ticks. The tables' text helpers are in :mod:`pfrepro.bookinfo`."""
from __future__ import annotations

import numpy as np


def phone() -> bool:
    """Whether the figure is being drawn for the phone (one panel per row, a narrow column)."""
    from ..plotting import current_layout

    layout = current_layout()
    return layout is not None and layout.max_cols == 1


def _check_ncol(who: str, ncol) -> None:
    if ncol is not None and (isinstance(ncol, bool) or not isinstance(ncol, (int, np.integer)) or ncol < 1):
        raise ValueError(f"{who} needs ncol >= 1 (or None), got {ncol!r}")


def legend_columns(labels, ncol: int | None = None, width_in: float | None = None, **legend_kw) -> int:
    """Most legend columns (at most ``ncol``; ``None``: one per label) whose entries fit side by side
    in ``width_in`` inches at the legend's type size.

    ``width_in`` defaults to the width the figure is drawn for (:func:`pfrepro.plotting.current_layout`;
    :data:`pfrepro.plotting.DESKTOP` outside a layout). The entries are laid out by matplotlib on a
    scratch figure and measured (``legend_kw`` as for ``Figure.legend``: a ``fontsize`` or
    ``columnspacing`` changes the width), so a label with mathematics counts at its drawn width. A
    legend wider than the figure would widen the PNG and shrink all of its text on the page.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from ..plotting import DESKTOP, current_layout

    labels = [str(lab) for lab in labels]
    _check_ncol("legend_columns", ncol)
    if width_in is None:
        width_in = (current_layout() or DESKTOP).width_in
    if not width_in > 0:
        raise ValueError(f"legend_columns needs width_in > 0, got {width_in!r}")
    if not labels:
        return 1
    scratch = Figure(dpi=150)  # the book's resolution: text is measured as it is drawn
    renderer = FigureCanvasAgg(scratch).get_renderer()
    kw = {"frameon": False, **legend_kw}
    for n in range(min(ncol or len(labels), len(labels)), 1, -1):
        leg = scratch.legend([Line2D([], []) for _ in labels], labels, ncol=n, **kw)
        wide = leg.get_window_extent(renderer).width / scratch.dpi
        leg.remove()
        if wide <= 0.98 * width_in:
            return n
    return 1


def legend_below(fig, axes=None, ncol: int | None = None, handles=None, labels=None, **legend_kw):
    """One legend for the whole figure, below all of its panels; returns the legend (``None`` when
    there is nothing to show).

    The entries are ``handles`` with ``labels`` when given, else those of ``axes`` (an axis or an
    array of them; default every visible axis of ``fig``), each label once (the first handle) and
    labels starting with ``_`` left out. The columns are as many as fit the width the figure is drawn
    at (its own width, at most the layout's, :func:`pfrepro.plotting.current_layout`;
    :func:`legend_columns`, at most ``ncol``), one on the phone: a legend inside
    a panel hides data, and one wider than the layout would make the whole drawing wider and its text
    smaller. The panels keep their size: a figure with ``layout="constrained"`` grows by the legend's
    height (the legend is placed ``"outside lower center"``); any other figure is laid out with
    ``tight_layout`` first and the legend is placed under the lowest panel's labels, outside the
    figure, where the saved PNG (``bbox_inches="tight"``) grows to hold it. ``legend_kw`` go to
    ``Figure.legend``.
    """
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    from ..plotting import current_layout

    _check_ncol("legend_below", ncol)
    if (handles is None) != (labels is None):
        raise ValueError("legend_below needs both handles and labels, or neither")
    if handles is None:
        pairs = [pair for ax in (fig.axes if axes is None else np.atleast_1d(axes).ravel())
                 if ax is not None and ax.get_visible() for pair in zip(*ax.get_legend_handles_labels())]
    else:
        handles, labels = list(handles), [str(lab) for lab in labels]
        if len(handles) != len(labels):
            raise ValueError(f"legend_below needs as many labels as handles, got {len(labels)} and {len(handles)}")
        pairs = list(zip(handles, labels))
    seen = {}
    for h, lab in pairs:
        if not lab.startswith("_"):
            seen.setdefault(lab, h)
    if not seen:
        return None
    labels, handles = list(seen), list(seen.values())
    # the figure's width, at most the layout's: a legend wider than a narrow figure would widen the PNG
    # beyond its panels, and the page would shrink the whole drawing (and its text) to fit the column
    layout = current_layout()
    width_in = fig.get_size_inches()[0] if layout is None else min(layout.width_in, fig.get_size_inches()[0])
    n = 1 if phone() else legend_columns(labels, ncol, width_in, **legend_kw)
    kw = {"frameon": False, "ncol": n, **legend_kw}
    if isinstance(fig.get_layout_engine(), ConstrainedLayoutEngine):
        leg = fig.legend(handles, labels, loc="outside lower center", **kw)
        # constrained layout takes the legend's height (and its pad) from the panels: give it back
        pad = fig.get_layout_engine().get()["h_pad"]
        w, h = fig.get_size_inches()
        fig.set_size_inches(w, h + leg.get_window_extent(fig.canvas.get_renderer()).height / fig.dpi + 2 * pad)
        return leg
    fig.tight_layout()
    renderer = fig.canvas.get_renderer()
    panels = [a for a in fig.axes if a.get_visible()]
    bottom = min(a.get_tightbbox(renderer).transformed(fig.transFigure.inverted()).y0 for a in panels)
    return fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, bottom), **kw)


def letter(i: int) -> str:
    """``"(a)"`` for 0, ``"(b)"`` for 1, ...: the panel letters the captions refer to."""
    return f"({'abcdefghijklmnop'[i]})"


def plain_log(ax, axis: str = "y", subs=(1.0, 2.0, 5.0)) -> None:
    """A log axis labelled 1, 2, 5, 10, 20, ... (``subs`` of each decade) in plain numbers ("0.1",
    "20", not 2×10¹), without minor labels."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    a = ax.yaxis if axis == "y" else ax.xaxis
    a.set_major_locator(LogLocator(subs=subs))
    a.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    a.set_minor_formatter(NullFormatter())
