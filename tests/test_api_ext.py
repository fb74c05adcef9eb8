"""book/_ext/pfrepro_sphinx.py: "(module docstring)" pointers in docstrings become links."""
import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("pfrepro_sphinx", ROOT / "book/_ext/pfrepro_sphinx.py")
ext = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ext)

DOCUMENTED = {"pfrepro.filters", "pfrepro.filters.dual_pf", "pfrepro.models"}


@pytest.mark.parametrize("before, after", [
    ("Hou & Yin's dual particle filter (module docstring).",
     "Hou & Yin's dual particle filter (described with :mod:`pfrepro.filters.dual_pf`)."),
    ("ESPF as reconstructed; see the module docstring.",
     "ESPF as reconstructed; see the description of :mod:`pfrepro.filters.dual_pf`."),
    ("Steps 2.1-2.5 of the module docstring: predict",
     "Steps 2.1-2.5 of the description of :mod:`pfrepro.filters.dual_pf`: predict"),
    ("(see the module docstring)", "(described with :mod:`pfrepro.filters.dual_pf`)"),
    ("The verdict word (see there and the module docstring).",
     "The verdict word (see there and the description of :mod:`pfrepro.filters.dual_pf`)."),
    ("A line that says nothing of it.", "A line that says nothing of it."),
])
def test_module_docstring_pointer_becomes_a_link(before, after):
    lines = [before]
    ext.link_module_docstring(lines, "pfrepro.filters.dual_pf", DOCUMENTED)
    assert lines == [after]


def test_an_undocumented_module_links_to_its_package_or_is_named():
    lines = ["The UNGM (module docstring)."]
    ext.link_module_docstring(lines, "pfrepro.models.ungm", DOCUMENTED)
    assert lines == ["The UNGM (described with :mod:`pfrepro.models`)."]
    lines = ["Nothing documented (module docstring)."]
    ext.link_module_docstring(lines, "elsewhere.mod", DOCUMENTED)
    assert lines == ["Nothing documented (described with ``elsewhere.mod``)."]


def test_documented_modules_are_read_from_the_api_pages():
    found = ext.documented_modules(ROOT / "book")
    assert {"pfrepro.filters", "pfrepro.filters.dual_pf", "pfrepro.claims"} <= found
    assert all(re.fullmatch(r"[\w.]+", m) for m in found)


def test_no_docstring_pointer_is_left_unlinked():
    """Every "module docstring" in the package's docstrings is one the extension rewrites."""
    bad = []
    documented = ext.documented_modules(ROOT / "book")
    for path in sorted((ROOT / "src/pfrepro").rglob("*.py")):
        for no, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if "module docstring" in line:
                probe = [line]
                ext.link_module_docstring(probe, "pfrepro.x", documented | {"pfrepro.x"})
                if "module docstring" in probe[0]:
                    bad.append(f"{path.name}:{no}: {line.strip()}")
    assert not bad, "\n".join(bad)


def _class_with_fields(described=("x", "P"), members=(("x", ""), ("P", ""), ("runs", "Number of runs."))):
    """A doctree like autodoc's: a class whose "Variables" field list describes some fields, then an
    attribute entry per member (empty unless it has its own docstring)."""
    from docutils import nodes
    from docutils.utils import new_document
    from docutils.frontend import get_default_settings
    from docutils.parsers.rst import Parser
    from sphinx import addnodes

    doc = new_document("test", get_default_settings(Parser))
    cls = addnodes.desc(objtype="class")
    cls += addnodes.desc_signature(ids=["pkg.R"], fullname="R")
    content = addnodes.desc_content()
    items = nodes.bullet_list()
    for name in described:
        items += nodes.list_item("", nodes.paragraph("", "", nodes.strong(text=name), nodes.Text(f" – the {name}")))
    content += nodes.field_list("", nodes.field("", nodes.field_name(text="Variables"), nodes.field_body("", items)))
    for name, text in members:
        m = addnodes.desc(objtype="attribute")
        m += addnodes.desc_signature(ids=[f"pkg.R.{name}"], fullname=f"R.{name}")
        body = addnodes.desc_content()
        if text:
            body += nodes.paragraph(text=text)
        m += body
        content += m
    cls += content
    doc += cls
    return doc


def test_a_field_described_by_its_class_is_listed_once():
    from sphinx import addnodes

    doc = _class_with_fields()
    assert ext.merge_described_fields(doc) == 2
    left = [d for d in doc.findall(addnodes.desc) if d.get("objtype") == "attribute"]
    assert [d[0]["fullname"] for d in left] == ["R.runs"]      # it has a description of its own
    # the anchors moved to the field's line, so links to R.x still land on its description
    lines = {li.astext().split(" ")[0]: li["ids"] for li in doc.findall(lambda n: n.tagname == "list_item")}
    assert lines == {"x": ["pkg.R.x"], "P": ["pkg.R.P"]}


def test_fields_without_a_description_in_the_class_stay():
    doc = _class_with_fields(described=())
    assert ext.merge_described_fields(doc) == 0
