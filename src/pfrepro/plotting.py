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
           "method_color", "SERIES_COLORS", "Layout", "DESKTOP", "PHONE", "PHONE_MEDIA", "figure_layout",
           "current_layout", "smallest_text_pt", "ResponsiveFigure", "responsive", "show_figure"]

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


#: Width in CSS px at which a figure in a cell output is shown in a 1366 px wide window (the
#: book's 757 px text column less the output's padding).
COLUMN_PX = 741
#: Smallest type size (points) of a figure drawn once, as the command line saves it; the book's
#: figures are drawn per layout at ``Layout.min_pt`` (10.5 pt and 12 pt).
MIN_FONT_PT = 8.0
#: Smallest size (CSS px) that the text of a figure drawn once has at :data:`COLUMN_PX`.
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
    "UT-prop. PF": "#a55194",   # light plum
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


# ---- figures made for the width they are read at -------------------------------------------
# A figure is read at two widths: in the text column of a laptop (about 745 CSS px) and of a
# phone (about 350 CSS px). Text in a PNG shrinks with the image, so one drawing cannot have
# body-sized text at both: every book figure is drawn twice, once per layout, and the page's
# <picture> element lets the browser pick the drawing for its width.

from contextlib import contextmanager  # noqa: E402
from dataclasses import dataclass  # noqa: E402


@dataclass(frozen=True)
class Layout:
    """How a figure is drawn for one reading width.

    Attributes
    ----------
    name : str
        ``"desktop"`` or ``"phone"``.
    width_in : float
        Widest figure (inches, at :data:`BOOK_DPI`) of this layout; :func:`responsive` narrows a
        drawing that comes out wider (legends outside the axes, long labels).
    max_cols : int
        Most panels side by side; :func:`pfrepro.figures.new_figure` reflows a wider grid.
    min_pt : float
        Type size (points) of every text of the style; shown at ``width_in`` in the layout's
        column, it is at least the body text's 16 CSS px.
    """

    name: str
    width_in: float
    max_cols: int
    min_pt: float

    def rc(self) -> dict:
        """The rcParams of the layout: :data:`BOOK_STYLE` with every type size at ``min_pt``."""
        rc = dict(BOOK_STYLE)
        for key in ("font.size", "axes.titlesize", "axes.labelsize", "legend.fontsize",
                    "legend.title_fontsize", "xtick.labelsize", "ytick.labelsize",
                    "figure.titlesize", "figure.labelsize"):
            rc[key] = self.min_pt
        return rc


#: The laptop layout. 745 CSS px of column show a 6.5 in (975 px) figure at 0.76, so 10.5 pt
#: text (21.9 px in the PNG) is 16.7 CSS px on screen, the size of the body text
DESKTOP = Layout("desktop", width_in=6.5, max_cols=2, min_pt=10.5)
#: The phone layout, one panel per row; about 350 CSS px of column show a 3.0 in (450 px)
#: figure at 0.78, so 12 pt text (25 px in the PNG) is 19 CSS px on screen
PHONE = Layout("phone", width_in=3.0, max_cols=1, min_pt=12.0)
#: The media query under which the browser shows the phone drawing
PHONE_MEDIA = "(max-width: 720px)"

_LAYOUTS: list[Layout] = []


@contextmanager
def figure_layout(layout: Layout):
    """Draw the figures made inside the block for ``layout`` (its panels per row and type sizes).

    Yields
    ------
    Layout
        ``layout``, current until the block ends (:func:`current_layout`).
    """
    if not isinstance(layout, Layout):
        raise TypeError(f"figure_layout needs a Layout (DESKTOP or PHONE), got {type(layout).__name__}")
    _LAYOUTS.append(layout)
    try:
        with mpl.rc_context(layout.rc()):
            yield layout
    finally:
        _LAYOUTS.pop()


def current_layout() -> Layout | None:
    """The layout figures are being drawn for, or ``None`` outside :func:`figure_layout`
    (the command line's PNGs: each figure at the size its code asks for)."""
    return _LAYOUTS[-1] if _LAYOUTS else None


def smallest_text_pt(fig) -> float:
    """Smallest type size (points) among the visible, non-empty texts of a drawn figure
    (tick labels, labels, titles, legends, annotations); ``inf`` for a figure without text."""
    from matplotlib.text import Text

    fig.canvas.draw()
    sizes = []
    for t in fig.findobj(Text):
        if not t.get_visible() or not t.get_text().strip():
            continue
        ax = getattr(t, "axes", None)
        if ax is not None and not ax.get_visible():
            continue
        sizes.append(float(t.get_fontsize()))
    return min(sizes, default=float("inf"))


def _tight_width_in(fig) -> float:
    renderer = fig.canvas.get_renderer()
    return fig.get_tightbbox(renderer).width  # inches


def _fit_width(fig, width_in: float) -> None:
    """Narrow a figure whose drawn extent (with legends and labels outside the axes) is wider than
    ``width_in``: the axes give up the room, the type keeps its size."""
    import warnings

    for _ in range(3):
        fig.canvas.draw()
        wide = _tight_width_in(fig)
        if wide <= width_in * 1.01:
            return
        w, h = fig.get_size_inches()
        fig.set_size_inches(max(w * width_in / wide, 1.0), h)
        if fig.get_layout_engine() is None:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fig.tight_layout()


def _png(fig) -> bytes:
    import io

    buf = io.BytesIO()
    # bbox_inches="tight", like the notebook's inline backend: what the reader sees
    fig.savefig(buf, format="png", dpi=BOOK_DPI, bbox_inches="tight")
    return buf.getvalue()


class ResponsiveFigure:
    """A figure drawn for the laptop and for the phone, shown as one ``<picture>``.

    Made by :func:`responsive`. In a notebook or a book page it displays as HTML: a
    ``<picture>`` whose ``<source>`` (the phone drawing) the browser uses under
    :data:`PHONE_MEDIA`, the desktop drawing otherwise, both inline as PNG data, and an
    "Enlarge" button (book/_static/pfrepro-figures.js opens the desktop drawing at full size).
    The ``img`` carries ``data-dpi``, ``data-min-pt`` and ``data-phone-min-pt`` (the smallest
    type actually drawn in each), from which the browser check computes the on-screen text size.

    Attributes
    ----------
    desktop_png : bytes
        The desktop drawing.
    phone_png : bytes
        The phone drawing.
    desktop_min_pt : float
        Smallest type size in the desktop drawing.
    phone_min_pt : float
        Smallest type size in the phone drawing.
    alt : str
        The text alternative of the figure.
    """

    def __init__(self, desktop_png: bytes, phone_png: bytes, desktop_min_pt: float,
                 phone_min_pt: float, alt: str):
        self.desktop_png = desktop_png
        self.phone_png = phone_png
        self.desktop_min_pt = desktop_min_pt
        self.phone_min_pt = phone_min_pt
        self.alt = alt

    def _repr_html_(self) -> str:
        import base64
        import html

        def uri(png):
            return "data:image/png;base64," + base64.b64encode(png).decode("ascii")

        return (
            '<div class="pf-figure"><picture>'
            f'<source media="{PHONE_MEDIA}" srcset="{uri(self.phone_png)}">'
            f'<img class="pf-figure-img" src="{uri(self.desktop_png)}" alt="{html.escape(self.alt)}" '
            f'data-dpi="{BOOK_DPI}" data-min-pt="{self.desktop_min_pt:.2f}" '
            f'data-phone-min-pt="{self.phone_min_pt:.2f}">'
            '</picture><button type="button" class="pf-enlarge">Enlarge</button></div>')

    def _repr_png_(self) -> bytes:
        return self.desktop_png

    def __repr__(self) -> str:
        return f"<ResponsiveFigure: {self.alt[:60]!r}>"


def responsive(draw, *args, alt: str, **kwargs) -> ResponsiveFigure:
    """Draw ``draw(*args, **kwargs)`` once for :data:`DESKTOP` and once for :data:`PHONE`.

    ``draw`` returns a matplotlib figure made with :func:`pfrepro.figures.new_figure` (which
    reflows its panels for the layout); each drawing is narrowed to its layout's width if its
    legends or labels stick out, saved as PNG and closed. ``alt`` (required, non-empty) says
    what the figure shows, for readers who cannot see it.
    """
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    if not callable(draw):
        raise TypeError("responsive needs a function that draws the figure (called once per "
                        f"layout), got {type(draw).__name__}")
    if not isinstance(alt, str) or not alt.strip():
        raise ValueError("responsive needs alt=: a sentence saying what the figure shows")
    out = {}
    for layout in (DESKTOP, PHONE):
        with figure_layout(layout):
            fig = draw(*args, **kwargs)
            if not isinstance(fig, Figure):
                raise TypeError(f"{getattr(draw, '__name__', 'draw')} must return a matplotlib "
                                f"Figure, got {type(fig).__name__}")
            try:
                _fit_width(fig, layout.width_in)
                out[layout.name] = (_png(fig), smallest_text_pt(fig))
            finally:
                plt.close(fig)
    return ResponsiveFigure(out["desktop"][0], out["phone"][0], out["desktop"][1], out["phone"][1], alt)


def show_figure(draw, *args, alt: str, **kwargs) -> None:
    """Display :func:`responsive` ``(draw, *args, alt=alt, **kwargs)`` in the notebook (a
    chapter's figure cell: its ``mystnb.figure`` metadata gives the caption). Returns nothing,
    so the cell shows the figure once."""
    from IPython.display import display

    display(responsive(draw, *args, alt=alt, **kwargs))
