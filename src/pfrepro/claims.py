"""Claims registry and the one verdict rule used by every chapter.

A chapter records each claim of its paper as a :class:`Claim` with the
published value (if the paper gives one), our reproduced value, our Monte Carlo
uncertainty (a standard error) and, where the claim is about an ordering or a
trend, whether that statement holds in our runs (computed by code, never
typed). :func:`verdict` turns those numbers into one of four verdicts:

``reproduced``
    a numeric claim whose published value lies within 2 standard errors of ours,
    or within the claim's stated relative tolerance (default 10 %); or a purely
    qualitative claim (no published number) whose statement holds.
``qualitatively reproduced``
    the numbers do not match, but the claim's ordering/trend holds.
``not reproduced``
    neither: our honest run contradicts the claim.
``not checkable``
    the paper gives nothing we can compare with (no number and no testable
    statement).
``inconclusive``
    an ordering claim whose paired difference lies within ``Z_CRIT`` standard
    errors of zero: our runs cannot tell the two apart.

Ordering claims ("A beats B") are decided on paired differences over common
random numbers: the chapter passes ``diff``, the mean over runs of a per-run
difference oriented so that the claim asserts ``diff > 0`` (e.g. RMSE of B minus
RMSE of A, on the same truths), and its standard error ``diff_se``
(:func:`paired_difference`). The claim holds if ``diff > Z_CRIT * diff_se``,
is contradicted if ``diff < -Z_CRIT * diff_se``, and is undecided otherwise.

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

__all__ = ["Claim", "ClaimsRegistry", "verdict", "VERDICTS", "claims_dir", "load_all_claims",
           "DEFAULT_REL_TOL", "Z_CRIT", "paired_difference", "ordering_holds"]

VERDICTS = ("reproduced", "qualitatively reproduced", "not reproduced", "not checkable", "inconclusive")
#: relative tolerance for numeric claims when none is stated
DEFAULT_REL_TOL = 0.10
#: a published value within Z_CRIT standard errors of ours counts as inside our uncertainty
Z_CRIT = 2.0


def _isnum(v) -> bool:
    # numpy scalars (float32, int64, ...) are numbers too; booleans are not
    return isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isfinite(v)


def paired_difference(a, b):
    """Mean and standard error of the per-run differences ``a - b`` (common random numbers).

    ``a`` and ``b`` are per-run values of two methods on the *same* runs (same
    truths). Returns ``(mean, se)`` with ``se = std(a - b, ddof=1) / sqrt(runs)``.
    """
    import numpy as np

    d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    d = d.ravel()
    if d.size < 2 or not np.all(np.isfinite(d)):
        raise ValueError(f"paired_difference needs >= 2 finite paired values, got {d.size}")
    return float(d.mean()), float(d.std(ddof=1) / np.sqrt(d.size))


def ordering_holds(diff, diff_se):
    """True / False / None (undecided) for an ordering asserting ``diff > 0`` (see module docstring)."""
    if not (_isnum(diff) and _isnum(diff_se)) or diff_se < 0:
        raise ValueError(f"ordering needs finite diff and diff_se >= 0, got {diff!r}, {diff_se!r}")
    if diff > Z_CRIT * diff_se:
        return True
    if diff < -Z_CRIT * diff_se:
        return False
    return None


def verdict(published=None, reproduced=None, se=None, rel_tol=DEFAULT_REL_TOL, qualitative=None,
            diff=None, diff_se=None) -> str:
    """The verdict rule (see module docstring). All inputs are numbers or None/bool.

    ``diff``/``diff_se`` (an ordering decided on paired differences) take the place
    of ``qualitative`` when given; an undecided ordering gives ``inconclusive``
    unless the published number itself is matched.
    """
    undecided = False
    if diff is not None or diff_se is not None:
        if qualitative is not None:
            raise ValueError("give either qualitative or diff/diff_se, not both")
        qualitative = ordering_holds(diff, diff_se)
        undecided = qualitative is None
    if _isnum(published) and _isnum(reproduced):
        diff = abs(reproduced - published)
        inside = _isnum(se) and se > 0 and diff <= Z_CRIT * se
        close = diff <= (rel_tol or 0.0) * abs(published)  # rel_tol None: exact agreement only
        if inside or close:
            return "reproduced"
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

    @property
    def verdict(self) -> str:
        return verdict(self.published, self.reproduced, self.se, self.rel_tol, self.qualitative,
                       self.diff, self.diff_se)

    def as_row(self) -> dict:
        d = asdict(self)
        d["verdict"] = self.verdict
        return d


def claims_dir() -> Path:
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

    def __init__(self, paper: str):
        self.paper = paper
        self.claims: list[Claim] = []

    def add(self, claim_id: str, text: str, *, published=None, reproduced=None, se=None,
            rel_tol=DEFAULT_REL_TOL, qualitative=None, source="", note="", diff=None,
            diff_se=None) -> Claim:
        if any(c.claim_id == claim_id for c in self.claims):
            raise ValueError(f"claim {claim_id!r} already recorded for {self.paper}")
        if qualitative is not None and not isinstance(qualitative, (bool,)):
            qualitative = bool(qualitative)
        c = Claim(self.paper, claim_id, text, _clean(published), _clean(reproduced), _clean(se),
                  _clean(rel_tol), qualitative, source, note, _clean(diff), _clean(diff_se))
        c.verdict  # validate now (e.g. both qualitative and diff given), not at the scorecard
        self.claims.append(c)
        return c

    def to_frame(self) -> pd.DataFrame:
        return pd.DataFrame([c.as_row() for c in self.claims])

    def save(self, directory: Path | None = None) -> Path:
        d = Path(directory) if directory is not None else claims_dir()
        d.mkdir(parents=True, exist_ok=True)
        path = d / f"{self.paper}.json"
        path.write_text(json.dumps([c.as_row() for c in self.claims], indent=1), encoding="utf-8")
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
