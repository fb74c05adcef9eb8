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


def plain_log(ax, axis: str = "y", subs=(1.0, 2.0, 5.0)) -> None:
    """A log axis labelled 1, 2, 5, 10, 20, ... (``subs`` of each decade) in plain numbers ("0.1",
    "20", not 2×10¹), without minor labels."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    a = ax.yaxis if axis == "y" else ax.xaxis
    a.set_major_locator(LogLocator(subs=subs))
    a.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
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
    return HTML(labelled_table_html(t.map(lambda v: html.escape(reader_text(str(v)))),
                                    classes="pf-claims pf-text pf-choices"))


_SUB = str.maketrans("0123456789k+-=()aeioruvxnmpsthlj", "₀₁₂₃₄₅₆₇₈₉ₖ₊₋₌₍₎ₐₑᵢₒᵣᵤᵥₓₙₘₚₛₜₕₗⱼ")
_SUP = str.maketrans("0123456789i+-nT", "⁰¹²³⁴⁵⁶⁷⁸⁹ⁱ⁺⁻ⁿᵀ")


def reader_text(text: str) -> str:
    """Plain-text formulas and names as a reader reads them: ``x_k`` -> ``xₖ``, ``x_{k-1}`` ->
    ``xₖ₋₁``, ``x_(k-1)`` -> ``xₖ₋₁``, ``y_1:k`` -> ``y₁:ₖ``, ``x_k^i`` -> ``xₖⁱ``, ``sigma_w2`` ->
    ``sigma w2`` (a name with underscores reads as words). Only for display: the claims and
    choices keep their text."""
    import re

    def sub(m):
        body = m.group(2) or m.group(3) or m.group(4)
        if all(ch in "0123456789k+-=()aeioruvxnmpsthlj:|" for ch in body):
            return m.group(1).replace("~", "\u0303") + "".join(ch if ch in ":|" else ch.translate(_SUB) for ch in body)
        return m.group(0)

    # one-letter symbols with a subscript: x_k, x_{k-1}, x_(k-1), y_1:k, B_k
    out = re.sub(r"(?<![A-Za-z0-9_])([A-Za-zσηαβθ](?:\u0302|~)?)_(?:\{([^{}]+)\}|\(([^()]+)\)|([0-9k]+(?::[0-9k]+)?|th))(?![A-Za-z_])", sub, text)
    out = re.sub(r"\^(\{[^{}]+\}|[0-9iTn])", lambda m: m.group(1).strip("{}").translate(_SUP)
                 if all(c in "0123456789i+-nT" for c in m.group(1).strip("{}")) else m.group(0), out)
    # remaining snake_case names read as words
    return re.sub(r"\b([A-Za-z][A-Za-z0-9]*(?:_[A-Za-z0-9]+)+)\b", lambda m: m.group(1).replace("_", " "), out)

