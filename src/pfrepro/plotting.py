"""One figure style for every chapter of the book.

Each chapter calls :func:`use_book_style` once, right after importing pyplot, so that all
figures share resolution and type sizes: 150 dpi (readable when the browser scales a figure
to the text column, sharp on high-density screens) and type sizes that stay legible at the
column width. Only rcParams are set; nothing else about a figure changes.
"""
from __future__ import annotations

import matplotlib as mpl

__all__ = ["BOOK_DPI", "BOOK_STYLE", "use_book_style", "log_ylim_from", "COLUMN_PX", "MIN_FONT_PT",
           "MIN_TEXT_PX", "max_figure_width", "rendered_text_px", "METHOD_COLORS", "REFERENCE_COLOR",
           "method_color", "SERIES_COLORS"]

#: resolution of every figure in the book (the inline backend renders at ``figure.dpi``)
BOOK_DPI = 150

#: the matplotlib rcParams every figure of the book is drawn with
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


#: width in CSS px at which a figure in a cell output is shown (the book's theme at a 1366 px wide
#: window, the 757 px text column less the output's padding; measured by tests/browser/check_pages.py)
COLUMN_PX = 741
#: smallest type size (points) any figure of the book may use (ticks, legends, annotations)
MIN_FONT_PT = 8.0
#: smallest size (CSS px) that figure text may have on screen at :data:`COLUMN_PX`
MIN_TEXT_PX = 8.0


def rendered_text_px(size_pt: float, width_in: float, dpi: float = BOOK_DPI,
                     column_px: float = COLUMN_PX) -> float:
    """On-screen size (CSS px) of ``size_pt`` text in a ``width_in`` inch wide figure.

    The figure is rendered at ``dpi`` (``width_in * dpi`` pixels) and the browser scales it down
    to the column when it is wider: the text is ``size_pt * dpi / 72`` pixels times
    ``min(1, column_px / (width_in * dpi))``.
    """
    return size_pt * dpi / 72.0 * min(1.0, column_px / (width_in * dpi))


def max_figure_width(size_pt: float = MIN_FONT_PT, min_px: float = MIN_TEXT_PX,
                     column_px: float = COLUMN_PX) -> float:
    """Widest figure (inches) in which ``size_pt`` text is still ``min_px`` on screen."""
    return size_pt * column_px / (72.0 * min_px)


#: one colour per method across the whole book (the reference / exact posterior is black);
#: variants of a method keep its colour and differ by line style or marker
METHOD_COLORS = {
    "PF": "#1f77b4",          # bootstrap particle filter (blue)
    "CMS-PF": "#ff7f0e",      # orange
    "DPF": "#2ca02c",         # green
    "EKF": "#d62728",         # red
    "UKF": "#9467bd",         # purple
    "DEKF": "#8c564b",        # brown
    "Liu-West": "#e377c2",    # pink
    "SIS": "#7f7f7f",         # grey
    "ESPF": "#bcbd22",        # olive
    "GPFF": "#17becf",        # cyan
    "IMMPF": "#393b79",       # dark blue
    "IMMPFOR": "#ad494a",     # dark red
    "IMM-EKF": "#d62728",     # the EKF's colour
    "IMM-UKF": "#9467bd",     # the UKF's colour
    "KF": "#1b9e77",          # teal
    "grid": "#000000",        # the exact reference
    # today's methods (synthesis, "Against today's methods")
    "APF": "#8c6d31",         # ochre
    "RPF": "#637939",         # moss
    "EKF-prop. PF": "#7b4173",  # plum
    "UKF-prop. PF": "#a55194",  # light plum
    "PFPF-EDH": "#e7969c",    # rose
    "PFPF-LEDH": "#843c39",   # maroon
    "SMC²": "#5254a3",        # indigo
    "JMPF": "#6b6ecf",        # periwinkle
}
#: colour of references (exact posterior, grid filter, truth)
REFERENCE_COLOR = "#000000"

_ALIASES = (("liu–west", "Liu-West"), ("liu west", "Liu-West"), ("exact", "grid"), ("reference", "grid"),
            ("cmspf", "CMS-PF"), ("sir", "PF"), ("bootstrap", "PF"), ("immpfor", "IMMPFOR"))


#: colours for series that are not methods (initial guesses, parameter values, readings), from
#: Paul Tol's "bright" scheme, distinct from each other and readable by colour-blind readers
SERIES_COLORS = ("#4477aa", "#ee6677", "#228833", "#ccbb44", "#66ccee", "#aa3377", "#bbbbbb")


def method_color(name: str, default: str | None = None) -> str:
    """The book's colour for the method a label names ("PF (500)", "PF, published", "CMS-PF (ours)",
    "IMM-EKF", "exact posterior mean" -> the reference's black).

    The longest method name the label starts with wins ("IMMPFOR ..." over "IMMPF", "DEKF" over
    "DPF"); labels naming no method of :data:`METHOD_COLORS` give ``default``, or raise
    ``KeyError`` without one.
    """
    low = name.strip().lower()
    for alias, key in _ALIASES:
        if low.startswith(alias):
            return METHOD_COLORS[key]
    best = max((k for k in METHOD_COLORS if low.startswith(k.lower())), key=len, default=None)
    if best is None:
        if default is not None:
            return default
        raise KeyError(f"no book colour for a method named {name!r}")
    return METHOD_COLORS[best]


def use_book_style() -> dict:
    """Apply :data:`BOOK_STYLE` to matplotlib's rcParams; returns the settings applied.

    Also shows the notebook's tables the book's way (:func:`pfrepro.prose.use_book_tables`:
    missing values as "—", no cell cut with "...").
    """
    from .prose import use_book_tables

    mpl.rcParams.update(BOOK_STYLE)
    use_book_tables()
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
