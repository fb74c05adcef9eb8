"""Sphinx extension: author-year labels in the bibliography, matching the in-text citations.

The text cites with ``bibtex_reference_style = author_year`` ("Gordon et al., 1993"), but the
bibliography list used pybtex's default *alpha* labels ("[GSS93]"), so a reader could not match
one with the other. This registers a pybtex formatting style ``authoryear``: the *unsrt* entry
format, sorted by author, year and title, labelled "Gordon et al., 1993" (one author: "Kalman,
1960"; two: "Wan and van der Merwe, 2000"); a repeated label gets a, b, ... like the text.
Enable with ``bibtex_default_style: authoryear`` (``_config.yml``).
"""
from __future__ import annotations

from collections import Counter

from pybtex.plugin import register_plugin
from pybtex.richtext import Text
from pybtex.style.formatting.unsrt import Style as UnsrtStyle
from pybtex.style.labels import BaseLabelStyle
from pybtex.style.sorting.author_year_title import SortingStyle


def _last(person) -> str:
    parts = person.prelast_names + person.last_names
    return Text(" ".join(parts)).render_as("text").replace("{", "").replace("}", "")


class AuthorYearLabelStyle(BaseLabelStyle):
    def format_labels(self, sorted_entries):
        labels = []
        for entry in sorted_entries:
            people = entry.persons.get("author") or entry.persons.get("editor") or []
            if not people:
                who = entry.fields.get("key", entry.key)
            elif len(people) == 1:
                who = _last(people[0])
            elif len(people) == 2:
                who = f"{_last(people[0])} and {_last(people[1])}"
            else:
                who = f"{_last(people[0])} et al."
            labels.append(f"{who}, {entry.fields.get('year', 'n.d.')}")
        counts = Counter(labels)
        seen = Counter()
        for label in labels:
            if counts[label] > 1:
                seen[label] += 1
                yield label + "abcdefghijklmnopqrstuvwxyz"[seen[label] - 1]
            else:
                yield label


class AuthorYearStyle(UnsrtStyle):
    default_label_style = AuthorYearLabelStyle
    default_sorting_style = SortingStyle


def setup(app):
    register_plugin("pybtex.style.formatting", "authoryear", AuthorYearStyle)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
