"""Per-cell execution time of book chapters: where a chapter's build time goes.

Usage::

    python benchmarks/chapter_cells.py book/20_gpff.md [book/60_immpf.md ...] [--top 15]
    python benchmarks/chapter_cells.py book/*_*.md --calls benchmarks/results/chapter_calls.csv

Each chapter (MyST-Markdown notebook) is read with jupytext and executed with nbclient in
``book/`` (as the book build does); the script prints the chapter's total and its slowest
cells with their first code line. Wall times move with machine load: compare cells within
one run, not across machines.

``--calls FILE`` also records every Monte Carlo call the chapter makes
(:func:`pfrepro.montecarlo.run_monte_carlo` and :func:`~pfrepro.montecarlo.map_runs`, the
outermost call only, wherever an experiment module imported them): its wall time, runs,
steps, filter names and the chapter line that made it, one CSV row per call. The hook is
installed by a first cell the script adds to its own copy of the notebook; the chapter's
numbers are unchanged (the wrapper only times the call).
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import tempfile
import time
from datetime import datetime
from pathlib import Path

import jupytext
import nbformat
from nbclient import NotebookClient

#: the first cell of the chapter's copy under ``--calls``: wrap the Monte Carlo entry points
#: (in pfrepro.montecarlo and in every experiment module that imported them by name) so that
#: each outermost call appends a JSON line to the file named by PFREPRO_CALL_LOG
_HOOK = '''
import functools as _ft, importlib as _il, inspect as _insp, json as _js, os as _os, pkgutil as _pk, threading as _th, time as _tm
import pfrepro.experiments as _ex, pfrepro.montecarlo as _mc
_depth = _th.local()     # per thread: a chapter may submit Monte Carlo calls from threads (the synthesis does)
_hook_file = _insp.currentframe().f_code.co_filename     # this cell's own frames are skipped
def _cell_line():
    for fr in _insp.stack(context=1):
        if "ipykernel_" in fr.filename and fr.filename != _hook_file:
            return (fr.code_context or ["?"])[0].strip()
    return "?"
def _wrap(fn, kind):
    if getattr(fn, "_timed_call", False):
        return fn
    @_ft.wraps(fn)
    def w(*a, **k):
        _depth.n = getattr(_depth, "n", 0) + 1
        t0 = _tm.perf_counter()
        try:
            return fn(*a, **k)
        finally:
            _depth.n -= 1
            if _depth.n == 0:
                row = {"kind": kind, "wall_s": _tm.perf_counter() - t0, "line": _cell_line()}
                if kind == "run_monte_carlo":
                    f = k.get("filters", a[1] if len(a) > 1 else {})
                    row.update(T=k.get("T", a[2] if len(a) > 2 else None),
                               runs=k.get("runs", a[3] if len(a) > 3 else None), filters="; ".join(f))
                with open(_os.environ["PFREPRO_CALL_LOG"], "a") as fh:
                    fh.write(_js.dumps(row, default=str) + "\\n")
    w._timed_call = True
    return w
for _name in ("run_monte_carlo", "map_runs"):
    setattr(_mc, _name, _wrap(getattr(_mc, _name), _name))
    for _m in _pk.iter_modules(_ex.__path__):
        _mod = _il.import_module(f"pfrepro.experiments.{_m.name}")
        if hasattr(_mod, _name):
            setattr(_mod, _name, _wrap(getattr(_mod, _name), _name))
'''


def _seconds(cell) -> float | None:
    ex = cell.get("metadata", {}).get("execution", {})
    t0, t1 = ex.get("iopub.execute_input"), ex.get("shell.execute_reply")
    if not (t0 and t1):
        return None
    parse = lambda s: datetime.fromisoformat(s.replace("Z", "+00:00"))  # noqa: E731
    return (parse(t1) - parse(t0)).total_seconds()


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("chapters", nargs="+", type=Path)
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--calls", type=Path, default=None,
                    help="CSV of every Monte Carlo call (chapter, line, runs, T, filters, wall seconds)")
    args = ap.parse_args(argv)
    call_rows = []
    for path in args.chapters:
        nb = jupytext.read(path)
        log = None
        if args.calls:
            fd, log = tempfile.mkstemp(suffix=".jsonl")
            os.close(fd)
            os.environ["PFREPRO_CALL_LOG"] = log          # the kernel inherits it
            nb.cells.insert(0, nbformat.v4.new_code_cell(_HOOK))
        t0 = time.perf_counter()
        NotebookClient(nb, timeout=None, kernel_name="python3", record_timing=True,
                       resources={"metadata": {"path": str(path.parent)}}).execute()
        total = time.perf_counter() - t0
        rows = []
        skip = 1 if log else 0       # the hook cell is not the chapter's: number the chapter's cells as in the file
        for i, cell in enumerate(nb.cells[skip:]):
            if cell.cell_type == "code":
                s = _seconds(cell)
                first = next((ln for ln in cell.source.splitlines()
                              if ln.strip() and not ln.lstrip().startswith("#")), "")
                rows.append((s or 0.0, i, first[:90]))
        rows.sort(reverse=True)
        print(f"== {path}: {total:.1f} s total, {len(rows)} code cells")
        for s, i, first in rows[: args.top]:
            print(f"  {s:7.1f} s  cell {i:3d}  {first}")
        if log:
            calls = [json.loads(ln) for ln in Path(log).read_text().splitlines()]
            Path(log).unlink()
            mc = sum(c["wall_s"] for c in calls)
            print(f"  Monte Carlo calls: {len(calls)}, {mc:.1f} s of {total:.1f} s")
            call_rows += [{"chapter": path.stem, "chapter_s": round(total, 2), **c} for c in calls]
    if args.calls:
        args.calls.parent.mkdir(parents=True, exist_ok=True)
        keys = ("chapter", "chapter_s", "kind", "wall_s", "runs", "T", "filters", "line")
        with open(args.calls, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
            w.writeheader()
            for r in call_rows:
                w.writerow({**r, "wall_s": round(r["wall_s"], 3)})
        print(f"wrote {args.calls} ({len(call_rows)} calls)")


if __name__ == "__main__":
    main()
