"""The registry of reproduced papers: what ``pfrepro list`` shows and ``pfrepro run`` runs.

Adding a paper is one :class:`Paper` entry in :data:`PAPERS`. The entry names the paper's
experiment module ``pfrepro.experiments.<key>`` (the functions its chapter calls) and its
figure module ``pfrepro.figures.<key>``, which must define

* ``TABLES`` and ``FIGURES``: the labels of the tables and figures it regenerates, and
* ``reproduce(runs=None, seed=None, executor=None, steps=None) -> Reproduction``: the
  paper's tables and figures from the experiment module's functions (``runs``/``seed``
  ``None`` mean the paper's own counts and our fixed seeds; ``steps(label)`` is called
  before each experiment, for a progress display).
"""
from __future__ import annotations

import contextlib
import importlib
import inspect
import math
import numbers
from dataclasses import dataclass, field

import pandas as pd

from .claims import ClaimsRegistry

__all__ = ["Paper", "PAPERS", "Reproduction", "get_paper", "paper_keys", "call_with_executor", "cell_claims", "override_seeds"]


@dataclass(frozen=True)
class Paper:
    """One reproduced paper.

    Attributes
    ----------
    key : str
        The experiment module's name (``pfrepro.experiments.<key>``), also the claims' paper key.
    aliases : tuple
        Short names (str) accepted by ``pfrepro run``.
    chapter : str
        The book chapter's source file.
    citation : str
        Authors, year, short title (optional; default: the entry of
        :data:`pfrepro.published.PAPERS`).
    """

    key: str
    aliases: tuple[str, ...]
    chapter: str
    citation: str = ""

    def __post_init__(self):
        if not self.citation:
            from .published import PAPERS as CITATIONS

            object.__setattr__(self, "citation", CITATIONS.get(self.key, self.key))

    @property
    def figures_module(self):
        """``pfrepro.figures.<key>`` (imported on first use)."""
        return importlib.import_module(f"pfrepro.figures.{self.key}")

    @property
    def tables(self) -> tuple[str, ...]:
        """Names of the tables the paper's figures module reproduces (its ``TABLES``)."""
        return tuple(self.figures_module.TABLES)

    @property
    def figures(self) -> tuple[str, ...]:
        """Names of the figures the paper's figures module reproduces (its ``FIGURES``)."""
        return tuple(self.figures_module.FIGURES)

    def reproduce(self, runs=None, seed=None, executor=None, steps=None) -> "Reproduction":
        """Run the paper's experiments and return its tables and figures."""
        return self.figures_module.reproduce(runs=runs, seed=seed, executor=executor, steps=steps)


#: every paper the command line knows; add a paper here (one entry)
PAPERS: tuple[Paper, ...] = (
    Paper("gpff_zhang2016", ("gpff", "zhang2016"), "book/20_gpff.md"),
    Paper("ekf_pf_li2012", ("li2012", "ekf_pf"), "book/30_ekf_pf.md"),
    Paper("cmspf_ning2011", ("cmspf", "ning2011"), "book/40_cmspf.md"),
    Paper("dpf_hou2008", ("dpf", "hou2008"), "book/50_dpf.md"),
    Paper("immpfor_zhou2017", ("immpf", "immpfor", "zhou2017"), "book/60_immpf.md"),
)


def paper_keys() -> dict[str, Paper]:
    """Every accepted name (key and aliases) -> its :class:`Paper`."""
    out = {}
    for p in PAPERS:
        for name in (p.key, *p.aliases):
            if name in out:
                raise RuntimeError(f"paper name {name!r} is used twice in PAPERS")
            out[name] = p
    return out


def get_paper(name: str) -> Paper:
    """The paper called ``name`` (key or alias, case-insensitive); ``KeyError`` names the choices."""
    keys = paper_keys()
    p = keys.get(str(name).lower())
    if p is None:
        raise KeyError(f"unknown paper {name!r}; choose from {', '.join(sorted(keys))}")
    return p


@dataclass
class Reproduction:
    """A paper's regenerated tables (DataFrames), figures (matplotlib Figures) and cell claims."""

    paper: str
    tables: dict[str, pd.DataFrame]
    figures: dict
    claims: ClaimsRegistry
    settings: dict = field(default_factory=dict)

    def verdict_counts(self) -> pd.Series:
        """How many claims got each verdict."""
        df = self.claims.to_frame()
        return df["verdict"].value_counts() if len(df) else pd.Series(dtype=int)


def call_with_executor(fn, *args, executor=None, **kwargs):
    """``fn(*args, **kwargs)``, passing ``executor=`` only if ``fn`` accepts it and it is not None."""
    if executor is not None:
        try:
            params = inspect.signature(fn).parameters
        except (TypeError, ValueError):  # builtins: no signature
            params = {}
        if "executor" in params or any(p.kind is p.VAR_KEYWORD for p in params.values()):
            kwargs["executor"] = executor
    return fn(*args, **kwargs)


def cell_claims(paper: str, table: pd.DataFrame, claim_id, text, source: str, *, published="published",
                ours="ours", se="se", registry: ClaimsRegistry | None = None) -> ClaimsRegistry:
    """A claim per table cell that has a published value: published vs ours within 2 se or 10 %.

    ``claim_id`` and ``text`` are functions of the row. Rows without a finite published
    value are skipped. The verdict is :func:`pfrepro.claims.verdict`'s, as in the chapter.
    """
    reg = registry if registry is not None else ClaimsRegistry(paper)
    for _, row in table.reset_index().iterrows():
        p = row.get(published)
        if not isinstance(p, numbers.Real) or isinstance(p, bool) or not math.isfinite(p):
            continue
        reg.add(claim_id(row), text(row), published=float(p), reproduced=float(row[ours]),
                se=float(row[se]), source=source)
    return reg


@contextlib.contextmanager
def override_seeds(seeds: dict, base: int | None):
    """Temporarily set the entries of an experiment module's ``SEEDS`` dict to ``base``, ``base + 1`` and so on.

    The entries are set in the dict's order; ``base=None`` leaves them unchanged. For experiment functions that
    read their seed from the module's table of fixed seeds.

    Yields
    ------
    dict
        ``seeds``, overridden until the ``with`` block ends (then restored).
    """
    if base is None:
        yield seeds
        return
    saved = dict(seeds)
    try:
        for i, k in enumerate(saved):
            seeds[k] = int(base) + i
        yield seeds
    finally:
        seeds.clear()
        seeds.update(saved)
