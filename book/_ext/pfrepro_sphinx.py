"""Sphinx glue for the API reference (loaded through ``sphinx.local_extensions`` in _config.yml).

* YAML has no tuples, but Sphinx matches ``nitpick_ignore`` entries as ``(type, target)``
  tuples; this turns the ``[type, target]`` pairs of _config.yml into tuples.
* ``.. pfrepro-summary:: pfrepro.filters`` -- the summary table of a package, generated from its
  ``__all__`` (its classes and functions; constants are documented below the table), so the
  table cannot omit what the package exports.
* ``.. pfrepro-module:: pfrepro.filters.dual_pf`` with ``:package: pfrepro.filters`` -- the
  module's docstring and the members it does *not* re-export through the package (those are
  documented once, under the package) and that it defines itself (a name it imports from a
  sibling, kept importable there, is documented with the sibling), so nothing is documented twice.
* "(module docstring)" in a docstring (a class or function pointing to the method its module's
  docstring describes) becomes a link to that module's section of the reference ("described
  with ``pfrepro.filters.dual_pf``", "see the description of ``pfrepro.claims``"), or to the
  nearest package documented, so the pointer leads somewhere on the page instead of naming a
  Python attribute the reader cannot open.
* A class whose docstring describes its fields (an ``Attributes`` section, shown as
  "Variables") lists each field once: the empty entry that ``:undoc-members:`` adds for the
  same field below it is dropped, and its anchor moves to the field's line, so links to
  ``Class.field`` still land on its description.
"""
import importlib
import inspect
import re
from pathlib import Path

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective


def _tuples(app, config):
    for name in ("nitpick_ignore", "nitpick_ignore_regex"):
        value = getattr(config, name, None)
        if value:
            setattr(config, name, [tuple(v) for v in value])


def _one_blas_thread_in_kernels():
    """Chapter kernels (started by myst-nb from this process) inherit ``OPENBLAS_NUM_THREADS=1``.

    The chapters parallelise over Monte Carlo runs on a two-worker process pool whose workers
    already run BLAS on one thread (``pfrepro.montecarlo.process_pool``); a kernel's own BLAS
    threads spin against those workers and gain nothing on the small matrix products of these
    filters (the bearings-only PF(4000) ran 2.7x slower with two BLAS threads than with one
    on a loaded machine). Numbers do not change: the filters' outputs are bit-identical with
    one and two BLAS threads (checked for the PF, EKF, UKF, GPFF and the IMM filters). A value
    the user has set is kept.
    """
    import os
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def _public(mod) -> list[str]:
    names = getattr(mod, "__all__", None)
    if names is None:
        names = [n for n, o in vars(mod).items() if not n.startswith("_")
                 and getattr(o, "__module__", None) == mod.__name__]
    return list(names)


class _Generated(SphinxDirective):
    def _parse(self, lines: list[str]) -> list[nodes.Node]:
        node = nodes.container()
        self.state.nested_parse(StringList(lines, source=self.get_source_info()[0]), self.content_offset, node)
        return node.children


class PackageSummary(_Generated):
    required_arguments = 1

    def run(self):
        name = self.arguments[0]
        mod = importlib.import_module(name)
        items = [n for n in mod.__all__ if inspect.isclass(getattr(mod, n)) or callable(getattr(mod, n))]
        return self._parse([f".. currentmodule:: {name}", "", ".. autosummary::", "   :nosignatures:", ""]
                           + [f"   {n}" for n in items])


class ModuleRest(_Generated):
    required_arguments = 1
    option_spec = {"package": str}

    def run(self):
        name = self.arguments[0]
        mod = importlib.import_module(name)
        pkg = importlib.import_module(self.options.get("package") or name.rpartition(".")[0])
        exported = set(pkg.__all__)
        rest = [n for n in _public(mod) if n not in exported
                and getattr(getattr(mod, n, None), "__module__", name) in (name, None)]
        lines = [f".. automodule:: {name}"]
        if rest:
            lines += [f"   :members: {', '.join(rest)}", "   :undoc-members:", "   :show-inheritance:",
                      "   :member-order: bysource"]
        return self._parse(lines)


#: the phrases a docstring uses to point at its module's docstring, and what each becomes
_MODULE_DOCSTRING = (
    (re.compile(r"\((?:see )?(?:the )?module docstring\)"), "(described with :mod:`{mod}`)"),
    (re.compile(r"\b(?:the |its )?module docstring"), "the description of :mod:`{mod}`"),
)
_DIRECTIVE_MODULE = re.compile(r"^\s*\.\.\s+(?:automodule|pfrepro-module|py:module)::\s+(\S+)", re.M)


def documented_modules(srcdir) -> set[str]:
    """The modules the API pages document (each has a ``module-<name>`` target to link to)."""
    found = set()
    for page in Path(srcdir).glob("**/api/*.md"):
        if "_build" not in page.parts:
            found.update(_DIRECTIVE_MODULE.findall(page.read_text(encoding="utf-8")))
    return found


def module_target(name: str, documented: set[str]) -> str | None:
    """``name`` if documented, else its nearest documented package (None if there is none)."""
    while name:
        if name in documented:
            return name
        name = name.rpartition(".")[0]
    return None


def link_module_docstring(lines: list[str], module: str, documented: set[str]) -> None:
    """Rewrite "(module docstring)" pointers in ``lines`` (in place) into links to ``module``."""
    target = module_target(module, documented)
    for i, line in enumerate(lines):
        if "module docstring" not in line:
            continue
        for rx, repl in _MODULE_DOCSTRING:
            if target:
                line = rx.sub(repl.format(mod=target), line)
            else:  # nothing documented to link to: name the module, as code
                line = rx.sub(repl.replace(":mod:`{mod}`", "``{mod}``").format(mod=module), line)
        lines[i] = line


def _process_docstring(app, what, name, obj, options, lines):
    if what == "module":
        return
    module = getattr(obj, "__module__", None) or name.rpartition(".")[0]
    if not isinstance(module, str):
        return
    if not hasattr(app.env, "_pfrepro_documented"):
        app.env._pfrepro_documented = documented_modules(app.srcdir)
    link_module_docstring(lines, module, app.env._pfrepro_documented)


_FIELD_SECTIONS = ("Variables", "Attributes")


def _described_fields(content) -> dict:
    """{field name: the element describing it} from the class body's "Variables" field list."""
    found = {}
    for fl in (c for c in content.children if isinstance(c, nodes.field_list)):
        for field in fl.children:
            if field[0].astext().strip() not in _FIELD_SECTIONS:
                continue
            body = field[1]
            items = list(body.findall(nodes.list_item)) or [p for p in body.children if isinstance(p, nodes.paragraph)]
            for item in items:
                strong = next(iter(item.findall(nodes.strong)), None)
                if strong is not None:
                    found.setdefault(strong.astext().strip(), item)
    return found


def merge_described_fields(doctree) -> int:
    """Drop the empty attribute entries of fields a class's docstring already describes (their
    anchors move to the description); returns how many entries were dropped."""
    from sphinx import addnodes

    dropped = 0
    for cls in list(doctree.findall(addnodes.desc)):
        if cls.get("objtype") not in ("class", "exception"):
            continue
        content = next((c for c in cls.children if isinstance(c, addnodes.desc_content)), None)
        if content is None:
            continue
        described = _described_fields(content)
        if not described:
            continue
        for member in [c for c in content.children if isinstance(c, addnodes.desc)]:
            if member.get("objtype") not in ("attribute", "data"):
                continue
            sigs = [c for c in member.children if isinstance(c, addnodes.desc_signature)]
            body = next((c for c in member.children if isinstance(c, addnodes.desc_content)), None)
            if not sigs or (body is not None and body.astext().strip()):
                continue
            name = sigs[0].get("fullname", "").rpartition(".")[2]
            if name in described:
                for sig in sigs:
                    described[name]["ids"].extend(i for i in sig["ids"] if i not in described[name]["ids"])
                content.remove(member)
                dropped += 1
    return dropped


def _merge_fields(app, doctree):
    merge_described_fields(doctree)


def setup(app):
    _one_blas_thread_in_kernels()
    # before the environment's collectors (the page's contents list) read the doctree
    app.connect("doctree-read", _merge_fields, priority=100)
    app.connect("config-inited", _tuples)
    app.connect("autodoc-process-docstring", _process_docstring)
    app.add_directive("pfrepro-summary", PackageSummary)
    app.add_directive("pfrepro-module", ModuleRest)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
