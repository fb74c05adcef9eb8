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
"""
from __future__ import annotations

import importlib
import numbers
from dataclasses import dataclass, field

import pandas as pd

from .claims import ClaimsRegistry

__all__ = ["Paper", "PAPERS", "Reproduction", "get_paper", "paper_keys", "resolve_seeds"]


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
        """Run the paper's experiments and return its tables, figures and claims (:meth:`run`)."""
        results, reg = self.run(runs=runs, seeds=seed, executor=executor, steps=steps)
        F = self.figures_module
        return Reproduction(self.key, tables=F.tables(results), figures=F.figures(results), claims=reg,
                            settings=dict(results.settings))


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
