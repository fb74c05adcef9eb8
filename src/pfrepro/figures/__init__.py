"""Figures of the reproduced papers, one module per paper (``pfrepro.figures.<paper key>``).

Each figure function takes the results of the paper's experiment functions
(:mod:`pfrepro.experiments`) and returns a :class:`matplotlib.figure.Figure`; the chapter
shows it (drawn for the laptop and for the phone, :func:`pfrepro.plotting.show_figure`) and
``pfrepro run <paper>`` saves it as PNG, so the drawing code exists once.
One legend for a whole figure, below its panels and fitted to the width the figure is drawn for,
is :func:`legend_below`. Every module also has ``tables(results)`` and ``figures(results)``: the paper's tables and
figures from the results of its ``run_all``, which is what the command line saves (see
:mod:`pfrepro.papers`).
"""
from __future__ import annotations

import math

__all__ = ["DPI", "new_figure", "legend_below", "legend_columns"]

from ._layout import legend_below, legend_columns  # noqa: E402  (re-exported: the figures' one legend helper)

#: resolution of every figure (the book's minimum)
DPI = 150

#: the tallest a panel may be relative to its width once reflowed, and the flattest
_PANEL_ASPECT = (0.45, 0.9)


def new_figure(nrows: int = 1, ncols: int = 1, *, figsize=None, sharex=False, sharey=False,
               squeeze: bool = True, **kwargs):
    """``matplotlib.pyplot.subplots`` at the book's resolution; returns ``(fig, axes)``.

    Inside :func:`pfrepro.plotting.figure_layout` (how the book draws every figure twice, for
    the laptop and for the phone) the ``nrows`` × ``ncols`` panels are reflowed to at most the
    layout's panels per row and its width, keeping each panel's shape: a 1 × 3 row becomes
    two rows of two on a laptop (the fourth place left empty) and a column of three on a phone.
    ``axes`` keeps the shape the caller asked for (``axes[0, 2]`` is still the third panel), so
    figure code is written once. ``sharex``/``sharey`` keep their meaning (``"row"``/``"col"``
    refer to the requested grid). Outside a layout the figure is made as asked.

    Figures are made through :mod:`matplotlib.pyplot`, so a notebook shows them inline;
    the command line closes each one after saving it.
    """
    import matplotlib.pyplot as plt
    import numpy as np

    from ..plotting import current_layout

    kwargs.setdefault("dpi", DPI)
    layout = current_layout()
    if nrows < 1 or ncols < 1:
        raise ValueError(f"new_figure needs nrows, ncols >= 1, got {nrows}, {ncols}")
    if layout is None:
        return plt.subplots(nrows, ncols, figsize=figsize, sharex=sharex, sharey=sharey,
                            squeeze=squeeze, **kwargs)
    w0, h0 = figsize if figsize is not None else plt.rcParams["figure.figsize"]
    n = nrows * ncols
    cols = ncols if ncols <= layout.max_cols else layout.max_cols
    rows = math.ceil(n / cols)
    aspect = (h0 / nrows) / (w0 / ncols)  # panel height / width as the caller drew it
    # a phone layout always takes its full width; a laptop one at most its width
    width = min(w0 * cols / ncols, layout.width_in) if layout.max_cols > 1 else layout.width_in
    lo, hi = _PANEL_ASPECT
    panel_w = width / cols
    panel_h = panel_w * min(max(aspect, lo), hi) if cols < ncols or layout.max_cols == 1 else panel_w * aspect
    gridspec_kw = dict(kwargs.pop("gridspec_kw", None) or {})
    if cols != ncols:
        gridspec_kw.pop("width_ratios", None)
    if rows != nrows:
        gridspec_kw.pop("height_ratios", None)
    share_all = {True: True, "all": True}
    fig, grid = plt.subplots(rows, cols, figsize=(width, panel_h * rows),
                             sharex=share_all.get(sharex, False), sharey=share_all.get(sharey, False),
                             squeeze=False, gridspec_kw=gridspec_kw or None, **kwargs)
    flat = grid.ravel()
    for ax in flat[n:]:
        ax.remove()  # the empty places of the last row
    axes = np.empty((nrows, ncols), dtype=object)
    for i in range(n):
        axes.flat[i] = flat[i]
    # "row" / "col" sharing refers to the grid the caller asked for
    for kind, how in (("x", sharex), ("y", sharey)):
        if how in ("row", "col"):
            groups = axes if how == "row" else axes.T
            for group in groups:
                for ax in group[1:]:
                    getattr(ax, f"share{kind}")(group[0])
    if squeeze:
        if n == 1:
            return fig, axes[0, 0]
        if nrows == 1 or ncols == 1:
            return fig, axes.ravel()
    return fig, axes
