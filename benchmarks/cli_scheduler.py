"""`pfrepro run PAPER --runs R` serially against `--scheduler` on a local dask cluster.

Starts a ``LocalCluster`` (``--workers`` worker processes, one thread each, on 127.0.0.1),
then times two complete command-line runs as subprocesses (imports, experiments, figures,
files): ``--jobs 1`` and ``--scheduler <the cluster>``, and checks that every output file is
the same bytes. The cluster's start-up is timed apart (a real cluster is started once and
reused). The load average is printed beside the times: on a shared machine it says how much
of the two cores the runs could have had. Run from the repository root::

    python benchmarks/cli_scheduler.py --paper li2012 --runs 1000

A script for the performance note, not a test (tests/test_cli_dask.py checks the identity
on a small run).
"""
from __future__ import annotations

import argparse
import datetime as _dt
import filecmp
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _load() -> str:
    return "/".join(f"{v:.1f}" for v in os.getloadavg())


def _run(argv: list[str], out: Path) -> tuple[float, str, str]:
    """Wall time of one ``python -m pfrepro run ...`` and the load average before and after it."""
    before = _load()
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "pfrepro", "run", *argv, "--out", str(out)],
                          capture_output=True, text=True, env={**os.environ, "CI": "1"})
    dt = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"pfrepro run {' '.join(argv)} failed:\n{proc.stderr}")
    return dt, before, _load()


def _files(d: Path) -> list[Path]:
    return sorted(p.relative_to(d) for p in d.rglob("*") if p.is_file())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paper", default="li2012")
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)

    import distributed

    common = [args.paper, "--runs", str(args.runs)] + ([] if args.seed is None else ["--seed", str(args.seed)])
    with tempfile.TemporaryDirectory(prefix="pfrepro-sched-") as tmp:
        tmp = Path(tmp)
        t_serial, l0, l1 = _run([*common, "--jobs", "1"], tmp / "serial")
        t0 = time.perf_counter()
        with distributed.LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                                      host="127.0.0.1", dashboard_address=":0") as cluster:
            t_up = time.perf_counter() - t0
            t_dask, l2, l3 = _run([*common, "--scheduler", cluster.scheduler_address], tmp / "dask")
        a, b = _files(tmp / "serial"), _files(tmp / "dask")
        differ = [str(f) for f in a if f in b and not filecmp.cmp(tmp / "serial" / f, tmp / "dask" / f, shallow=False)]
        same = a == b and not differ
        print(f"# `pfrepro run {' '.join(common)}`: serial vs --scheduler ({args.workers}-worker LocalCluster)\n")
        print(f"{_dt.datetime.now().isoformat(timespec='seconds')}, {platform.node()}, {os.cpu_count()} cores, "
              f"Python {platform.python_version()}\n")
        print("| run | wall time (s) | load average (1/5/15 min) before | after |")
        print("|---|---|---|---|")
        print(f"| --jobs 1 (serial) | {t_serial:.1f} | {l0} | {l1} |")
        print(f"| --scheduler, {args.workers} workers | {t_dask:.1f} | {l2} | {l3} |")
        print(f"\ncluster start-up (not in the time above): {t_up:.1f} s; speed-up {t_serial / t_dask:.2f}x")
        print(f"{len(a)} output files; byte-identical: {same}" + (f" (differ: {', '.join(differ)})" if differ else "")
              + ("" if a == b else f" (file lists differ: {sorted(set(map(str, a)) ^ set(map(str, b)))})"))
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
