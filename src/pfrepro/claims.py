"""Claims registry and the one verdict rule used by every chapter.

A chapter records each claim of its paper as a :class:`Claim` with the
published value (if the paper gives one), our reproduced value, our Monte Carlo
uncertainty (a standard error) and, where the claim is about an ordering or a
trend, whether that statement holds in our runs (computed by code, never
typed). :func:`verdict` turns those numbers into one of five verdicts:

``reproduced``
    a numeric claim whose published value lies within ``Z_CRIT`` combined standard
    errors of ours (``|ours - published| <= Z_CRIT * sqrt(se**2 + published_se**2)``,
    where ``published_se`` is the paper's own standard error when it prints a spread
    or per-run rows), or within the claim's stated relative tolerance (default 10 %);
    or a purely qualitative claim (no published number) whose statement holds.
``qualitatively reproduced``
    the numbers do not match, but the claim's ordering/trend holds.
``not reproduced``
    neither: our honest run contradicts the claim.
``not checkable``
    the paper gives nothing we can compare with (no number and no testable
    statement).
``inconclusive``
    the evidence does not decide, always with its cause (``CAUSES``): the admissible
    readings of the paper disagree (*depends on the reading*), the interval holds both no
    effect and the effect that matters (*too few runs*, with the runs a power plan says would
    decide it), the difference is shown smaller than the claim's stated margin (*tie within the
    stated margin*), or a cost count does not decide.

Ordering claims ("A beats B") are decided on paired differences over common
random numbers: the chapter passes ``diff``, the mean over runs of a per-run
difference oriented so that the claim asserts ``diff > 0`` (e.g. RMSE of B minus
RMSE of A, on the same truths), its standard error ``diff_se``
(:func:`pfrepro.stats.paired_difference`) and the ``runs`` behind it. The direction is shown if
``diff > Z_CRIT * diff_se`` and reversed if ``diff < -Z_CRIT * diff_se``. Where the paper printed
both sides of the comparison, ``effect`` (the printed effect in ``diff``'s units) makes the rule
test the size too (:func:`judge_ordering`, the truth table of CONTRIBUTING.md); elsewhere ``margin``
states the smallest effect of interest up front.

Cost claims (``basis="count"``) are decided on a deterministic count of what each
filter asks of its model (:mod:`pfrepro.cost`), which does not move with machine
load; the published number (a ratio of the paper's seconds) and our measured time
are context and are not matched numerically: ``qualitative`` is the count's answer,
and ``None`` (the count does not decide) gives ``inconclusive``.

A conclusion that depends on an ambiguous reading of the paper is judged under every
admissible reading: ``reading_diffs`` (reading -> ``(diff, se, runs)``) for an ordering,
``readings`` (reading -> True / False / None) for a yes/no statement, ``reading_values``
(reading -> ``(ours, se)``) for a published number; ``excluded`` names readings the paper's own
text or numbers rule out (shown, not counted). :func:`combine_readings` makes one verdict of
them. Which free choices a claim rests on is declared in ``depends_on`` and checked against
the chapter's assumptions table (:mod:`pfrepro.choices`). An absolute number that the paper's
unpublished settings decide passes ``not_checkable="<why>"``: its verdict is ``not checkable``
whatever the numbers.

:func:`claims_table` turns a chapter's claims (or the scorecard's) into the compact
table every page shows: the claim, ours ± SE, published (± its SE), what was judged
(the value, the ordering or a statement), the verdict and the test that was applied.

Each chapter saves its claims to ``<claims dir>/<paper>.json``; the scorecard
page gathers all of them. The claims directory is ``$PFREPRO_CLAIMS_DIR`` or
``./_claims`` relative to the working directory of the notebook (``book/``).
"""
from __future__ import annotations

import json
import math
import numbers
import os
from dataclasses import asdict, dataclass
from pathlib import Path

import pandas as pd

# the paired-comparison statistics live in pfrepro.stats; re-exported here, where chapters found them
from .stats import CommonRunsError, common_runs, paired_difference

__all__ = ["Claim", "ClaimsRegistry", "verdict", "judge", "judge_ordering", "combine_readings", "Judgement",
           "CAUSES", "CAUSE_READING", "CAUSE_RUNS", "CAUSE_TIE", "CAUSE_COUNT", "VERDICTS", "claims_dir", "load_all_claims",
           "DEFAULT_REL_TOL", "Z_CRIT", "ordering_holds", "weakest_ordering",
           "readings_hold", "claims_table", "causes_table", "inconclusive_table", "cause_text", "as_claims", "plan_problems", "BASES", "number_matches", "check_saved_claims",
           "VERDICT_HREF", "verdict_html"]

VERDICTS = ("reproduced", "qualitatively reproduced", "not reproduced", "not checkable", "inconclusive")
#: Where the book defines the verdict words (the scorecard's section labelled ``verdict-scale``),
#: relative to a page of ``book/`` (every chapter, the introduction and the scorecard itself).
VERDICT_HREF = "99_scorecard.html#verdict-scale"
#: relative tolerance for numeric claims when none is stated
DEFAULT_REL_TOL = 0.10
#: a published value within Z_CRIT standard errors of ours counts as inside our uncertainty
Z_CRIT = 2.0
#: The bases a claim's verdict can rest on. ``""`` means numbers or orderings (the default),
#: ``"count"`` a cost claim decided on a deterministic cost count (see :mod:`pfrepro.cost`).
BASES = ("", "count")


def _isnum(v) -> bool:
    # numpy scalars (float32, int64, ...) are numbers too; booleans are not
    return isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isfinite(v)


def ordering_holds(diff, diff_se):
    """True / False / None (undecided) for an ordering asserting ``diff > 0`` (see module docstring)."""
    if not (_isnum(diff) and _isnum(diff_se)) or diff_se < 0:
        raise ValueError(f"ordering needs finite diff and diff_se >= 0, got {diff!r}, {diff_se!r}")
    if diff > Z_CRIT * diff_se:
        return True
    if diff < -Z_CRIT * diff_se:
        return False
    return None


def _z(diff, diff_se):
    if diff_se > 0:
        return diff / diff_se
    return math.copysign(math.inf, diff) if diff != 0 else 0.0


def weakest_ordering(pairs):
    """The ``(diff, diff_se)`` pair with the smallest ``diff / diff_se`` among ``pairs``.

    A claim that asserts several orderings at once ("A beats B, C and D", "in every
    component") holds if every one of them holds; the weakest pair decides it: it
    holds iff all hold, is contradicted iff at least one is contradicted, and is
    undecided otherwise. ``pairs`` is an iterable of ``(diff, diff_se)``.
    """
    pairs = [(float(d), float(s)) for d, s in pairs]
    if not pairs:
        raise ValueError("weakest_ordering needs at least one (diff, diff_se) pair")
    for d, s in pairs:
        ordering_holds(d, s)  # validates
    return min(pairs, key=lambda p: _z(*p))


def readings_hold(readings):
    """True if the statement holds under every reading, False if it fails under every
    reading, None otherwise (the readings disagree or one of them is undecided)."""
    vals = list(dict(readings).values())
    if not vals:
        raise ValueError("readings must name at least one reading")
    if all(v is True or (v is not None and bool(v)) for v in vals):
        return True
    if all(v is not None and not bool(v) for v in vals):
        return False
    return None


def number_matches(published, reproduced, se=None, published_se=None, rel_tol=DEFAULT_REL_TOL) -> bool:
    """Is the published number matched by ours: inside ``Z_CRIT`` combined standard errors
    (``|ours - published| <= Z_CRIT * sqrt(se**2 + published_se**2)``) or within ``rel_tol``
    of the published value (``rel_tol=None``: exact agreement only)."""
    diff = abs(reproduced - published)
    ses = [s for s in (se, published_se) if _isnum(s) and s > 0]
    total_se = math.sqrt(sum(s * s for s in ses)) if ses else 0.0
    inside = total_se > 0 and diff <= Z_CRIT * total_se
    return bool(inside or diff <= (rel_tol or 0.0) * abs(published))


def _reading_pair(v):
    """``(value, se)`` from a reading_values entry: a number, or a pair (value, se)."""
    if _isnum(v):
        return float(v), None
    try:
        value, se = v
    except (TypeError, ValueError):
        raise ValueError(f"reading_values entries must be a number or a pair (value, se), got {v!r}") from None
    return value, se


#: Why an inconclusive claim is inconclusive (:attr:`Judgement.cause`).
CAUSE_READING = "depends on the reading"
CAUSE_RUNS = "too few runs"
CAUSE_TIE = "tie within the stated margin"
CAUSE_COUNT = "the count does not decide"
CAUSES = (CAUSE_READING, CAUSE_RUNS, CAUSE_TIE, CAUSE_COUNT)
_POSITIVE = ("reproduced", "qualitatively reproduced")
#: the name of the main reading where a published number is judged under several readings
MAIN_READING = "the main reading"


@dataclass(frozen=True)
class Judgement:
    """A verdict with what decided it.

    Attributes
    ----------
    verdict : str
        One of ``VERDICTS``.
    cause : str
        For ``inconclusive``: one of ``CAUSES``; else ``""``.
    runs_needed : int or None
        For ``too few runs``: the runs that would decide the undecided reading(s) with 80 % power
        (:func:`pfrepro.stats.plan_runs` against the printed effect or the stated margin);
        ``None`` when no size was stated.
    per_reading : tuple
        ``(reading, verdict, cause)`` of every admissible reading, when the claim has readings.
    """

    verdict: str
    cause: str = ""
    runs_needed: int | None = None
    per_reading: tuple = ()

    def under(self, kind: str) -> list:
        """The readings under which the claim ``"holds"`` (reproduced or qualitatively reproduced),
        ``"fails"`` (not reproduced), ``"ties"`` or is ``"undecided"`` (too few runs)."""
        test = {"holds": lambda v, c: v in _POSITIVE, "fails": lambda v, c: v == "not reproduced",
                "ties": lambda v, c: c == CAUSE_TIE,
                "undecided": lambda v, c: v == "inconclusive" and c != CAUSE_TIE}[kind]
        return [r for r, v, c in self.per_reading if test(v, c)]


def _needed(diff_se, runs, size, gap=None):
    """Runs that would decide an undecided ordering (None if unknown).

    The plan for ``size`` (the printed effect or the margin) given ``diff_se`` on ``runs`` runs; when
    the runs already met that plan, the runs that would resolve what is left, ``gap`` (the observed
    difference, or its distance to the printed effect, whichever is larger), so that the number is
    always more than the runs the claim had.
    """
    from .stats import plan_runs

    if not (_isnum(size) and size > 0 and _isnum(diff_se) and runs):
        return None
    sd = float(diff_se) * math.sqrt(int(runs))
    need = plan_runs(sd, float(size), z=Z_CRIT)
    if need <= int(runs):
        need = plan_runs(sd, float(gap), z=Z_CRIT) if _isnum(gap) and gap > 0 else None
    return need


def judge_ordering(diff, diff_se, *, effect=None, margin=None, rel_tol=DEFAULT_REL_TOL, runs=None) -> Judgement:
    """The verdict of one ordering under one reading: the paired difference ``diff ± diff_se``
    (the claim asserts ``diff > 0``) against the printed effect or the stated margin.

    With a printed ``effect`` (> 0: the size the paper's own numbers give, oriented like ``diff``),
    direction *and* size are judged (the truth table in CONTRIBUTING.md). "Shown" is
    ``diff > Z_CRIT * diff_se``, "reversed" ``diff < -Z_CRIT * diff_se``, "attained"
    ``|diff - effect| <= Z_CRIT * diff_se`` (or within ``rel_tol`` of the effect):

    ========  ==========  ======================================
    shown     attained    verdict
    ========  ==========  ======================================
    yes       yes         reproduced
    yes       no          qualitatively reproduced
    reversed  --          not reproduced
    no        no          not reproduced (the printed size excluded)
    no        yes         inconclusive, too few runs (0 and the effect both inside)
    ========  ==========  ======================================

    Without a printed effect: shown -> reproduced; reversed -> not reproduced; otherwise
    inconclusive, a *tie within the stated margin* when ``diff ± Z_CRIT * diff_se`` lies inside
    ``(-margin, margin)``, else *too few runs*. ``runs`` (the runs behind ``diff``) gives the runs that
    would decide it (:attr:`Judgement.runs_needed`): the power plan for the effect or the margin, or,
    where the claim already ran that plan, the plan for the difference left to resolve.
    """
    shown = ordering_holds(diff, diff_se)
    if effect is not None:
        if not (_isnum(effect) and effect > 0):
            raise ValueError(f"a printed effect must be a finite number > 0 oriented like diff, got {effect!r}")
        gap = abs(diff - effect)
        attained = gap <= Z_CRIT * diff_se or gap <= (rel_tol or 0.0) * effect
        if shown is True:
            return Judgement("reproduced" if attained else "qualitatively reproduced")
        if shown is False or not attained:
            return Judgement("not reproduced")
        return Judgement("inconclusive", CAUSE_RUNS, _needed(diff_se, runs, effect, max(abs(diff), abs(effect - diff))))
    if shown is True:
        return Judgement("reproduced")
    if shown is False:
        return Judgement("not reproduced")
    if _isnum(margin) and margin > 0 and abs(diff) + Z_CRIT * diff_se < margin:
        return Judgement("inconclusive", CAUSE_TIE)
    return Judgement("inconclusive", CAUSE_RUNS, _needed(diff_se, runs, margin, abs(diff)))


def _statement(holds, basis="") -> Judgement:
    if holds is None:
        return Judgement("inconclusive", CAUSE_COUNT if basis == "count" else CAUSE_RUNS)
    return Judgement("reproduced" if bool(holds) else "not reproduced")


def combine_readings(per_reading: dict) -> Judgement:
    """One verdict from the verdicts of the admissible readings (reading -> :class:`Judgement`).

    * the same verdict (and cause) under every reading -> that verdict;
    * the direction shown under every reading, the printed size under some only -> *qualitatively
      reproduced* (the strongest statement true under every reading);
    * fails under some readings and ties under the others -> *not reproduced* (it holds under none);
    * the decided readings disagree otherwise (holds under some, fails or ties under others) ->
      *inconclusive*, cause *depends on the reading* (:meth:`Judgement.under` names which);
    * the decided readings agree and some reading is undecided -> *inconclusive*, cause *too few runs*
      (``runs_needed``: the most any undecided reading needs), or the undecided reading's own cause.
    """
    if not per_reading:
        raise ValueError("combine_readings needs at least one reading")
    rows = tuple((str(r), j.verdict, j.cause) for r, j in per_reading.items())
    js = list(per_reading.values())

    def kind(j):
        if j.verdict in _POSITIVE:
            return "holds"
        if j.verdict == "not reproduced":
            return "fails"
        return "ties" if j.cause == CAUSE_TIE else "undecided"

    kinds = [kind(j) for j in js]
    decided = {k for k in kinds if k != "undecided"}
    if decided == {"fails", "ties"}:
        # fails under some readings, no effect that matters under the others: it holds under none
        # (unless an undecided reading could still show it: too few runs, below)
        decided = {"fails"}
        if "undecided" not in kinds:
            return Judgement("not reproduced", "", None, rows)
    if len(decided) > 1:
        return Judgement("inconclusive", CAUSE_READING, None, rows)
    if "undecided" in kinds:
        und = [j for j in js if kind(j) == "undecided"]
        causes = {j.cause for j in und}
        cause = causes.pop() if len(causes) == 1 else CAUSE_RUNS
        needs = [j.runs_needed for j in und if j.cause == CAUSE_RUNS]
        need = max(needs) if needs and all(n is not None for n in needs) else None
        return Judgement("inconclusive", cause, need, rows)
    if decided == {"ties"}:
        return Judgement("inconclusive", CAUSE_TIE, None, rows)
    verdicts = {j.verdict for j in js}
    if len(verdicts) == 1:
        return Judgement(verdicts.pop(), "", None, rows)
    return Judgement("qualitatively reproduced", "", None, rows)


def _diff_triple(v):
    """``(diff, se, runs)`` from a reading_diffs entry ``(diff, se)`` or ``(diff, se, runs)``."""
    try:
        vals = list(v)
    except TypeError:
        raise ValueError(f"reading_diffs entries must be (diff, se) or (diff, se, runs), got {v!r}") from None
    if len(vals) not in (2, 3) or not (_isnum(vals[0]) and _isnum(vals[1]) and vals[1] >= 0):
        raise ValueError(f"reading_diffs entries must be (diff, se[, runs]) with finite diff and se >= 0, got {v!r}")
    runs = int(vals[2]) if len(vals) == 3 and vals[2] is not None else None
    return float(vals[0]), float(vals[1]), runs


def judge(published=None, reproduced=None, se=None, rel_tol=DEFAULT_REL_TOL, qualitative=None,
          diff=None, diff_se=None, published_se=None, basis="", readings=None,
          reading_values=None, not_checkable="", effect=None, margin=None, runs=None,
          reading_diffs=None, excluded=None) -> Judgement:
    """The verdict rule with its cause (see the module docstring and CONTRIBUTING.md).

    The ordering is judged per admissible reading: ``reading_diffs`` (reading -> ``(diff, se[, runs])``,
    every reading including the main one) by :func:`judge_ordering` against ``effect`` / ``margin``;
    ``readings`` (reading -> holds) as statements; otherwise the main ``diff``/``diff_se`` (or
    ``qualitative``). Readings named in ``excluded`` (reading -> why the paper excludes it) are context
    and not counted. The readings are combined by :func:`combine_readings`. A published number
    (``published`` and ``reproduced``) is judged under the main reading and every ``reading_values``
    entry: matched under all -> *reproduced*; under some -> *qualitatively reproduced* if the ordering
    holds under every reading, else *inconclusive* (depends on the reading); under none -> the
    ordering decides (*qualitatively reproduced* / *not reproduced* / its inconclusive cause).
    """
    if not_checkable:
        return Judgement("not checkable")
    basis = basis or ""
    if basis not in BASES:
        raise ValueError(f"basis must be one of {BASES}, got {basis!r}")
    has_diff = diff is not None or diff_se is not None
    if qualitative is not None and (has_diff or readings is not None or reading_diffs is not None):
        raise ValueError("give either qualitative or diff/diff_se or readings, not more than one")
    if effect is not None and not (_isnum(effect) and effect > 0):
        raise ValueError(f"a printed effect must be a finite number > 0 oriented like diff, got {effect!r}")
    if margin is not None and not (_isnum(margin) and margin > 0):
        raise ValueError(f"a margin must be a finite number > 0, got {margin!r}")
    if effect is not None and readings:
        raise ValueError("a claim with a printed effect judges each reading on its difference: "
                         "pass reading_diffs={reading: (diff, se, runs)}, not readings")
    if effect is not None and not (has_diff or reading_diffs):
        raise ValueError("a printed effect needs the paired difference (diff, diff_se or reading_diffs)")
    skip = set(excluded or {})
    kw = dict(effect=effect, margin=margin, rel_tol=rel_tol)
    per = {}
    for r, v in (readings or {}).items():
        if r not in skip:
            per[r] = _statement(v, basis)
    for r, v in (reading_diffs or {}).items():
        if r not in skip:
            d, s, n = _diff_triple(v)
            per[r] = judge_ordering(d, s, runs=n, **kw)
    if readings or reading_diffs:
        if not per:
            raise ValueError("every reading of the claim is excluded: keep at least one admissible reading")
        order = combine_readings(per)
    elif has_diff:
        if not (_isnum(diff) and _isnum(diff_se)) or diff_se < 0:
            raise ValueError(f"ordering needs finite diff and diff_se >= 0, got {diff!r}, {diff_se!r}")
        order = judge_ordering(diff, diff_se, runs=runs, **kw)
    elif qualitative is not None:
        order = _statement(qualitative, basis)
    else:
        order = None
    if basis == "count":
        if order is None:
            return Judgement("inconclusive", CAUSE_COUNT)
        return order if order.verdict != "inconclusive" or order.cause else Judgement(
            "inconclusive", CAUSE_COUNT, None, order.per_reading)
    if reading_values and not (_isnum(published) and _isnum(reproduced)):
        raise ValueError("reading_values judge a published number: give published and reproduced too")
    if _isnum(published) and _isnum(reproduced):
        matched = {MAIN_READING: number_matches(published, reproduced, se, published_se, rel_tol)}
        for r, v in (reading_values or {}).items():
            if r in skip:
                continue
            value, value_se = _reading_pair(v)
            matched[r] = bool(_isnum(value) and number_matches(published, value, value_se, published_se, rel_tol))
        rows = order.per_reading if order is not None else ()
        if all(matched.values()):
            return Judgement("reproduced", "", None, rows)
        holds_all = order is not None and order.verdict in _POSITIVE
        if holds_all:
            return Judgement("qualitatively reproduced", "", None, rows)
        if any(matched.values()):
            # the number is matched under some readings only: name them (the ordering's rows follow)
            num_rows = tuple((r, "reproduced" if m else "not reproduced", "") for r, m in matched.items())
            return Judgement("inconclusive", CAUSE_READING, None, num_rows)
        if order is None or order.verdict == "not reproduced":
            return Judgement("not reproduced", "", None, rows)
        return order
    if order is None:
        return Judgement("not checkable")
    return order


def verdict(published=None, reproduced=None, se=None, rel_tol=DEFAULT_REL_TOL, qualitative=None,
            diff=None, diff_se=None, published_se=None, basis="", readings=None,
            reading_values=None, not_checkable="", effect=None, margin=None, runs=None,
            reading_diffs=None, excluded=None) -> str:
    """The verdict word of :func:`judge` (see there and the module docstring)."""
    return judge(published, reproduced, se, rel_tol, qualitative, diff, diff_se, published_se, basis,
                 readings, reading_values, not_checkable, effect, margin, runs, reading_diffs,
                 excluded).verdict


@dataclass
class Claim:
    """One claim of one paper, with the numbers its verdict is computed from.

    A chapter records claims with :meth:`ClaimsRegistry.add`, whose arguments are these fields;
    the verdict is never stored, it is recomputed from them (:attr:`verdict`).
    """

    #: The paper's key, e.g. ``"gpff_zhang2016"``.
    paper: str
    #: The claim's id within its paper (the anchor of its row in the chapter).
    claim_id: str
    #: The claim in words, with where the paper makes it.
    text: str
    #: The published number, if the paper prints one.
    published: float | None = None
    #: Our number for it (a Monte Carlo mean).
    reproduced: float | None = None
    #: The standard error of our number.
    se: float | None = None
    #: Relative tolerance for a number without standard errors (``DEFAULT_REL_TOL`` unless stated).
    rel_tol: float | None = DEFAULT_REL_TOL
    #: Whether a yes/no statement holds in our runs (no number compared).
    qualitative: bool | None = None
    #: Where in the paper (table, figure, section).
    source: str = ""
    #: What was compared, in a few words.
    note: str = ""
    #: Paired difference the claim asserts is positive (``pfrepro.stats.paired_difference``).
    diff: float | None = None
    #: The standard error of ``diff``.
    diff_se: float | None = None
    #: The paper's own standard error (a printed spread or per-run rows).
    published_se: float | None = None
    #: ``"count"`` for a cost claim decided on a deterministic cost count, else ``""``.
    basis: str = ""
    #: Reading of the paper -> does the statement hold under it.
    readings: dict | None = None
    #: Reading -> ``[ours, se]`` of a published number under it.
    reading_values: dict | None = None
    #: The free choices (``pfrepro.choices``) the verdict rests on.
    depends_on: list | None = None
    #: Why the paper's unpublished settings decide this number (then it is not checkable).
    not_checkable: str = ""
    #: ``published`` exactly as the paper prints it (``pfrepro.published.printed``).
    published_text: str | None = None
    #: The printed effect, oriented like ``diff`` (> 0): its size is tested.
    effect: float | None = None
    #: The smallest effect of interest, stated up front when the paper prints no effect.
    margin: float | None = None
    #: The runs behind ``diff`` (the main reading).
    runs: int | None = None
    #: Reading -> ``[diff, se, runs]`` of the ordering under it.
    reading_diffs: dict | None = None
    #: Reading -> why the paper excludes it (shown, not counted).
    excluded: dict | None = None

    @property
    def judgement(self) -> Judgement:
        """The verdict with its cause, recomputed from the stored numbers by :func:`judge`."""
        return judge(self.published, self.reproduced, self.se, self.rel_tol, self.qualitative,
                     self.diff, self.diff_se, self.published_se, self.basis, self.readings,
                     self.reading_values, self.not_checkable, self.effect, self.margin, self.runs,
                     self.reading_diffs, self.excluded)

    @property
    def verdict(self) -> str:
        """The verdict, recomputed from the stored numbers by :func:`verdict` (never stored as text)."""
        return self.judgement.verdict

    @property
    def cause(self) -> str:
        """Why an inconclusive claim is inconclusive (one of ``CAUSES``; ``""`` otherwise)."""
        return self.judgement.cause

    @property
    def runs_needed(self) -> int | None:
        """For *too few runs*: the runs a power plan says would decide the claim (else ``None``)."""
        return self.judgement.runs_needed

    def verdict_text(self) -> str:
        """The verdict with its cause in words, e.g. ``"inconclusive (too few runs: 140 would decide)"``."""
        j = self.judgement
        if j.verdict != "inconclusive":
            return j.verdict
        if j.cause == CAUSE_RUNS and j.runs_needed:
            return f"inconclusive ({j.cause}: {j.runs_needed} would decide)"
        return f"inconclusive ({j.cause})" if j.cause else "inconclusive"

    def test_text(self) -> str:
        """The rule that decided this claim, in a few words (for the verdict tables)."""
        parts = []
        if self.not_checkable:
            parts.append(f"not checkable: {self.not_checkable}")
        if self.basis == "count":
            parts.append("cost count (load-independent); published/measured time: context")
        elif _isnum(self.published) and _isnum(self.reproduced):
            se_txt = "√(se²+se_pub²)" if _isnum(self.published_se) else "se"
            tol = f" or ≤ {self.rel_tol:.0%}" if self.rel_tol else ""
            parts.append(f"|ours − pub| ≤ {Z_CRIT:g}·{se_txt}{tol}")
        if self.reading_values:
            parts.append("under other readings: " + "; ".join(
                f"{k}: {_pm(*_reading_pair(v))}" for k, v in self.reading_values.items()))
        if self.diff is not None:
            z = _z(self.diff, self.diff_se)
            n = f" on {self.runs} runs" if self.runs else ""
            parts.append(f"paired diff {_fmt(self.diff)} ± {_fmt(self.diff_se)}{n} (z = {z:.1f}; decided at |z| > {Z_CRIT:g})")
        if _isnum(self.effect):
            parts.append(f"printed effect {_fmt(self.effect)}: size tested (attained if inside ±{Z_CRIT:g} se)")
        elif _isnum(self.margin):
            parts.append(f"smallest effect of interest {_fmt(self.margin)}")
        skip = self.excluded or {}
        if self.readings:
            word = {True: "holds", False: "fails", None: "undecided"}
            parts.append("readings: " + "; ".join(f"{k} → {word[None if v is None else bool(v)]}"
                                                   for k, v in self.readings.items() if k not in skip))
        if self.reading_diffs:
            per = {r: (v, c) for r, v, c in self.judgement.per_reading}
            items = []
            for k, v in self.reading_diffs.items():
                if k in skip:
                    continue
                d, s_, n = _diff_triple(v)
                vv, cc = per.get(k, ("", ""))
                items.append(f"{k}: Δ {_pm(d, s_)}" + (f" on {n} runs" if n else "") + f" → {vv}"
                             + (f" ({cc})" if cc else ""))
            parts.append("readings: " + "; ".join(items))
        if skip:
            parts.append("not counted (the paper excludes them): " + "; ".join(f"{k}: {why}" for k, why in skip.items()))
        if self.note:
            parts.append(self.note)
        return "; ".join(parts)

    def judged(self) -> str:
        """What the verdict was decided on, in a few words (the ``judged`` column of the tables).

        ``"value"``: the published number against ours; ``"value, else ordering"``: the
        number first, and the ordering or trend when the number is not matched
        (*qualitatively reproduced*); ``"ordering (paired)"``: a paired difference, so the
        numbers shown beside it are context; ``"ordering, on counts"``: a cost or
        equal-budget claim decided on deterministic counts (a published ratio of seconds and our
        count ratio are shown, not matched); ``"statement"``: a yes/no statement. Followed by
        "under every reading": decided under each admissible reading of the paper.
        """
        if self.not_checkable:
            return "not checkable"
        every = " under every reading"
        if self.basis == "count":
            return "ordering, on counts" + (every if self.readings else "") + (
                " (numbers: context)" if _isnum(self.reproduced) or _isnum(self.published) else "")
        if _isnum(self.published) and _isnum(self.reproduced):
            out = "value" + (every if self.reading_values else "")
            if self.readings or self.reading_diffs:
                out += ", else ordering" + every
            elif self.diff is not None or self.qualitative is not None:
                out += ", else ordering"
            return out
        if self.readings or self.reading_diffs:
            size = " and size" if _isnum(self.effect) else ""
            return ("ordering" + size if (self.diff is not None or self.reading_diffs) else "statement") + every
        if self.diff is not None or self.diff_se is not None:
            return "ordering and size (paired)" if _isnum(self.effect) else "ordering (paired)"
        if self.qualitative is not None:
            return "statement" + (", the number as context" if _isnum(self.reproduced) else "")
        return "–"

    def as_row(self) -> dict:
        """The claim's fields and its verdict as a dict (one row of the scorecard / JSON file)."""
        d = asdict(self)
        j = self.judgement
        d["verdict"], d["cause"], d["runs_needed"] = j.verdict, j.cause, j.runs_needed
        return d


def _fmt(v, digits=3) -> str:
    """A number in ``digits`` significant digits, without exponent noise for ordinary sizes."""
    if not _isnum(v):
        return ""
    v = float(v)
    if v == 0:
        return "0"
    if 1e-3 <= abs(v) < 1e5:
        dec = max(0, digits - 1 - int(math.floor(math.log10(abs(v)))))
        return f"{v:.{dec}f}"
    return f"{v:.{digits - 1}e}"


def _pm(value, se) -> str:
    """``value ± se`` with the se in 2 significant digits and the value to the same decimals."""
    if not _isnum(value):
        return "–"
    if not (_isnum(se) and se > 0):
        return _fmt(value)
    dec = 1 - int(math.floor(math.log10(se)))
    if 0 <= dec <= 6 and abs(value) < 1e6:
        return f"{value:.{dec}f} ± {se:.{dec}f}"
    return f"{_fmt(value)} ± {_fmt(se, 2)}"


def _published_cell(c: Claim) -> str:
    """The claims table's ``published`` cell: the printed string when the claim carries one
    (``published_text``, the paper's digits), else the number rounded by :func:`_pm`."""
    text = c.published_text
    if isinstance(text, str) and text:
        if _isnum(c.published_se) and c.published_se > 0:
            return f"{text} ± {_fmt(c.published_se, 2)}"
        return text
    return _pm(c.published, c.published_se)


def as_claims(claims) -> list:
    """:class:`Claim` objects from a :class:`ClaimsRegistry`, a list of claims or a DataFrame of claim
    rows (e.g. :func:`load_all_claims`; the computed columns are dropped and recomputed)."""
    if isinstance(claims, ClaimsRegistry):
        return list(claims.claims)
    if isinstance(claims, pd.DataFrame):
        fields = set(Claim.__dataclass_fields__)
        return [Claim(**{k: (None if (isinstance(v, float) and math.isnan(v)) else v)
                         for k, v in row.items() if k in fields})
                for row in claims.to_dict("records")]
    return list(claims)


def cause_text(c: Claim, *, as_html: bool = False) -> str:
    """Why ``c`` is inconclusive, for a reader: the cause and what it means for this claim.

    *depends on the reading*: the readings under which it holds and those under which it fails
    (or ties); *too few runs*: the runs it had and the runs a plan says would decide it; the
    other causes as they are. ``""`` for a claim that is not inconclusive. With ``as_html`` the
    text is HTML and each reading's name (a setting such as ``p_stay=0.98``, defined in the
    chapter's assumptions table) is set as code, so running text does not read it as a word.
    """
    import html as _html

    j = c.judgement
    if j.verdict != "inconclusive":
        return ""

    def names(rs):  # a joint reading "a=1, b=2" in parentheses, so the list stays readable
        shown = [f"({r})" if "," in r else r for r in rs]
        if as_html:
            shown = [_html.escape(r) if r == MAIN_READING else f'<code class="pf-reading">{_html.escape(r)}</code>'
                     for r in shown]
        return ", ".join(shown)

    if j.cause == CAUSE_READING:
        number = any(r == MAIN_READING for r, _, _ in j.per_reading)
        word = ({"holds": "the number is matched", "fails": "not matched"} if number else
                {"holds": "holds", "fails": "fails", "ties": "ties", "undecided": "undecided"})
        parts = [f"{word[kind]} under {names(j.under(kind))}" for kind in word if j.under(kind)]
        return j.cause + (": " + "; ".join(parts) if parts else "")
    if j.cause == CAUSE_RUNS:
        undecided = j.under("undecided")
        diffs = c.reading_diffs or {}
        if undecided:   # the readings still undecided and their runs, not the main reading's
            runs = sorted({_diff_triple(diffs[r])[2] for r in undecided if r in diffs} - {None})
            had = f"undecided under {names(undecided)}" + (f" on {'/'.join(map(str, runs))} runs" if runs else "")
        else:
            runs = c.runs or max((_diff_triple(v)[2] or 0 for v in diffs.values()), default=0)
            had = f"{runs} runs" if runs else ""
        statement = bool(undecided) and not any(r in diffs for r in undecided)
        need = (f"{j.runs_needed} would decide" if j.runs_needed else
                "" if statement else "no size stated to plan runs for")
        return f"{j.cause} ({', '.join(x for x in (had, need) if x)})"
    return j.cause


def causes_table(claims, *, by: str = "paper") -> pd.DataFrame:
    """The inconclusive claims counted by cause: one row per ``by`` value (a paper), one column per
    cause of ``CAUSES``, plus ``inconclusive`` (their sum) and a last row ``all claims``."""
    rows = [{by: getattr(c, by), "cause": c.cause} for c in as_claims(claims) if c.verdict == "inconclusive"]
    df = pd.DataFrame(rows, columns=[by, "cause"])
    keys = list(dict.fromkeys(getattr(c, by) for c in as_claims(claims)))
    out = pd.crosstab(df[by], df["cause"]).reindex(index=keys, columns=list(CAUSES), fill_value=0)
    out["inconclusive"] = out.sum(axis=1)
    out.loc["all claims"] = out.sum(axis=0)
    out.index.name = by
    return out.astype(int)


def inconclusive_table(claims) -> pd.DataFrame:
    """Every inconclusive claim with its cause in words (:func:`cause_text`) and, for *too few runs*,
    the runs a plan says would decide it: columns ``paper``, ``id``, ``claim``, ``cause``, ``why``,
    ``runs needed``."""
    rows = [{"paper": c.paper, "id": c.claim_id, "claim": c.text, "cause": c.cause, "why": cause_text(c),
             "runs needed": c.runs_needed} for c in as_claims(claims) if c.verdict == "inconclusive"]
    return pd.DataFrame(rows, columns=["paper", "id", "claim", "cause", "why", "runs needed"])


def verdict_html(text: str, href: str = VERDICT_HREF, *, escape=None, cls: str = "pf-verdict-link") -> str:
    """A verdict as HTML for the book's tables and findings: the verdict word a link to its
    definition (``href``, the scorecard's verdict scale), whatever follows it (the cause of an
    inconclusive verdict, ``Claim.verdict_text``) after it as text.

    ``text``: a verdict of ``VERDICTS``, alone or followed by a space and more words, e.g.
    ``"inconclusive (too few runs: 140 would decide)"``; text that starts with no verdict word is
    returned escaped, without a link. ``escape``: how the rest is turned into HTML (default
    ``html.escape``; the tables pass their number-keeping escaper). The link carries the classes
    ``cls`` and ``pf-verdict-<word>`` (the stylesheet colours verdicts by the latter); the default
    ``pf-verdict-link`` keeps the theme's link underline and lets a long verdict wrap in a
    narrow table column (the findings' ``pf-verdict`` links do not wrap).
    """
    import html

    if not isinstance(text, str):
        raise TypeError(f"verdict_html: text must be a str, got {type(text).__name__}")
    escape = escape or html.escape
    word = next((v for v in sorted(VERDICTS, key=len, reverse=True)
                 if text == v or text.startswith(v + " ")), None)
    if word is None:
        return escape(text)
    classes = f"{cls} pf-verdict-" + word.replace(" ", "-")
    return (f'<a class="{html.escape(classes, quote=True)}" href="{html.escape(href, quote=True)}">{html.escape(word)}</a>'
            + escape(text[len(word):]))


def claims_table(claims, *, ids: bool = True, paper: bool = False) -> pd.DataFrame:
    """The compact verdict table every chapter and the scorecard show.

    ``claims``: a :class:`ClaimsRegistry`, a list of :class:`Claim`, or a DataFrame
    of claim rows (e.g. :func:`load_all_claims`). Columns (all strings, short
    headers so the table fits the text column): ``id`` (if ``ids``), ``paper`` (if
    ``paper``), ``claim``, ``ours`` (value ± SE, or the paired difference ± SE of an
    ordering), ``published`` (± its SE), ``judged`` (what the verdict was decided on:
    the value, the ordering or a statement, :meth:`Claim.judged`; an ordering claim shows
    numbers that were not matched), ``verdict``, ``test`` (the rule applied and the
    claim's note).
    """
    items = as_claims(claims)
    rows = []
    for c in items:
        if _isnum(c.reproduced):
            ours = _pm(c.reproduced, c.se)
        elif c.diff is not None:
            ours = "Δ " + _pm(c.diff, c.diff_se)
        elif c.readings or c.reading_diffs:
            j = c.judgement
            ours = f"{len(j.under('holds'))}/{len(j.per_reading)} readings hold"
        elif c.qualitative is not None:
            ours = "holds" if c.qualitative else "fails"
        else:
            ours = "–"
        row = {}
        if paper:
            row["paper"] = c.paper
        if ids:
            row["id"] = c.claim_id
        row.update({"claim": c.text, "ours": ours, "published": _published_cell(c),
                    "judged": c.judged(), "verdict": c.verdict_text(), "test": c.test_text()})
        rows.append(row)
    cols = ((["paper"] if paper else []) + (["id"] if ids else [])
            + ["claim", "ours", "published", "judged", "verdict", "test"])
    return pd.DataFrame(rows, columns=cols)


def claims_dir() -> Path:
    """Where claims are saved and read: ``$PFREPRO_CLAIMS_DIR``, else ``_claims`` under the working directory."""
    return Path(os.environ.get("PFREPRO_CLAIMS_DIR", Path.cwd() / "_claims"))


def _clean(v):
    """JSON-safe scalars (numpy -> python, NaN -> None)."""
    if v is None or isinstance(v, (str, bool)):
        return v
    try:
        import numpy as np

        if isinstance(v, np.bool_):
            return bool(v)
        v = float(v)
    except (TypeError, ValueError):
        return v
    return v if math.isfinite(v) else None


class ClaimsRegistry:
    """Collects a chapter's claims and saves them for the scorecard."""

    def __init__(self, paper: str, choices=None):
        """``choices``: the chapter's free choices (:class:`pfrepro.choices.FreeChoice` rows),
        against which every claim's ``depends_on`` is checked."""
        from . import choices as _choices

        self.paper = paper
        self.choices = _choices.as_choice_map(choices)
        self.claims: list[Claim] = []

    def add(self, claim_id: str, text: str, *, published=None, reproduced=None, se=None,
            rel_tol=DEFAULT_REL_TOL, qualitative=None, source="", note="", diff=None,
            diff_se=None, published_se=None, basis="", readings=None, reading_values=None,
            depends_on=None, not_checkable="", published_text=None, effect=None, margin=None,
            runs=None, reading_diffs=None, excluded=None) -> Claim:
        """Record one claim of the paper and check now that its verdict can be computed.

        Parameters
        ----------
        claim_id : str
            Unique within the paper (``ValueError`` if recorded twice).
        text : str
            The claim in a few words, as the paper states it.
        published, reproduced, se : float, optional
            A numeric claim: the paper's value, ours and our standard error.
        rel_tol : float, optional
            Relative tolerance of a numeric claim (default :data:`DEFAULT_REL_TOL`).
        qualitative : bool, optional
            A claim judged by eye (holds / does not hold), when no number decides it.
        source : str, optional
            Where in the paper (table, figure, section).
        note : str, optional
            What was compared, in a few words.
        diff, diff_se : float, optional
            An ordering claim: the paired difference oriented so that the claim asserts
            ``diff > 0`` and its standard error (:func:`pfrepro.stats.paired_difference`).
        published_se : float, optional
            The paper's own standard error, if it prints one.
        basis : {"", "count"}, optional
            ``"count"``: a cost claim decided on a deterministic cost count.
        readings : dict, optional
            Reading of the paper -> whether the statement holds under it (bool or None).
            Names of readings of a free choice are tagged ``"<choice>=<value>"``
            (:func:`pfrepro.choices.over`).
        reading_values : dict, optional
            Reading -> ``(ours, se)`` of the published number under that reading (besides
            ``reproduced``/``se`` under the main one); matched under some but not all:
            ``inconclusive``.
        depends_on : sequence of str, optional
            The free choices of the chapter's assumptions table the verdict rests on;
            each one not fixed by the paper must be covered by tagged readings
            (:func:`pfrepro.choices.check_claim`, ``FreeChoiceError`` otherwise).
        not_checkable : str, optional
            Why the number is decided by the paper's unpublished settings; the verdict is
            then ``not checkable``.
        published_text : str, optional
            ``published`` exactly as the paper prints it (:func:`pfrepro.published.printed`),
            shown by :func:`claims_table` instead of a rounded number; must parse to
            ``published`` (``ValueError`` otherwise). Omitted: the table rounds the number.
        effect : float, optional
            The effect the paper printed (both sides of the comparison printed), in ``diff``'s units
            and orientation (> 0): direction *and* size are judged (:func:`judge_ordering`).
        margin : float, optional
            Where no effect is printed: the smallest effect of interest, stated up front; an
            interval inside ``(-margin, margin)`` is a tie, and the power plan resolves it.
        runs : int, optional
            The runs behind ``diff`` (for the runs a plan needs).
        reading_diffs : dict, optional
            Reading -> ``(diff, se, runs)`` of the ordering under it (every reading, the main one
            included); each reading is judged by :func:`judge_ordering`, then combined
            (:func:`combine_readings`).
        excluded : dict, optional
            Reading -> why the paper's text or printed numbers exclude it; shown, not counted.

        Returns
        -------
        Claim
            The recorded claim; its verdict is :func:`verdict` of these fields.
        """
        if any(c.claim_id == claim_id for c in self.claims):
            raise ValueError(f"claim {claim_id!r} already recorded for {self.paper}")
        if qualitative is not None and not isinstance(qualitative, (bool,)):
            qualitative = bool(qualitative)
        if readings is not None:
            readings = {str(k): (None if v is None else bool(v)) for k, v in dict(readings).items()}
        if reading_values is not None:
            reading_values = {str(k): [_clean(x) for x in _reading_pair(v)]
                              for k, v in dict(reading_values).items()}
        if depends_on is not None:
            depends_on = [depends_on] if isinstance(depends_on, str) else [str(d) for d in depends_on]
        if reading_diffs is not None:
            reading_diffs = {str(k): [_clean(x) for x in _diff_triple(v)] for k, v in dict(reading_diffs).items()}
            reading_diffs = {k: v[:2] + [None if v[2] is None else int(v[2])] for k, v in reading_diffs.items()}
        if excluded is not None:
            excluded = {str(k): str(v) for k, v in dict(excluded).items()}
            known = set(readings or {}) | set(reading_diffs or {}) | set(reading_values or {})
            unknown = sorted(set(excluded) - known)
            if unknown:
                raise ValueError(f"claim {claim_id!r}: excluded readings {unknown} are not readings of the claim")
        if published_text is not None:
            published_text = str(published_text).strip()
            try:
                ok = _isnum(published) and abs(float(published_text) - float(published)) <= 1e-12 * max(
                    1.0, abs(float(published)))
            except ValueError:
                ok = False
            if not ok:
                raise ValueError(f"claim {claim_id!r}: published_text {published_text!r} is not the "
                                 f"printed form of published={published!r}")
        from .choices import check_claim

        check_claim(claim_id, depends_on, {**(readings or {}), **(reading_diffs or {})}, reading_values,
                    self.choices)
        c = Claim(self.paper, claim_id, text, _clean(published), _clean(reproduced), _clean(se),
                  _clean(rel_tol), qualitative, source, note, _clean(diff), _clean(diff_se),
                  _clean(published_se), basis, readings, reading_values, depends_on, str(not_checkable or ""),
                  published_text or None, _clean(effect), _clean(margin), None if runs is None else int(runs),
                  reading_diffs, excluded)
        c.verdict  # validate now (e.g. both qualitative and diff given), not at the scorecard
        self.claims.append(c)
        return c

    def verdicts(self) -> dict:
        """``{claim_id: verdict}`` of every claim, in the order recorded (verdicts recomputed, never stored)."""
        return {c.claim_id: c.verdict for c in self.claims}

    def to_frame(self) -> pd.DataFrame:
        """Every recorded claim as a row (:meth:`Claim.as_row`), with its verdict."""
        return pd.DataFrame([c.as_row() for c in self.claims])

    def table(self, **kw) -> pd.DataFrame:
        """:func:`claims_table` of this registry."""
        return claims_table(self, **kw)

    def save(self, directory: Path | None = None) -> Path:
        """Write the claims to ``<directory>/<paper>.json`` for the scorecard.

        Parameters
        ----------
        directory : path, optional
            Default :func:`claims_dir`; created if missing.

        Returns
        -------
        pathlib.Path
            The file written.
        """
        d = Path(directory) if directory is not None else claims_dir()
        d.mkdir(parents=True, exist_ok=True)
        path = d / f"{self.paper}.json"
        path.write_text(json.dumps([c.as_row() for c in self.claims], indent=1), encoding="utf-8")
        from .choices import save_choices

        save_choices(self.paper, self.choices.values(), d)
        return path


def load_all_claims(directory: Path | None = None) -> pd.DataFrame:
    """Every saved claim, with verdicts recomputed by :func:`verdict` (never read back as text)."""
    d = Path(directory) if directory is not None else claims_dir()
    rows = []
    for path in sorted(d.glob("*.json")):
        for row in json.loads(path.read_text(encoding="utf-8")):
            for computed in ("verdict", "cause", "runs_needed"):
                row.pop(computed, None)
            rows.append(Claim(**row).as_row())
    cols = list(Claim.__dataclass_fields__) + ["verdict", "cause", "runs_needed"]
    return pd.DataFrame(rows, columns=cols)


def plan_problems(claims) -> list:
    """What keeps a claim's evidence from being planned (empty when none): an ordering (``diff`` or
    ``reading_diffs``, not a cost count) must state its size -- the printed ``effect`` or a ``margin``
    -- and the runs behind each difference, so that an undecided one says how many runs would decide it."""
    out = []
    for c in as_claims(claims):
        if c.not_checkable or c.basis == "count" or not (c.diff is not None or c.reading_diffs):
            continue
        if not (_isnum(c.effect) or _isnum(c.margin)):
            out.append(f"{c.paper}:{c.claim_id}: an ordering without a printed effect or a stated margin")
        runs = [c.runs] if c.diff is not None and not c.reading_diffs else [
            _diff_triple(v)[2] for k, v in c.reading_diffs.items() if k not in (c.excluded or {})]
        if not all(runs):
            out.append(f"{c.paper}:{c.claim_id}: a difference without the runs behind it")
    return out


def check_saved_claims(directory: Path | None = None) -> int:
    """Check every saved claim's free-choice dependencies against its chapter's saved
    assumptions (:func:`pfrepro.choices.check_claim`) and that every ordering can be planned
    (:func:`plan_problems`); returns the number of claims checked, raises
    :class:`pfrepro.choices.FreeChoiceError` on the first uncovered claim and ``ValueError`` listing
    the orderings without a size or runs."""
    from .choices import check_claim, load_choices

    d = Path(directory) if directory is not None else claims_dir()
    n = 0
    problems = plan_problems(load_all_claims(d))
    if problems:
        raise ValueError(f"{len(problems)} saved claim(s) cannot be planned:\n" + "\n".join(problems))
    for path in sorted(d.glob("*.json")):
        paper = path.stem
        choices = load_choices(paper, d)
        for row in json.loads(path.read_text(encoding="utf-8")):
            check_claim(f"{paper}:{row['claim_id']}", row.get("depends_on"),
                        {**(row.get("readings") or {}), **(row.get("reading_diffs") or {})},
                        row.get("reading_values"), choices)
            n += 1
    return n
