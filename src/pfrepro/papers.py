"""The registry of reproduced papers: what ``pfrepro list`` shows and ``pfrepro run`` runs.

Adding a paper is one :class:`Paper` entry in :data:`PAPERS`. Each paper has three modules:

* ``pfrepro.experiments.<key>`` runs the experiments, readings and sweeps:
  ``run_all(runs=None, seeds=None, executor=None, steps=None) -> results`` (``runs``/``seeds``
  ``None`` mean the paper's own counts and the book's fixed seeds, ``SEEDS`` of the module;
  ``steps(label)`` is called before each experiment, for a progress display). The results
  object has a ``settings`` dict (the runs and seeds it used). The module's ``CHOICES`` are the
  chapter's free choices.
* ``pfrepro.verdicts.<key>`` decides the claims: ``record_claims(reg, results)`` adds every
  claim of the paper to a :class:`~pfrepro.claims.ClaimsRegistry`.
* ``pfrepro.figures.<key>`` draws: ``TABLES``/``FIGURES`` (labels), ``tables(results)`` and
  ``figures(results)`` (label -> DataFrame / matplotlib Figure).

The chapter and the command line both go through :meth:`Paper.run`, so they save the same
claims for the same runs and seeds.

Measured times (wall clock) differ between any two runs, so :meth:`Paper.reproduce` keeps
them out of the tables and figures it returns: the table columns named in
:attr:`Paper.timing_columns` move to :attr:`Reproduction.timings` (one row per cell), and a
figures module's ``timing_figures(results)`` (if it has one) draws the time panels, which
``figures(results)`` then leaves out. Everything else ``pfrepro run`` writes is the same
bytes for the same runs and seeds, serially or spread over processes or a cluster.
"""
from __future__ import annotations

import importlib
import numbers
from dataclasses import dataclass, field

import pandas as pd

from .claims import ClaimsRegistry

__all__ = ["Paper", "PAPERS", "Reproduction", "get_paper", "paper_keys", "resolve_seeds", "split_timings",
           "TIMING_COLUMNS"]

#: the columns of :attr:`Reproduction.timings`
TIMING_COLUMNS = ("table", "row", "column", "value")


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
    timing_columns : tuple
        The measured-time columns of the paper's tables, as pairs
        ``(table label, (column, ...))``: :meth:`reproduce` moves them to
        :attr:`Reproduction.timings`.
    """

    key: str
    aliases: tuple[str, ...]
    chapter: str
    citation: str = ""
    timing_columns: tuple = ()

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

    @property
    def experiments_module(self):
        """``pfrepro.experiments.<key>`` (imported on first use)."""
        return importlib.import_module(f"pfrepro.experiments.{self.key}")

    @property
    def verdicts_module(self):
        """``pfrepro.verdicts.<key>``, the module that decides the paper's claims (``None`` if it has none yet)."""
        try:
            return importlib.import_module(f"pfrepro.verdicts.{self.key}")
        except ModuleNotFoundError as exc:
            if exc.name != f"pfrepro.verdicts.{self.key}":
                raise
            return None

    def run(self, runs=None, seeds=None, executor=None, steps=None):
        """Run every experiment of the paper and decide its claims: ``(results, registry)``.

        The one path from experiments to verdicts: the chapter calls it, and so does
        ``pfrepro run``. ``runs`` replaces every Monte Carlo run count of the paper, ``seeds``
        the fixed seeds (an int: a base, see :func:`resolve_seeds`; a dict: some entries).
        """
        verdicts = self.verdicts_module
        if verdicts is None:
            raise NotImplementedError(f"{self.key} has no pfrepro.verdicts module: its claims are decided nowhere")
        E = self.experiments_module
        results = E.run_all(runs=runs, seeds=seeds, executor=executor, steps=steps)
        reg = ClaimsRegistry(self.key, choices=E.CHOICES)
        verdicts.record_claims(reg, results)
        return results, reg

    def reproduce(self, runs=None, seed=None, executor=None, steps=None) -> "Reproduction":
        """Run the paper's experiments and return its tables, figures and claims (:meth:`run`).

        The measured times are set apart (module docstring): the tables lose their
        :attr:`timing_columns`, which become :attr:`Reproduction.timings`, and the figures
        module's ``timing_figures`` (if any) become :attr:`Reproduction.timing_figures`.
        """
        results, reg = self.run(runs=runs, seeds=seed, executor=executor, steps=steps)
        F = self.figures_module
        tables, timings = split_timings(F.tables(results), dict(self.timing_columns))
        timing_figures = F.timing_figures(results) if callable(getattr(F, "timing_figures", None)) else {}
        return Reproduction(self.key, tables=tables, figures=F.figures(results), claims=reg,
                            settings=dict(results.settings), timings=timings, timing_figures=timing_figures)


_GPFF_TIMES = ("time / GPFF(100)", "batch time / GPFF(100)")
#: every paper the command line knows; add a paper here (one entry)
PAPERS: tuple[Paper, ...] = (
    Paper("gpff_zhang2016", ("gpff", "zhang2016"), "book/20_gpff.md",
          timing_columns=(("Table 1", _GPFF_TIMES), ("Table 2", _GPFF_TIMES))),
    Paper("ekf_pf_li2012", ("li2012", "ekf_pf"), "book/30_ekf_pf.md"),
    Paper("cmspf_ning2011", ("cmspf", "ning2011"), "book/40_cmspf.md",
          timing_columns=(("Table 2", ("time ratio to PF, ours",)),)),
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
    """A paper's regenerated tables (DataFrames), figures (matplotlib Figures) and cell claims.

    ``timings`` holds the measured times taken out of the tables (columns ``table, row,
    column, value``, see :func:`split_timings`) and ``timing_figures`` the figures of measured
    times: they differ between any two runs, the rest does not.
    """

    paper: str
    tables: dict[str, pd.DataFrame]
    figures: dict
    claims: ClaimsRegistry
    settings: dict = field(default_factory=dict)
    timings: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=list(TIMING_COLUMNS)))
    timing_figures: dict = field(default_factory=dict)

    def verdict_counts(self) -> pd.Series:
        """How many claims got each verdict."""
        df = self.claims.to_frame()
        return df["verdict"].value_counts() if len(df) else pd.Series(dtype=int)


def _row_label(key) -> str:
    return " / ".join(str(k) for k in key) if isinstance(key, tuple) else str(key)


def split_timings(tables: dict, timing_columns: dict) -> tuple[dict, pd.DataFrame]:
    """Take the measured-time columns out of a paper's tables.

    Parameters
    ----------
    tables : dict
        Table label -> DataFrame (a figures module's ``tables(results)``).
    timing_columns : dict
        Table label -> the names of its columns that hold measured times.

    Returns
    -------
    tables : dict
        The same tables without those columns (new frames; the others untouched).
    timings : pandas.DataFrame
        One row per removed cell: ``table`` (label), ``row`` (the row's index label, levels
        joined with " / "), ``column`` and ``value``; in table, row and column order.

    Raises
    ------
    KeyError
        If a label or a column named in ``timing_columns`` is not in ``tables`` (the
        declaration has drifted from the figures module).
    """
    out, rows = dict(tables), []
    for label, cols in timing_columns.items():
        if label not in out:
            raise KeyError(f"timing columns are declared for table {label!r}, which the paper does not have "
                           f"(its tables: {list(out)})")
        df = out[label]
        missing = [c for c in cols if c not in df.columns]
        if missing:
            raise KeyError(f"{label}: no timing column(s) {missing}; its columns: {list(df.columns)}")
        for key, row in df[list(cols)].iterrows():
            rows.extend({"table": label, "row": _row_label(key), "column": c, "value": row[c]} for c in cols)
        out[label] = df.drop(columns=list(cols))
    return out, pd.DataFrame(rows, columns=list(TIMING_COLUMNS))


def resolve_seeds(defaults: dict, seeds=None) -> dict:
    """The seeds an experiment module runs with: a new dict, never the module's own.

    ``seeds=None``: ``defaults`` (the book's fixed seeds); an int ``base``: every entry replaced,
    in the dict's order, by ``base``, ``base + 1``, ... (``pfrepro run --seed``); a mapping: the
    named entries replaced (``KeyError`` for a name ``defaults`` does not have).
    """
    out = dict(defaults)
    if seeds is None:
        return out
    if isinstance(seeds, numbers.Integral) and not isinstance(seeds, bool):
        if seeds < 0:
            raise ValueError(f"a base seed must be >= 0, got {seeds}")
        return {k: int(seeds) + i for i, k in enumerate(out)}
    if not hasattr(seeds, "items"):
        raise TypeError(f"seeds must be None, an int base or a mapping name -> seed, got {type(seeds).__name__}")
    unknown = sorted(set(seeds) - set(out))
    if unknown:
        raise KeyError(f"unknown seed name(s) {unknown}; the seeds are {list(out)}")
    out.update({k: int(v) for k, v in seeds.items()})
    return out
