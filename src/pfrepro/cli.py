"""The ``pfrepro`` command line: list the papers, rerun one, print a scorecard.

::

    pfrepro list
    pfrepro run <paper> [--runs R] [--seed S] [--jobs J | --scheduler ADDRESS] [--out DIR]
    pfrepro scorecard [--format table|csv|json] [--dir DIR]

``run`` makes the chapter's own call, :meth:`pfrepro.papers.Paper.run` (every experiment,
reading and sweep of the paper, then every claim decided by ``pfrepro.verdicts.<paper>``),
writes every table as CSV and every figure as PNG into ``--out`` (default
``pfrepro-<paper>``), saves the chapter's claims to ``<out>/claims/<paper>.json`` and prints
the verdict summary.
``--jobs J`` spreads the runs over J local processes, ``--scheduler ADDRESS`` over the
workers of a running dask.distributed scheduler (several machines; every worker needs the
same environment, e.g. ``pip install -e .`` of the same commit): the files are the same
bytes either way (per-run random streams, :mod:`pfrepro.montecarlo`).
Bad arguments -- an unreachable scheduler included -- end with a one-line message on
stderr and exit code 2, and so does a run stopped because a worker runs other code than
this process (checked on every task: ``pfrepro._codeid``) or because the scheduler has
had no worker for ``--worker-timeout`` seconds.
"""
from __future__ import annotations

import argparse
import os
import re
import sys
import time
from pathlib import Path

__all__ = ["main", "build_parser", "UsageError"]

EXIT_USAGE = 2
#: the file of ``pfrepro run``'s output directory that holds the measured times (table, row, column, value)
TIMINGS_FILE = "timings.csv"
#: seconds to wait for a --scheduler to answer, and for its first worker
DEFAULT_CONNECT_TIMEOUT = 10.0
#: seconds a --scheduler run goes on waiting while the scheduler has no worker
DEFAULT_WORKER_TIMEOUT = 60.0


class UsageError(Exception):
    """A bad command-line argument (reported in one line, exit code 2)."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (argparse would print the usage too)
        raise UsageError(message)


def _positive_int(name, low: int = 1, why: str = ""):
    def parse(text):
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be an integer >= {low}, got {text!r}") from None
        if v < low:
            raise argparse.ArgumentTypeError(f"{name} must be >= {low}{why}, got {v}")
        return v
    return parse


def _positive_float(name):
    def parse(text):
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number > 0, got {text!r}") from None
        if not v > 0 or v == float("inf"):
            raise argparse.ArgumentTypeError(f"{name} must be a finite number > 0, got {text}")
        return v
    return parse


def _seed(text):
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--seed must be a non-negative integer, got {text!r}") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"--seed must be a non-negative integer, got {v}")
    return v


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (sub-commands ``list``, ``run``, ``scorecard``)."""
    p = _Parser(prog="pfrepro", description="Rerun the particle-filtering papers reproduced in the book.")
    sub = p.add_subparsers(dest="command", metavar="{list,run,scorecard}", parser_class=_Parser)
    sub.required = True
    sub.add_parser("list", help="papers, their tables and figures, and the claims of the last build")
    r = sub.add_parser("run", help="regenerate a paper's tables (CSV) and figures (PNG)")
    r.add_argument("paper", help="paper key or alias (see `pfrepro list`)")
    r.add_argument("--runs", type=_positive_int("--runs", 2, " (the claims compare methods over pairs of runs)"),
                   default=None, help="Monte Carlo runs of every experiment, >= 2 (default: the paper's)")
    r.add_argument("--seed", type=_seed, default=None, help="base seed (default: the book's fixed seeds)")
    r.add_argument("--jobs", type=_positive_int("--jobs"), default=None,
                   help="worker processes (default 1: one batched call per filter)")
    r.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on the workers of a dask.distributed scheduler, e.g. tcp://HOST:8786 "
                        "(every worker needs this environment: pip install -e .); not with --jobs")
    r.add_argument("--connect-timeout", type=_positive_float("--connect-timeout"), default=DEFAULT_CONNECT_TIMEOUT,
                   metavar="SECONDS", help="give up on --scheduler when it has not answered, or has no worker, "
                                           f"after this long (default {DEFAULT_CONNECT_TIMEOUT:g})")
    r.add_argument("--worker-timeout", type=_positive_float("--worker-timeout"), default=DEFAULT_WORKER_TIMEOUT,
                   metavar="SECONDS", help="stop a --scheduler run when the scheduler has had no worker for this "
                                           f"long (default {DEFAULT_WORKER_TIMEOUT:g})")
    r.add_argument("--out", default=None, help="output directory (default: ./pfrepro-<paper>)")
    s = sub.add_parser("scorecard", help="the claims of a book build or of a run")
    s.add_argument("--format", choices=("table", "csv", "json"), default="table")
    s.add_argument("--dir", default=None,
                   help="claims directory (default: $PFREPRO_CLAIMS_DIR, else book/_claims, else ./_claims)")
    return p


# -- helpers --------------------------------------------------------------------------------
def _slug(label: str) -> str:
    """'Table 1' -> 'table1', 'Fig. 2' -> 'fig2', 'Table 2 (std)' -> 'table2_std'."""
    s = re.sub(r"[^a-z0-9]+", "_", label.lower()).strip("_")
    return re.sub(r"^(table|fig)_(\d)", r"\1\2", s)


def _default_claims_dir() -> Path:
    env = os.environ.get("PFREPRO_CLAIMS_DIR")
    if env:
        return Path(env)
    for cand in (Path("book/_claims"), Path("_claims")):
        if cand.is_dir():
            return cand
    return Path("book/_claims")


def _writable_dir(path: Path) -> Path:
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".pfrepro-write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as exc:
        raise UsageError(f"--out {str(path)!r} is not a writable directory ({exc.strerror or exc})") from None
    return path


def _progress_bars() -> bool:
    """Whether to draw progress bars: the engine's rule (a terminal, not CI) when available."""
    try:
        from .montecarlo import progress_enabled
    except ImportError:  # older montecarlo without the rule
        return sys.stderr.isatty() and "CI" not in os.environ
    return bool(progress_enabled(None))


class _Steps:
    """Progress over a paper's experiments: a tqdm bar in a terminal, else one line per experiment.

    Each experiment's Monte Carlo runner draws its own bar under it (``run_monte_carlo``'s
    ``progress``, on in a terminal).
    """

    def __init__(self, total_hint: int | None, desc: str):
        self.t0 = time.perf_counter()
        tqdm = None
        if _progress_bars():
            try:
                from tqdm.auto import tqdm
            except ImportError:  # pragma: no cover - tqdm is in requirements.txt
                tqdm = None
        self.bar = tqdm(total=total_hint, desc=desc, unit="exp", file=sys.stderr, leave=True) if tqdm else None
        self.n = 0

    def __call__(self, label: str):
        if self.bar is not None:
            if self.n:
                self.bar.update(1)
            self.bar.set_postfix_str(label)
        else:
            print(f"[{time.perf_counter() - self.t0:6.1f} s] {label}", file=sys.stderr, flush=True)
        self.n += 1

    def close(self):
        if self.bar is not None:
            self.bar.total = max(self.bar.total or 0, self.n)
            self.bar.update(self.n - self.bar.n)
            self.bar.refresh()
            self.bar.close()


# -- commands -------------------------------------------------------------------------------
def cmd_list(args) -> int:
    from .claims import load_all_claims
    from .papers import PAPERS

    d = _default_claims_dir()
    claims = load_all_claims(d) if d.is_dir() else None
    for p in PAPERS:
        print(f"{p.key}  (aliases: {', '.join(p.aliases)})")
        print(f"  {p.citation}; chapter {p.chapter}")
        print(f"  tables:  {', '.join(p.tables)}")
        print(f"  figures: {', '.join(p.figures)}")
        if claims is not None:
            sub = claims[claims["paper"] == p.key]
            print(f"  claims ({len(sub)}, verdicts of the build in {d}):")
            for _, c in sub.iterrows():
                why = f" ({c['cause']})" if isinstance(c.get("cause"), str) and c["cause"] else ""
                print(f"    [{c['verdict']}{why}] {c['claim_id']}: {c['text']}")
        print()
    if claims is None:
        print(f"(no claims found in {d}: build the book, or `pfrepro run <paper>` and "
              f"`pfrepro scorecard --dir <out>/claims`, to see them)")
    return 0


def cmd_run(args) -> int:
    from .papers import get_paper

    try:
        paper = get_paper(args.paper)
    except KeyError as exc:
        raise UsageError(exc.args[0]) from None
    if args.out is not None and not args.out.strip():
        raise UsageError("--out must name a directory, got an empty string (use --out . for the current one)")
    out = _writable_dir(Path(args.out if args.out is not None else f"pfrepro-{paper.key}"))
    others = sorted(p.stem for p in (out / "claims").glob("*.json") if p.stem != paper.key)
    if others:   # tables and figures share names across papers (table1.csv, fig1.png): never mix two
        raise UsageError(f"--out {str(out)!r} holds the results of another paper ({', '.join(others)}); "
                         f"choose another --out for {paper.key}")
    import matplotlib

    if "matplotlib.pyplot" not in sys.modules:
        matplotlib.use("Agg")  # files only: no window

    from .export import write_table

    if args.scheduler is not None and args.jobs is not None:
        raise UsageError("--scheduler and --jobs cannot be used together (the scheduler's workers are the jobs)")
    executor = client = None
    if args.scheduler is not None:
        client = _connect_scheduler(args.scheduler, args.connect_timeout)
        from .montecarlo import dask_executor

        executor = dask_executor(client, worker_timeout=args.worker_timeout)
    elif (args.jobs or 1) > 1:
        from .montecarlo import process_pool

        executor = process_pool(args.jobs)
    t0 = time.perf_counter()
    steps = _Steps(getattr(paper.figures_module, "N_STEPS", None), paper.key)
    try:
        rep = paper.reproduce(runs=args.runs, seed=args.seed, executor=executor, steps=steps)
    finally:
        steps.close()
        if client is not None:
            executor.shutdown(wait=False)   # cancels what is left (after an error or Ctrl-C)
            client.close()
        elif executor is not None:
            executor.shutdown()
    written, timed = [], []
    for label, df in rep.tables.items():
        written.append(write_table(df, out / f"{_slug(label)}.csv"))
    for label, fig in rep.figures.items():
        written.append(_save_figure(fig, out / f"{_slug(label)}.png"))
    written.append(rep.claims.save(out / "claims"))
    # measured times differ between any two runs: a file of their own, so that every other
    # file is the same bytes for the same runs and seeds (serial, --jobs or --scheduler)
    if len(rep.timings):
        timed.append(write_table(rep.timings, out / TIMINGS_FILE))
    for label, fig in rep.timing_figures.items():
        timed.append(_save_figure(fig, out / f"timings_{_slug(label)}.png"))
    print(f"{paper.key}: {paper.citation}")
    for k, v in rep.settings.items():
        print(f"  {k}: {v}")
    print(f"wrote {len(written) + len(timed)} files to {out} in {time.perf_counter() - t0:.1f} s:")
    for path in written:
        print(f"  {path.relative_to(out)}")
    for path in timed:
        print(f"  {path.relative_to(out)}  (measured times: differ between runs)")
    df = rep.claims.to_frame()
    print(f"\nverdicts of the {len(df)} claims (the chapter's claims, decided by the same code):")
    for v, n in rep.verdict_counts().items():
        print(f"  {n:3d}  {v}")
    if len(df):
        print()
        print(_claims_table(df))
    return 0


def _save_figure(fig, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=max(150, fig.dpi), bbox_inches="tight")
    plt.close(fig)
    return path


# -- --scheduler ------------------------------------------------------------------------------
def _worker_environment_probe():
    """A function reporting the versions and the pfrepro code identity of the process it runs in.

    Built in a closure so that it is pickled by value (cloudpickle): a worker that cannot
    import pfrepro, or runs one without ``pfrepro._codeid``, can still run it and say so.
    The code identity is that of the modules as the worker imported them
    (``pfrepro._codeid.identity``), with the ones edited on disk since (``stale``).
    """
    def probe():
        import importlib
        import platform

        out = {"python": ".".join(platform.python_version_tuple()[:2])}
        for name in ("numpy", "scipy", "pfrepro"):
            try:
                out[name] = importlib.import_module(name).__version__
            except Exception as exc:  # noqa: BLE001 - reported, not raised
                out[name] = f"cannot import ({type(exc).__name__}: {exc})"
        try:
            cid = importlib.import_module("pfrepro._codeid")
            out["code"], out["stale"] = cid.identity(), cid.stale_modules()
        except Exception as exc:  # noqa: BLE001
            out["code"], out["stale"] = f"cannot tell ({type(exc).__name__}: {exc})", []
        return out
    return probe


def _local_environment() -> dict:
    """What :func:`_worker_environment_probe` reports, for this process."""
    return _worker_environment_probe()()


def _environment_difference(here: dict, there: dict) -> str:
    """'' when a worker's report ``there`` matches this process's ``here``, else what differs and what to do."""
    diff = [f"{k} {there.get(k)!r} (here {v!r})" for k, v in here.items()
            if k not in ("code", "stale") and there.get(k) != v]
    code_here, code_there = here.get("code"), there.get("code")
    stale = []
    if not isinstance(code_there, dict) or not isinstance(code_here, dict):
        diff.append(f"pfrepro code identity {code_there if not isinstance(code_there, dict) else 'unknown here'}")
    else:
        mods = sorted(m for m in set(code_here) | set(code_there)
                      if m.startswith("pfrepro") and code_here.get(m) != code_there.get(m))
        if mods:
            shown = ", ".join(mods[:3]) + (f" and {len(mods) - 3} more" if len(mods) > 3 else "")
            diff.append(f"pfrepro source of {shown}")
            stale = [m for m in mods if m in (there.get("stale") or ())]
    if not diff:
        return ""
    if stale and len(diff) == 1:
        hint = "it imported them before they were edited on disk: restart it (Ctrl-C, then dask worker ... again)"
    else:
        hint = ("install the same pfrepro (pip install -e . of this commit) and packages on every worker "
                "and restart it")
    return f"{'; '.join(diff)}; {hint}"


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return f"{type(exc).__name__}: {text.splitlines()[0]}" if text else type(exc).__name__


def _probe_scheduler(address: str, timeout: float) -> None:
    """Open and close one connection to ``address`` (distributed's handshake included), within
    ``timeout`` seconds.

    In a daemon thread of its own (so that a caller's running event loop, e.g. Jupyter's, does
    not matter), which is left behind, never joined, when it does not finish in time: a port
    that accepts the connection and then stays silent (a web server, a dashboard) cannot hold
    the command, on the way out either. Raises what the connection raised, or ``TimeoutError``.
    """
    import asyncio
    import threading

    from distributed.comm import connect
    from distributed.security import Security

    result = {}
    # TLS (tls://) takes its certificates from dask's configuration, as the Client does
    conn_args = Security().get_connection_args("client")

    async def probe():
        # distributed's own timeout first (it names a refused connection); ours if it hangs anyway
        comm = await asyncio.wait_for(connect(address, timeout=timeout, **conn_args), timeout + 1.0)
        await comm.close()

    def target():
        try:
            asyncio.run(probe())
        except BaseException as exc:  # noqa: BLE001 - handed to the caller
            result["error"] = exc

    t = threading.Thread(target=target, name="pfrepro-scheduler-probe", daemon=True)
    t.start()
    t.join(timeout + 2.0)
    if t.is_alive():
        raise TimeoutError(f"no answer within {timeout:g} s")
    if "error" in result:
        raise result["error"]


def _connect_scheduler(address: str, timeout: float):
    """A ``dask.distributed.Client`` of the scheduler at ``address``, checked before any work.

    One-line :class:`UsageError` (exit 2) when the address is malformed, nothing answers
    within ``timeout`` seconds (a silent port, a web server and a dashboard included), the
    scheduler has no worker within ``timeout`` seconds, or a worker runs another environment
    (python, numpy, scipy, or pfrepro version, or pfrepro code as it imported it,
    ``pfrepro._codeid``) than this process: its numbers could then differ from a serial
    run. Workers that join later are checked on every task they get.
    """
    try:
        from distributed import Client
    except ImportError:  # pragma: no cover - dask[distributed] is in requirements.txt
        raise UsageError("--scheduler needs dask.distributed: pip install 'dask[distributed]'") from None
    address = address.strip()
    hint = "start one with `dask scheduler` and workers with `dask worker tcp://HOST:8786 --nthreads 1`"
    if not address:
        raise UsageError(f"--scheduler needs an address such as tcp://HOST:8786 ({hint})")
    try:
        _probe_scheduler(address, timeout)
    except ValueError as exc:
        raise UsageError(f"--scheduler {address!r} is not a scheduler address ({_first_line(exc)}); "
                         f"expected tcp://HOST:PORT (the default port is 8786)") from None
    except TimeoutError:
        raise UsageError(f"no dask scheduler answered at {address!r} within {timeout:g} s (what listens there "
                         f"does not speak dask: a silent port, the scheduler's dashboard or another web "
                         f"server?); {hint}") from None
    except OSError as exc:
        raise UsageError(f"no dask scheduler reachable at {address!r} within {timeout:g} s "
                         f"({_first_line(exc)}); {hint}") from None
    except Exception as exc:  # noqa: BLE001 - something answered, but not a dask scheduler
        raise UsageError(f"no dask scheduler answered at {address!r} (a connection opened, but the dask handshake failed: "
                         f"{_first_line(exc)})") from None
    try:
        client = Client(address, timeout=timeout, set_as_default=False)
    except Exception as exc:  # noqa: BLE001 - e.g. the scheduler went away since the probe
        raise UsageError(f"cannot connect to the dask scheduler at {address!r}: {_first_line(exc)}") from None
    try:
        try:
            client.wait_for_workers(1, timeout=timeout)
        except (TimeoutError, OSError):
            raise UsageError(f"the dask scheduler at {address!r} has no worker after {timeout:g} s; start "
                             f"workers with `dask worker {address} --nthreads 1`") from None
        here = _local_environment()
        try:
            there = client.run(_worker_environment_probe())
        except Exception as exc:  # noqa: BLE001
            raise UsageError(f"cannot check the workers of {address!r}: {_first_line(exc)}") from None
        for worker, env in sorted(there.items()):
            diff = _environment_difference(here, env)
            if diff:
                raise UsageError(f"worker {worker} runs another environment than this process: {diff}")
    except BaseException:
        client.close()
        raise
    return client


def _claims_table(df) -> str:
    cols = ["paper", "claim_id", "published", "reproduced", "se", "verdict"]
    show = df[cols].copy()
    return show.to_string(index=False, float_format=lambda v: f"{v:.4g}", na_rep="")


def cmd_scorecard(args) -> int:
    from .claims import load_all_claims

    d = Path(args.dir) if args.dir is not None else _default_claims_dir()
    if not d.is_dir():
        raise UsageError(f"no claims directory {str(d)!r} (build the book or pass --dir <out>/claims of a run)")
    try:
        df = load_all_claims(d)
    except (ValueError, TypeError, KeyError, AttributeError, UnicodeDecodeError) as exc:
        # a corrupt or wrong-shaped JSON file: one line naming it, exit 2 (not a traceback)
        bad = _first_bad_claims_file(d)
        where = f" in {str(bad)!r}" if bad else ""
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise UsageError(f"cannot read the claims{where}: {msg}") from None
    if not len(df):
        raise UsageError(f"no claims (*.json) in {str(d)!r}")
    if args.format == "csv":
        sys.stdout.write(df.to_csv(index=False))
    elif args.format == "json":
        # every number as Python writes it (round-trips exactly, as in the CSV and the saved
        # claims); pandas' to_json kept 10 digits. A missing number (NaN) is null.
        import json
        import math

        rows = [{k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in r.items()}
                for r in df.to_dict(orient="records")]
        sys.stdout.write(json.dumps(rows, indent=1) + "\n")
    else:
        print(_claims_table(df))
        print()
        print(df["verdict"].value_counts().to_string())
        inc = df[df["verdict"] == "inconclusive"]
        if len(inc):
            print()
            print("inconclusive, by cause:")
            print(inc["cause"].value_counts().to_string())
    return 0


def _first_bad_claims_file(d: Path):
    """The first ``*.json`` of ``d`` that is not a list of claim records (for the error message)."""
    import json

    from .claims import Claim

    for path in sorted(d.glob("*.json")):
        try:
            rows = json.loads(path.read_text(encoding="utf-8"))
            for row in rows:
                row = dict(row)
                row.pop("verdict", None)
                Claim(**row)
        except Exception:  # noqa: BLE001 - any failure marks this file
            return path
    return None


COMMANDS = {"list": cmd_list, "run": cmd_run, "scorecard": cmd_scorecard}


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def _run_stopped_errors() -> tuple:
    from .montecarlo import CodeIdentityError
    from .montecarlo import WorkersLostError

    return (CodeIdentityError, WorkersLostError)


#: errors that stop a run on an executor for a reason the user can fix (reported in one line, exit 2)
_RUN_STOPPED = _run_stopped_errors()


def main(argv=None) -> int:
    """Entry point of the ``pfrepro`` console script and ``python -m pfrepro``; returns the exit code."""
    try:
        args = build_parser().parse_args(argv)
        return COMMANDS[args.command](args)
    except UsageError as exc:
        print(f"pfrepro: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except _RUN_STOPPED as exc:   # a worker on other code, or no worker left: one line, exit 2
        print(f"pfrepro: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("pfrepro: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. `pfrepro list | head`
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass
        return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
