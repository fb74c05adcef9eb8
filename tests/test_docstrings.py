"""Docstring linter over the public API: every docstring the API reference renders is numpydoc-valid.

``numpydoc.validate`` (pinned in requirements.txt) parses each public object's docstring the
way the reference's napoleon does. A parameter written as ``name : its description`` puts the
description in the italic "(type)" slot of the rendered page; prose run on after the
Parameters section becomes more "parameters"; both show up here as PR02/PR04/PR05/PR07/PR10.

Public API: every name in a module's ``__all__`` (else its public names defined there), and
the public methods and properties those classes define.
"""
from __future__ import annotations

import importlib
import inspect
import pkgutil
import warnings

import pytest

numpydoc_validate = pytest.importorskip("numpydoc.validate")

import pfrepro  # noqa: E402

#: numpydoc checks that decide how a docstring renders (all must pass)
CHECKED = {
    "GL03": "double line break",
    "GL05": "tabs",
    "GL06": "unknown section (the book's one custom section, 'Model methods', is declared in "
            "_config.yml napoleon_custom_sections and accepted below)",
    "GL07": "sections out of order",
    "GL08": "no docstring (a method overriding a documented one inherits it, as autodoc shows it)",
    "GL09": "deprecation warning placement",
    "GL10": "reST directive with one colon",
    "SS01": "no summary",
    "PR02": "documented parameter not in the signature (run-on prose read as parameters)",
    "PR03": "parameters documented out of order",
    "PR04": "parameter with no type",
    "PR05": "type ending in '.' (a description in the type slot)",
    "PR06": "type spelled 'integer'/'boolean'/'string'",
    "PR07": "parameter with no description (a description in the type slot)",
    "PR10": "no space before the colon",
    "RT02": "Returns naming only the type of a single value",
    "RT03": "return value with no description",
    "YD01": "generator with no Yields section",
}
#: numpydoc checks not applied, and why (none of them changes how a page renders)
NOT_CHECKED = {
    "SA01": "a See Also section: the book's chapters are the cross references",
    "EX01": "an Examples section: the chapters are the worked examples",
    "ES01": "an extended summary: optional for small helpers",
    "PR01": "every parameter documented: many small helpers document their settings in the "
            "summary prose; the form of every documented parameter is checked (PR02-PR10)",
    "RT01": "a Returns section on every function: same reason as PR01",
    "PR08": "description starting with a capital letter: style only",
    "PR09": "description ending with a period: style only",
    "RT04": "return description starting with a capital letter: style only",
    "RT05": "return description ending with a period: style only",
    "SS02": "summary starting with a capital letter: style only",
    "SS03": "summary ending with a period: style only",
    "SS04": "summary with leading whitespace: style only",
    "SS05": "summary in the infinitive mood: style only",
    "SS06": "summary on one line: style only (Sphinx renders wrapped summaries as one paragraph)",
    "GL01": "summary on the line after the opening quotes: style only",
    "GL02": "closing quotes on their own line: style only",
    "GL11": "Other Parameters without Parameters: not used in this package",
}


def public_objects() -> dict[str, object]:
    objs: dict[str, object] = {}
    for info in pkgutil.walk_packages(pfrepro.__path__, "pfrepro."):
        if info.name.endswith("__main__"):
            continue
        mod = importlib.import_module(info.name)
        names = getattr(mod, "__all__", None)
        if names is None:
            names = [n for n, o in vars(mod).items() if not n.startswith("_")
                     and getattr(o, "__module__", None) == mod.__name__]
        for n in names:
            o = getattr(mod, n, None)
            if not (inspect.isclass(o) or inspect.isfunction(o)):
                continue
            if not getattr(o, "__module__", "").startswith("pfrepro"):
                continue
            q = f"{o.__module__}.{o.__qualname__}"
            objs[q] = o
            if inspect.isclass(o):
                for an, a in vars(o).items():
                    if an.startswith("_"):
                        continue
                    if inspect.isfunction(a) or isinstance(a, (property, staticmethod, classmethod)):
                        objs[f"{q}.{an}"] = (o, an)
    return objs


def _inherits_doc(o) -> bool:
    """A method without a docstring of its own that overrides a documented base method."""
    if not isinstance(o, tuple):
        return False
    cls, name = o
    return any(getattr(vars(b).get(name), "__doc__", None) for b in cls.__mro__[1:])


def _problems(qualname: str, o) -> list[str]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numpydoc warns about the custom "Model methods" section
        res = numpydoc_validate.validate(qualname)
    out = []
    for code, msg in res["errors"]:
        if code not in CHECKED:
            assert code in NOT_CHECKED, f"numpydoc check {code} neither checked nor explained: {msg}"
            continue
        if code == "GL08" and _inherits_doc(o):
            continue
        if code in ("GL06", "GL07") and "Model methods" in (res["docstring"] or ""):
            # GL06 names the custom section; GL07 fails because of it (numpydoc does not know
            # where it goes): accept both when the section is the only unknown one
            if code == "GL06" and "Model methods" in msg:
                continue
            if code == "GL07":
                continue
        out.append(f"{code} {msg}")
    return out


OBJECTS = public_objects()


def test_the_public_api_is_found():
    assert len(OBJECTS) > 300
    assert "pfrepro.filters.imm.IMMParticleFilter" in OBJECTS


def test_checks_are_explained():
    assert not set(CHECKED) & set(NOT_CHECKED)


@pytest.mark.parametrize("qualname", sorted(OBJECTS))
def test_docstring_is_numpydoc_valid(qualname):
    problems = _problems(qualname, OBJECTS[qualname])
    assert not problems, f"{qualname}:\n  " + "\n  ".join(problems)


# ---- __all__: one source of truth for what a package exports -------------------------------
@pytest.mark.parametrize("package", ["pfrepro.filters", "pfrepro.models"])
def test_every_public_class_is_exported(package):
    """Every public class of the package's modules is in the package's ``__all__`` (the API
    reference's summary table is generated from it) and importable from the package."""
    pkg = importlib.import_module(package)
    missing = []
    for info in pkgutil.iter_modules(pkg.__path__):
        mod = importlib.import_module(f"{package}.{info.name}")
        for name, obj in vars(mod).items():
            if inspect.isclass(obj) and obj.__module__ == mod.__name__ and not name.startswith("_"):
                if name not in pkg.__all__ or getattr(pkg, name, None) is not obj:
                    missing.append(f"{info.name}.{name}")
    assert not missing, f"public classes missing from {package}.__all__: {missing}"
    assert len(set(pkg.__all__)) == len(pkg.__all__)
    assert all(hasattr(pkg, n) for n in pkg.__all__)


def test_package_docstring_lists_every_module():
    listed = " ".join(line.split()[0] + " " + (line.split()[1] if len(line.split()) > 1 else "")
                      for line in pfrepro.__doc__.splitlines() if line[:1].isalpha())
    names = {info.name for info in pkgutil.iter_modules(pfrepro.__path__) if not info.name.startswith("_")}
    missing = [n for n in sorted(names) if n not in listed.replace(",", " ").split()]
    assert not missing, f"pfrepro's docstring does not list {missing}"


# ---- the "(type)" slot holds a type --------------------------------------------------------
#: longest type a docstring may give (the longest real one, "numpy.random.Generator or
#: pfrepro.rng.RunStreams", has 49 characters)
MAX_TYPE_CHARS = 50


def _modules():
    return [importlib.import_module(i.name) for i in pkgutil.walk_packages(pfrepro.__path__, "pfrepro.")
            if not i.name.endswith("__main__")]


def _bad_types(doc: str) -> list[str]:
    """Entries of the parameter-like sections whose type is a description: too long, a sentence
    (ends with "."), "name : text: more" (a colon), or reST markup (rendered raw in the slot)."""
    from numpydoc.docscrape import NumpyDocString

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        parsed = NumpyDocString(doc)
    bad = []
    for section in ("Parameters", "Other Parameters", "Returns", "Yields", "Attributes"):
        for p in parsed[section]:
            t = p.type.strip()
            if (len(t) > MAX_TYPE_CHARS or t.endswith(".") or ": " in t or "`" in t):
                bad.append(f"{section} {p.name!r}: type {t[:70]!r}")
    return bad


@pytest.mark.parametrize("module", [m.__name__ for m in _modules()])
def test_module_docstring_types_are_types(module):
    doc = importlib.import_module(module).__doc__ or ""
    assert not _bad_types(doc), _bad_types(doc)


def test_object_docstring_types_are_types():
    bad = {}
    for q, o in OBJECTS.items():
        obj = getattr(*o) if isinstance(o, tuple) else o
        doc = inspect.getdoc(obj) or ""
        if isinstance(obj, type) and obj.__init__.__doc__ and "Parameters\n" in obj.__init__.__doc__:
            doc += "\n\n" + inspect.cleandoc(obj.__init__.__doc__)
        problems = _bad_types(doc)
        if problems:
            bad[q] = problems
    assert not bad, "\n".join(f"{q}: {p}" for q, p in bad.items())
