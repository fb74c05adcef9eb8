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
    the evidence does not decide: an ordering claim whose paired difference lies
    within ``Z_CRIT`` standard errors of zero (our runs cannot tell the two apart);
    a cost claim that the deterministic cost count does not decide; a conclusion
    whose admissible readings of the paper disagree.

Ordering claims ("A beats B") are decided on paired differences over common
random numbers: the chapter passes ``diff``, the mean over runs of a per-run
difference oriented so that the claim asserts ``diff > 0`` (e.g. RMSE of B minus
RMSE of A, on the same truths), and its standard error ``diff_se``
(:func:`pfrepro.stats.paired_difference`). The claim holds if ``diff > Z_CRIT * diff_se``,
is contradicted if ``diff < -Z_CRIT * diff_se``, and is undecided otherwise.

Cost claims (``basis="count"``) are decided on a deterministic count of what each
filter asks of its model (:mod:`pfrepro.cost`), which does not move with machine
load; the published number (a ratio of the paper's seconds) and our measured time
are context and are not matched numerically: ``qualitative`` is the count's answer,
and ``None`` (the count does not decide) gives ``inconclusive``.

A conclusion that depends on an ambiguous reading of the paper passes ``readings``,
a mapping from each admissible reading to whether the statement holds under it
(True / False / None); the claim holds if it holds under every reading, fails if it
fails under every reading, and is ``inconclusive`` otherwise. A published *number*
judged under several readings passes ``reading_values`` (reading -> ``(ours, se)``
under it, besides the main reading's ``reproduced``/``se``): it is ``reproduced`` only
if it is matched under every reading, and ``inconclusive`` if some readings match it
and others do not. Which free choices a claim rests on is declared in ``depends_on``
and checked against the chapter's assumptions table (:mod:`pfrepro.choices`). An
absolute number that the paper's unpublished settings decide passes
``not_checkable="<why>"``: its verdict is ``not checkable`` whatever the numbers.

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

__all__ = ["Claim", "ClaimsRegistry", "verdict", "VERDICTS", "claims_dir", "load_all_claims",
           "DEFAULT_REL_TOL", "Z_CRIT", "ordering_holds", "weakest_ordering",
           "readings_hold", "claims_table", "BASES", "number_matches", "check_saved_claims"]

VERDICTS = ("reproduced", "qualitatively reproduced", "not reproduced", "not checkable", "inconclusive")
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


def verdict(published=None, reproduced=None, se=None, rel_tol=DEFAULT_REL_TOL, qualitative=None,
            diff=None, diff_se=None, published_se=None, basis="", readings=None,
            reading_values=None, not_checkable="") -> str:
    """The verdict rule (see module docstring). All inputs are numbers or None/bool.

    ``diff``/``diff_se`` (an ordering decided on paired differences) or ``readings``
    (a mapping reading -> holds; with a ``diff`` beside them the readings decide and the
    diff is the main reading's, for display) take the place of ``qualitative`` when given; an
    undecided ordering or disagreeing readings give ``inconclusive`` unless the
    published number itself is matched. ``published_se`` (the paper's own standard
    error) widens the interval: inside iff
    ``|reproduced - published| <= Z_CRIT * sqrt(se**2 + published_se**2)``.
    ``basis="count"``: a cost claim decided by ``qualitative`` alone (the count's answer);
    ``None`` gives ``inconclusive``. ``reading_values`` (reading -> ``(ours, se)``): the
    published number must be matched under the main reading and every other one
    (mixed: ``inconclusive``). ``not_checkable`` (a reason): ``not checkable``.
    """
    if not_checkable:
        return "not checkable"
    basis = basis or ""
    if basis not in BASES:
        raise ValueError(f"basis must be one of {BASES}, got {basis!r}")
    undecided = False
    has_diff = diff is not None or diff_se is not None
    if qualitative is not None and (has_diff or readings is not None):
        raise ValueError("give either qualitative or diff/diff_se or readings, not more than one")
    if readings is not None:
        # the readings decide (the main reading is one of them); a diff given beside them
        # is the main reading's paired difference, shown but not deciding on its own
        qualitative = readings_hold(readings)
        undecided = qualitative is None
    elif has_diff:
        qualitative = ordering_holds(diff, diff_se)
        undecided = qualitative is None
    if basis == "count":
        if qualitative is None:
            return "inconclusive"
        return "reproduced" if bool(qualitative) else "not reproduced"
    if reading_values and not (_isnum(published) and _isnum(reproduced)):
        raise ValueError("reading_values judge a published number: give published and reproduced too")
    if _isnum(published) and _isnum(reproduced):
        matched = [number_matches(published, reproduced, se, published_se, rel_tol)]
        for v in (reading_values or {}).values():
            value, value_se = _reading_pair(v)
            matched.append(_isnum(value) and number_matches(published, value, value_se, published_se, rel_tol))
        if all(matched):
            return "reproduced"
        if any(matched):
            return "inconclusive"  # the readings disagree about the number
        if qualitative is not None and bool(qualitative):  # also numpy.bool_(True)
            return "qualitatively reproduced"
        return "inconclusive" if undecided else "not reproduced"
    if undecided:
        return "inconclusive"
    if qualitative is None:
        return "not checkable"
    return "reproduced" if bool(qualitative) else "not reproduced"


@dataclass
class Claim:
    """One claim of one paper, with the numbers its verdict is computed from."""

    paper: str
    claim_id: str
    text: str
    published: float | None = None
    reproduced: float | None = None
    se: float | None = None
    rel_tol: float | None = DEFAULT_REL_TOL
    qualitative: bool | None = None
    source: str = ""   # where in the paper (table/figure/section)
    note: str = ""     # what was compared, in a few words
    diff: float | None = None     # paired difference (claim asserts diff > 0), see paired_difference
    diff_se: float | None = None  # its standard error
    published_se: float | None = None  # the paper's own standard error (printed spread / per-run rows)
    basis: str = ""               # "count": a cost claim decided on a deterministic cost count
    readings: dict | None = None  # reading of the paper -> does the statement hold under it
    reading_values: dict | None = None  # reading -> [ours, se] of a published number under it
    depends_on: list | None = None      # free choices (pfrepro.choices) the verdict rests on
    not_checkable: str = ""             # why the paper's unpublished settings decide this number
    published_text: str | None = None   # ``published`` exactly as the paper prints it (pfrepro.published.printed)

    @property
    def verdict(self) -> str:
        """The verdict, recomputed from the stored numbers by :func:`verdict` (never stored as text)."""
        return verdict(self.published, self.reproduced, self.se, self.rel_tol, self.qualitative,
                       self.diff, self.diff_se, self.published_se, self.basis, self.readings,
                       self.reading_values, self.not_checkable)

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
            parts.append(f"paired diff {_fmt(self.diff)} ± {_fmt(self.diff_se)} (z = {z:.1f}; decided at |z| > {Z_CRIT:g})")
        if self.readings:
            word = {True: "holds", False: "fails", None: "undecided"}
            parts.append("readings: " + "; ".join(f"{k} → {word[None if v is None else bool(v)]}"
                                                   for k, v in self.readings.items()))
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
            if self.readings:
                out += ", else ordering" + every
            elif self.diff is not None or self.qualitative is not None:
                out += ", else ordering"
            return out
        if self.readings:
            return ("ordering" if self.diff is not None else "statement") + every
        if self.diff is not None or self.diff_se is not None:
            return "ordering (paired)"
        if self.qualitative is not None:
            return "statement" + (" (number: context)" if _isnum(self.reproduced) else "")
        return "–"

    def as_row(self) -> dict:
        """The claim's fields and its verdict as a dict (one row of the scorecard / JSON file)."""
        d = asdict(self)
        d["verdict"] = self.verdict
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
    if isinstance(claims, ClaimsRegistry):
        items = list(claims.claims)
    elif isinstance(claims, pd.DataFrame):
        fields = set(Claim.__dataclass_fields__)
        items = [Claim(**{k: (None if (isinstance(v, float) and math.isnan(v)) else v)
                          for k, v in row.items() if k in fields})
                 for row in claims.to_dict("records")]
    else:
        items = list(claims)
    rows = []
    for c in items:
        if _isnum(c.reproduced):
            ours = _pm(c.reproduced, c.se)
        elif c.diff is not None:
            ours = "Δ " + _pm(c.diff, c.diff_se)
        elif c.readings:
            ours = f"{sum(bool(v) for v in c.readings.values() if v is not None)}/{len(c.readings)} readings hold"
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
                    "judged": c.judged(), "verdict": c.verdict, "test": c.test_text()})
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
            depends_on=None, not_checkable="", published_text=None) -> Claim:
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

        check_claim(claim_id, depends_on, readings, reading_values, self.choices)
        c = Claim(self.paper, claim_id, text, _clean(published), _clean(reproduced), _clean(se),
                  _clean(rel_tol), qualitative, source, note, _clean(diff), _clean(diff_se),
                  _clean(published_se), basis, readings, reading_values, depends_on, str(not_checkable or ""),
                  published_text or None)
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
            row.pop("verdict", None)
            rows.append(Claim(**row).as_row())
    cols = list(Claim.__dataclass_fields__) + ["verdict"]
    return pd.DataFrame(rows, columns=cols)


def check_saved_claims(directory: Path | None = None) -> int:
    """Check every saved claim's free-choice dependencies against its chapter's saved
    assumptions (:func:`pfrepro.choices.check_claim`); returns the number of claims
    checked, raises :class:`pfrepro.choices.FreeChoiceError` on the first uncovered one."""
    from .choices import check_claim, load_choices

    d = Path(directory) if directory is not None else claims_dir()
    n = 0
    for path in sorted(d.glob("*.json")):
        paper = path.stem
        choices = load_choices(paper, d)
        for row in json.loads(path.read_text(encoding="utf-8")):
            check_claim(f"{paper}:{row['claim_id']}", row.get("depends_on"), row.get("readings"),
                        row.get("reading_values"), choices)
            n += 1
    return n
