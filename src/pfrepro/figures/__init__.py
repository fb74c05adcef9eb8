"""Figures of the reproduced papers, one module per paper (``pfrepro.figures.<paper key>``).

Each figure function takes the results of the paper's experiment functions
(:mod:`pfrepro.experiments`) and returns a :class:`matplotlib.figure.Figure`; the chapter
shows it and ``pfrepro run <paper>`` saves it as PNG, so the drawing code exists once.
Every module also has ``tables(results)`` and ``figures(results)``: the paper's tables and
figures from the results of its ``run_all``, which is what the command line saves (see
:mod:`pfrepro.papers`).
"""
from __future__ import annotations

__all__ = ["DPI", "new_figure"]

#: resolution of every figure (the book's minimum)
DPI = 150


def new_figure(*args, **kwargs):
    """``matplotlib.pyplot.subplots`` at the book's resolution; returns ``(fig, axes)``.

    Figures are made through :mod:`matplotlib.pyplot`, so a notebook shows them inline;
    the command line closes each one after saving it.
    """
    import matplotlib.pyplot as plt

    kwargs.setdefault("dpi", DPI)
    return plt.subplots(*args, **kwargs)
