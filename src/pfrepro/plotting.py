"""One figure style for every chapter of the book.

Each chapter calls :func:`use_book_style` once, right after importing pyplot, so that all
figures share resolution and type sizes: 150 dpi (readable when the browser scales a figure
to the text column, sharp on high-density screens) and type sizes that stay legible at the
column width. Only rcParams are set; nothing else about a figure changes.
"""
from __future__ import annotations

import matplotlib as mpl

__all__ = ["BOOK_DPI", "BOOK_STYLE", "use_book_style", "log_ylim_from"]

#: resolution of every figure in the book (the inline backend renders at ``figure.dpi``)
BOOK_DPI = 150

BOOK_STYLE = {
    "figure.dpi": BOOK_DPI,
    "savefig.dpi": BOOK_DPI,
    "font.size": 10,
    "axes.titlesize": 10,
    "axes.labelsize": 10,
    "legend.fontsize": 8.5,
    "xtick.labelsize": 9,
    "ytick.labelsize": 9,
    "legend.framealpha": 0.85,
}


def use_book_style() -> dict:
    """Apply :data:`BOOK_STYLE` to matplotlib's rcParams; returns the settings applied."""
    mpl.rcParams.update(BOOK_STYLE)
    return dict(BOOK_STYLE)


def log_ylim_from(ax, *curves, pad: float = 2.0) -> tuple[float, float]:
    """Set a log axis' y-limits to span ``curves`` (arrays) with a factor ``pad`` of margin.

    For panels where a reference curve (e.g. a bound that starts at zero) would stretch
    the axis over decades no filter visits: the limits follow the curves that matter and
    the reference is clipped. Non-finite and non-positive values are ignored.
    """
    import numpy as np

    vals = np.concatenate([np.ravel(np.asarray(c, dtype=float)) for c in curves])
    vals = vals[np.isfinite(vals) & (vals > 0)]
    if vals.size == 0:
        raise ValueError("log_ylim_from: no finite positive values in curves")
    lo, hi = float(vals.min()) / pad, float(vals.max()) * pad
    ax.set_ylim(lo, hi)
    return lo, hi
