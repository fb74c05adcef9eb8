"""Layout helpers the chapter figure modules share: which drawing is being made (laptop or phone),
one legend below a figure's panels, panel letters and plain log ticks."""
from __future__ import annotations

import numpy as np


def phone() -> bool:
    """Whether the figure is being drawn for the phone (one panel per row, a narrow column)."""
    from ..plotting import current_layout

    layout = current_layout()
    return layout is not None and layout.max_cols == 1


def legend_below(fig, axes, ncol: int = 2, handles=None, labels=None):
    """One legend for the whole figure, below its panels (the entries of every panel, each label
    once, unless ``handles`` and ``labels`` are given), in ``ncol`` columns on the laptop and one
    on the phone. Made after ``tight_layout``, so the panels keep their size and the saved PNG
    (``bbox_inches="tight"``) grows to hold it."""
    axes = [a for a in np.atleast_1d(axes).ravel() if a.get_visible()]
    if handles is None:
        seen = {}
        for ax in axes:
            for h, lab in zip(*ax.get_legend_handles_labels()):
                if not lab.startswith("_") and lab not in seen:
                    seen[lab] = h
        labels, handles = list(seen), list(seen.values())
    if not labels:
        return None
    fig.tight_layout()
    renderer = fig.canvas.get_renderer()
    bottom = min(a.get_tightbbox(renderer).transformed(fig.transFigure.inverted()).y0 for a in axes)
    return fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, bottom),
                      ncol=1 if phone() else min(ncol, len(labels)), frameon=False)


def letter(i: int) -> str:
    """``"(a)"`` for 0, ``"(b)"`` for 1, ...: the panel letters the captions refer to."""
    return f"({'abcdefghijklmnop'[i]})"


def plain_log(ax, axis: str = "y") -> None:
    """A log axis labelled 1, 2, 5, 10, 20, ... in plain numbers (not 2×10¹), without minor labels."""
    from matplotlib.ticker import LogLocator, NullFormatter, ScalarFormatter

    a = ax.yaxis if axis == "y" else ax.xaxis
    a.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    a.set_major_formatter(ScalarFormatter())
    a.set_minor_formatter(NullFormatter())


def choices_cards(choices):
    """The chapter's assumptions table (:func:`pfrepro.choices.choices_table`) as HTML whose rows
    become cards on a phone (:func:`pfrepro.bookinfo.labelled_table_html`, class ``pf-choices``:
    on a laptop a table with a wide "reason" column, on a phone one card per choice) instead of a
    five-column table wrapping one word per line."""
    import html

    from IPython.display import HTML

    from ..bookinfo import labelled_table_html
    from ..choices import choices_table

    t = choices_table(choices)
    return HTML(labelled_table_html(t.map(lambda v: html.escape(str(v))), classes="pf-claims pf-text pf-choices"))
