"""Per-cell execution time of book chapters: where a chapter's build time goes.

Usage::

    python benchmarks/chapter_cells.py book/20_gpff.md [book/60_immpf.md ...] [--top 15]

Each chapter (MyST-Markdown notebook) is read with jupytext and executed with nbclient in
``book/`` (as the book build does); the script prints the chapter's total and its slowest
cells with their first code line. Wall times move with machine load: compare cells within
one run, not across machines.
"""
from __future__ import annotations

import argparse
import time
from datetime import datetime
from pathlib import Path

import jupytext
from nbclient import NotebookClient


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
    args = ap.parse_args(argv)
    for path in args.chapters:
        nb = jupytext.read(path)
        t0 = time.perf_counter()
        NotebookClient(nb, timeout=None, kernel_name="python3", record_timing=True,
                       resources={"metadata": {"path": str(path.parent)}}).execute()
        total = time.perf_counter() - t0
        rows = []
        for i, cell in enumerate(nb.cells):
            if cell.cell_type == "code":
                s = _seconds(cell)
                first = next((ln for ln in cell.source.splitlines()
                              if ln.strip() and not ln.lstrip().startswith("#")), "")
                rows.append((s or 0.0, i, first[:90]))
        rows.sort(reverse=True)
        print(f"== {path}: {total:.1f} s total, {len(rows)} code cells")
        for s, i, first in rows[: args.top]:
            print(f"  {s:7.1f} s  cell {i:3d}  {first}")


if __name__ == "__main__":
    main()
