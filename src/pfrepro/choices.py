"""Free choices: the values a paper leaves open, and how each verdict survives them.

Every chapter's assumptions table lists the settings the paper does not fix (a step
coefficient, a noise level, a threshold, a reading of an ambiguous sentence) as
:class:`FreeChoice` rows, each with one of three statuses:

``fixed by the paper``
    the paper states the value (the row documents where); nothing to vary.
``does not matter (sweep)``
    the chapter sweeps the value over its plausible range (with a figure or a table)
    and every claim that depends on it is decided at every swept value.
``reading``
    the chapter runs each admissible value (a *reading* of the paper) and every claim
    that depends on it is decided under every reading.
``design choice``
    a value we chose where the paper says nothing (its reason given); no verdict may rest on
    it unless it is also run at another value (tagged readings, as for a reading).

A row *fixed by the paper* cites the paper's place in ``source`` (a line, section, table,
figure or equation); a value we chose is never *fixed by the paper*.

The rule (CONTRIBUTING.md, *Free choices*): a claim that depends on a choice which
is not fixed by the paper declares it (``depends_on=`` in
:meth:`pfrepro.claims.ClaimsRegistry.add`) and is decided under every value of it
(``readings=`` for an ordering or a statement, ``reading_values=`` for a published
number); the verdict holds only if it holds under all of them, otherwise it is
*inconclusive*. Reading names are tagged with the choice they vary,
``"<choice>=<value>"`` (build them with :func:`over`), so the registry can check that
each declared dependency is covered; :func:`check_claim` is that check, run when a
claim is added, again on the saved claims by the scorecard, and in the tests.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import pandas as pd

__all__ = ["FreeChoice", "FIXED", "SWEEP", "READING", "DESIGN", "STATUSES", "reading_values_of", "over", "choices_table",
           "as_choice_map", "check_claim", "FreeChoiceError", "save_choices", "load_choices"]

FIXED = "fixed by the paper"
SWEEP = "does not matter (sweep)"
READING = "reading"
DESIGN = "design choice"
#: The statuses a row of an assumptions table can have.
STATUSES = (FIXED, SWEEP, READING, DESIGN)


class FreeChoiceError(ValueError):
    """A claim depends on a free choice and is not decided under its readings or sweep."""


@dataclass(frozen=True)
class FreeChoice:
    """One row of a chapter's assumptions table.

    Parameters
    ----------
    name : str
        Short identifier, used in ``depends_on`` and as the tag of reading names
        (``"d=0.1"``); letters, digits, ``_`` and ``.`` only.
    value : str
        The value of the main reading (the one the chapter's tables show), as text.
    status : str
        One of :data:`STATUSES`.
    reason : str
        Why this value (and, for a sweep or a reading, which other values are run).
    source : str, optional
        Where the paper says (or does not say) it.
    """

    name: str
    value: str
    status: str
    reason: str
    source: str = ""

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name or any(
                not (ch.isalnum() or ch in "_.") for ch in self.name):
            raise ValueError(f"FreeChoice name must be a non-empty identifier, got {self.name!r}")
        if self.status not in STATUSES:
            raise ValueError(f"FreeChoice {self.name!r}: status must be one of {STATUSES}, got {self.status!r}")
        for field in ("value", "reason", "source"):
            if not isinstance(getattr(self, field), str):
                raise TypeError(f"FreeChoice {self.name!r}: {field} must be a str")
        if not self.reason.strip():
            raise ValueError(f"FreeChoice {self.name!r}: give the reason for the value")


def over(choice: str, values: dict) -> dict:
    """Reading names for one choice: ``{value: x}`` -> ``{"<choice>=<value>": x}``.

    Parameters
    ----------
    choice : str
        The ``FreeChoice.name`` the readings vary.
    values : dict
        Value of the choice (printed as given) -> what holds or was measured under it.

    Returns
    -------
    dict
        The same items with tagged keys, ready for ``readings=`` / ``reading_values=``
        (merge several with ``{**over("a", ...), **over("b", ...)}``).
    """
    return {f"{choice}={k}": v for k, v in dict(values).items()}


def as_choice_map(choices) -> dict:
    """``{name: FreeChoice}`` from an iterable of :class:`FreeChoice` (or such a dict); names unique."""
    if choices is None:
        return {}
    items = list(choices.values()) if isinstance(choices, dict) else list(choices)
    out = {}
    for c in items:
        if not isinstance(c, FreeChoice):
            raise TypeError(f"choices must be FreeChoice rows, got {type(c).__name__}")
        if c.name in out:
            raise ValueError(f"free choice {c.name!r} listed twice")
        out[c.name] = c
    return out


def _tags(keys) -> set:
    tags = set()
    for k in keys or ():
        for part in str(k).split(","):
            if "=" in part:
                tags.add(part.split("=", 1)[0].strip())
    return tags


def _norm(v) -> str:
    return " ".join(str(v).strip().lower().split())


def reading_values_of(choice: str, keys) -> set:
    """The values of ``choice`` named by the reading names ``keys`` (``"<choice>=<value>"`` parts)."""
    out = set()
    for k in keys or ():
        for part in str(k).split(","):
            if "=" in part:
                name, value = part.split("=", 1)
                if name.strip() == choice:
                    out.add(value.strip())
    return out


def check_claim(claim_id: str, depends_on, readings, reading_values, choices) -> None:
    """Raise :class:`FreeChoiceError` unless every free choice the claim depends on is covered.

    A dependency on a choice with status ``reading`` or ``sweep`` is covered when some
    reading name of the claim (``readings`` or ``reading_values``) is tagged with it
    (``"<choice>=..."``, several tags joined by commas). Unknown choice names are errors
    too (a typo would otherwise hide a dependency).
    """
    cmap = as_choice_map(choices)
    tags = _tags(readings) | _tags(reading_values)
    undeclared = sorted((tags & set(cmap)) - set(depends_on or ()))
    if undeclared:
        raise FreeChoiceError(f"claim {claim_id!r} is decided under readings of {undeclared} but does not declare "
                              f"them in depends_on: a verdict that changes with a choice must say it rests on it")
    for name in depends_on or ():
        if name not in cmap:
            raise FreeChoiceError(f"claim {claim_id!r} depends on {name!r}, which is not a row of the "
                                  f"assumptions table (known: {', '.join(sorted(cmap)) or 'none'})")
        c = cmap[name]
        if c.status != FIXED and name not in tags:
            raise FreeChoiceError(
                f"claim {claim_id!r} depends on the free choice {name!r} ({c.status}) but is decided under "
                f"no value of it: pass readings=/reading_values= tagged '{name}=<value>' (pfrepro.choices.over)")
        if c.status != FIXED:
            values = reading_values_of(name, list(readings or ()) + list(reading_values or ()))
            if values and all(_norm(v) == _norm(c.value) for v in values):
                raise FreeChoiceError(
                    f"claim {claim_id!r} depends on the free choice {name!r} but is decided only at its main "
                    f"value {c.value!r}: run another value of it as a reading")


def choices_table(choices) -> pd.DataFrame:
    """The assumptions table a chapter shows: choice, value, status, reason (and source)."""
    rows = [{"choice": c.name, "value": c.value, "status": c.status, "reason": c.reason,
             "paper": c.source} for c in as_choice_map(choices).values()]
    df = pd.DataFrame(rows, columns=["choice", "value", "status", "reason", "paper"])
    if not df["paper"].astype(bool).any():
        df = df.drop(columns="paper")
    return df


def save_choices(paper: str, choices, directory: Path) -> Path:
    """Write a paper's free choices next to its claims (``<directory>/choices/<paper>.json``)."""
    d = Path(directory) / "choices"
    d.mkdir(parents=True, exist_ok=True)
    path = d / f"{paper}.json"
    path.write_text(json.dumps([asdict(c) for c in as_choice_map(choices).values()], indent=1),
                    encoding="utf-8")
    return path


def load_choices(paper: str, directory: Path) -> dict:
    """The free choices :func:`save_choices` wrote for ``paper`` (empty if none were saved)."""
    path = Path(directory) / "choices" / f"{paper}.json"
    if not path.exists():
        return {}
    return as_choice_map(FreeChoice(**row) for row in json.loads(path.read_text(encoding="utf-8")))
