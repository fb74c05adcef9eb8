"""Code identity: which pfrepro sources a process runs, checked on every task sent to a worker.

A worker of a process pool or of a dask cluster runs the code it *imported*, which need not
be the code of the process that sends it work (another checkout, a worker that joined with
an edited copy) nor the code on disk now (the sources were edited after it imported them).
Either way its numbers could silently differ from a serial run's. So every pfrepro module's
source is hashed when the module is imported, and every task sent to a worker carries the
sender's identity; the worker compares it with the modules it has loaded, before the task and
again after it (a module imported while the task ran), and raises :class:`CodeIdentityError`,
naming itself and the modules that differ, instead of returning a result.

* :func:`identity` -- this process's code: ``{module: digest}`` for every pfrepro module
  (a loaded one as it was imported, another as it is on disk now) plus the Python (major.minor),
  numpy and scipy versions.
* :func:`differences` -- which of this process's loaded modules (and versions) differ from an
  identity.
* :func:`checked_call` -- run a task on a worker under that check (what
  :func:`pfrepro.montecarlo.run_monte_carlo` and :func:`~pfrepro.montecarlo.map_runs` submit).

How a module is hashed: an import hook records the SHA-256 of the source bytes each pfrepro
module is compiled from, at its import. The modules imported before this one (during the same
``import pfrepro``) are read when this module is imported, a few milliseconds later.
"""
from __future__ import annotations

import hashlib
import importlib.abc
import importlib.machinery
import os
import platform
import sys
import threading
from pathlib import Path

__all__ = ["CodeIdentityError", "identity", "differences", "stale_modules", "checked_call", "worker_name",
           "describe_differences"]

PACKAGE = __name__.rpartition(".")[0] or "pfrepro"
_ROOT = Path(__file__).resolve().parent
#: module name -> digest of the source it was compiled from (at its import in this process)
_RECORDS: dict[str, str] = {}
_LOCK = threading.Lock()
#: path -> ((mtime_ns, size), digest): sources on disk, read again only when they change
_DISK: dict[str, tuple] = {}
#: the entries of an identity that are versions, not modules
ENVIRONMENT_KEYS = ("python", "numpy", "scipy")


class CodeIdentityError(RuntimeError):
    """A worker runs other code (pfrepro sources or Python, numpy, scipy versions) than the process
    that sent it a task; the message names the worker and what differs, in one line."""


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()[:16]


def _ours(name: str) -> bool:
    return name == PACKAGE or name.startswith(PACKAGE + ".")


def _module_name(path: Path) -> str:
    parts = (PACKAGE, *path.relative_to(_ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _record(name: str, source: bytes) -> None:
    with _LOCK:
        _RECORDS[name] = _digest(source)


class _RecordingLoader(importlib.machinery.SourceFileLoader):
    """The standard source loader, recording the digest of the source it compiles (or whose
    cached bytecode it validates against the same file)."""

    def get_code(self, fullname):
        try:
            _record(fullname, self.get_data(self.path))
        except OSError:      # the import itself will say what is wrong
            pass
        return super().get_code(fullname)


class _RecordingFinder(importlib.abc.MetaPathFinder):
    """Finds pfrepro's submodules as the standard path finder does, with :class:`_RecordingLoader`."""

    pfrepro_code_identity = True

    def find_spec(self, fullname, path, target=None):
        if not fullname.startswith(PACKAGE + "."):
            return None
        spec = importlib.machinery.PathFinder.find_spec(fullname, path, target)
        if spec is not None and type(spec.loader) is importlib.machinery.SourceFileLoader:
            spec.loader = _RecordingLoader(spec.loader.name, spec.loader.path)
        return spec


def _record_loaded() -> None:
    """Record every loaded pfrepro module not recorded yet (those imported before the hook), from its file."""
    for name, mod in list(sys.modules.items()):
        if _ours(name) and name not in _RECORDS:
            f = getattr(mod, "__file__", None)
            if f and f.endswith(".py"):
                try:
                    _record(name, Path(f).read_bytes())
                except OSError:
                    _RECORDS[name] = "unreadable"


def _install() -> None:
    if not any(getattr(f, "pfrepro_code_identity", False) for f in sys.meta_path):
        sys.meta_path.insert(0, _RecordingFinder())
    _record_loaded()


def _disk_digest(path: Path) -> str:
    try:
        st = path.stat()
        key = (st.st_mtime_ns, st.st_size)
        hit = _DISK.get(str(path))
        if hit is not None and hit[0] == key:
            return hit[1]
        d = _digest(path.read_bytes())
    except OSError:
        return "missing"
    _DISK[str(path)] = (key, d)
    return d


_ENV: dict = {}


def _environment() -> dict:
    if not _ENV:
        import numpy
        _ENV.update(python=".".join(platform.python_version_tuple()[:2]), numpy=numpy.__version__)
        try:
            import scipy
            _ENV["scipy"] = scipy.__version__
        except ImportError:  # pragma: no cover - scipy is a requirement
            _ENV["scipy"] = "not installed"
    return dict(_ENV)


def identity() -> dict:
    """This process's code: ``{module name: digest}`` of every pfrepro module -- a loaded module as
    it was imported, the others as they are on disk now -- and the ``python``, ``numpy`` and
    ``scipy`` versions."""
    _record_loaded()
    out = {_module_name(f): _disk_digest(f) for f in sorted(_ROOT.rglob("*.py"))}
    out.update(_RECORDS)
    out.update(_environment())
    return out


def stale_modules() -> list:
    """The loaded pfrepro modules whose source file has changed (or gone) since this process imported them."""
    _record_loaded()
    out = []
    for name, d in sorted(_RECORDS.items()):
        f = getattr(sys.modules.get(name), "__file__", None)
        if f and _disk_digest(Path(f)) != d:
            out.append(name)
    return out


def differences(expected: dict) -> list:
    """What of this process differs from the identity ``expected``: the names of its loaded pfrepro
    modules whose source differs (or that ``expected`` does not have), then the versions that differ."""
    _record_loaded()
    diff = [name for name, d in sorted(_RECORDS.items()) if expected.get(name) != d]
    env = _environment()
    return diff + [k for k in ENVIRONMENT_KEYS if expected.get(k) != env.get(k)]


def worker_name() -> str:
    """The dask worker's address when this runs in one, else ``process <pid> on <host>``."""
    if "distributed" in sys.modules:
        try:
            from distributed import get_worker

            w = get_worker()
            return str(w.address) if w.name in (None, w.address) else f"{w.address} (name {w.name})"
        except (ValueError, ImportError, AttributeError):
            pass
    return f"process {os.getpid()} on {platform.node()}"


def describe_differences(diff: list, expected: dict, stale: list | None = None) -> str:
    """One phrase for :func:`differences`' output: what differs and what to do about it."""
    env = _environment()
    mods = [n for n in diff if n not in ENVIRONMENT_KEYS]
    parts = []
    if mods:
        shown = ", ".join(mods[:3]) + (f" and {len(mods) - 3} more" if len(mods) > 3 else "")
        parts.append(f"pfrepro source of {shown}")
    parts += [f"{k} {env.get(k)} (sender {expected.get(k)})" for k in diff if k in ENVIRONMENT_KEYS]
    stale = [n for n in (stale or ()) if n in mods]
    if stale and len(stale) == len(mods):
        hint = "it imported them before they were edited on disk: restart it"
    else:
        hint = "install the sender's checkout and packages on it (pip install -e . of the same commit) and restart it"
    return f"{'; '.join(parts)} differ; {hint}"


def _check(expected: dict) -> None:
    diff = differences(expected)
    if diff:
        what = describe_differences(diff, expected, stale_modules())
        raise CodeIdentityError(f"worker {worker_name()} runs other code than the process that sent it the task: "
                                f"{what}. The run is stopped (its numbers could differ from a serial run's)")


def checked_call(expected: dict, fn, *args, **kwargs):
    """``fn(*args, **kwargs)`` on a worker, refused (:class:`CodeIdentityError`) if the worker's loaded
    code differs from ``expected`` (the sender's :func:`identity`) before the call or after it."""
    _check(expected)
    out = fn(*args, **kwargs)
    _check(expected)   # modules imported while fn ran
    return out


_install()
