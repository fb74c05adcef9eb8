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
"""
import importlib
import inspect

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


def setup(app):
    _one_blas_thread_in_kernels()
    app.connect("config-inited", _tuples)
    app.add_directive("pfrepro-summary", PackageSummary)
    app.add_directive("pfrepro-module", ModuleRest)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
