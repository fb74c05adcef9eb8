"""`pfrepro run PAPER --scheduler ADDRESS`: a dask.distributed scheduler's workers write the same
bytes as a serial run; a bad or unreachable scheduler is one line on stderr and exit code 2."""
from __future__ import annotations

import socket
import time

import pytest

from pfrepro import cli, montecarlo

distributed = pytest.importorskip("distributed")


class _TickClock:
    """``time.perf_counter`` stand-in (1 s a call): the timing columns depend on the call
    sequence only (timing always runs serially in this process), as in tests/test_cli.py."""

    def __init__(self):
        self.t = 0.0

    def perf_counter(self):
        self.t += 1.0
        return self.t


@pytest.fixture(scope="module")
def cluster():
    # dashboard on a free port (":0"; None would still take 8787, maybe in use on a shared machine);
    # the workers are spawned processes: they inherit this process's sys.path (PYTHONPATH=src),
    # the environment a remote worker gets from `pip install -e .`
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=":0") as c:
        yield c


def _files(out):
    return sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file())


def test_scheduler_run_is_byte_identical_to_serial(cluster, tmp_path, capsys, monkeypatch):
    """Every output file (tables, figures, claims) of `--scheduler` equals `--jobs 1` byte for byte;
    the runs really went to the cluster's workers."""
    with distributed.Client(cluster.scheduler_address) as watcher:
        before = sum(watcher.run(lambda dask_worker: dask_worker.state.executed_count).values())
    outs = {}
    for mode, extra in (("serial", ["--jobs", "1"]), ("dask", ["--scheduler", cluster.scheduler_address])):
        monkeypatch.setattr(montecarlo, "time", _TickClock())
        out = tmp_path / mode
        code = cli.main(["run", "li2012", "--runs", "2", "--seed", "7", *extra, "--out", str(out)])
        _, err = capsys.readouterr()
        assert code == 0, err
        outs[mode] = out
    with distributed.Client(cluster.scheduler_address) as watcher:
        executed = sum(watcher.run(lambda dask_worker: dask_worker.state.executed_count).values())
        assert set(watcher.nthreads().values()) == {1} and len(watcher.nthreads()) == 2
    assert executed - before >= 8, "the --scheduler run did not use the cluster's workers"
    files = _files(outs["serial"])
    assert _files(outs["dask"]) == files
    assert any(f.suffix == ".png" for f in files) and any(f.suffix == ".csv" for f in files)
    assert any(f.suffix == ".json" for f in files)
    for f in files:
        assert (outs["serial"] / f).read_bytes() == (outs["dask"] / f).read_bytes(), \
            f"{f} differs between --jobs 1 and --scheduler"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _one_line_error(capsys, argv):
    code = cli.main(argv)
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert code == 2, (argv, err)
    assert len(lines) == 1 and lines[0].startswith("pfrepro: error:"), (argv, err)
    assert "Traceback" not in err and out == "", argv
    return lines[0]


def test_unreachable_scheduler_is_one_line_within_the_timeout(capsys, tmp_path):
    address = f"tcp://127.0.0.1:{_free_port()}"          # nothing listens there
    t0 = time.perf_counter()
    msg = _one_line_error(capsys, ["run", "li2012", "--runs", "2", "--scheduler", address,
                                   "--connect-timeout", "1", "--out", str(tmp_path)])
    assert time.perf_counter() - t0 < 15                 # the 1 s timeout, not distributed's 30 s
    assert "no dask scheduler reachable" in msg and address in msg and "dask scheduler" in msg


@pytest.mark.parametrize("argv, words", [
    (["--scheduler", "tcp://127.0.0.1:8786", "--jobs", "2"], "cannot be used together"),
    (["--jobs", "1", "--scheduler", "tcp://127.0.0.1:8786"], "cannot be used together"),
    (["--scheduler", "127.0.0.1"], "missing port"),
    (["--scheduler", "host:notaport"], "not a scheduler address"),
    (["--scheduler", "http://127.0.0.1:8786"], "not a scheduler address"),
    (["--scheduler", " "], "needs an address"),
    (["--scheduler", "tcp://127.0.0.1:8786", "--connect-timeout", "0"], "--connect-timeout"),
    (["--scheduler", "tcp://127.0.0.1:8786", "--connect-timeout", "soon"], "--connect-timeout"),
])
def test_bad_scheduler_arguments_exit_2_with_one_line(argv, words, capsys, tmp_path):
    msg = _one_line_error(capsys, ["run", "li2012", "--runs", "2", *argv, "--out", str(tmp_path)])
    assert words in msg


def test_scheduler_without_workers_is_one_line(capsys, tmp_path):
    with distributed.LocalCluster(n_workers=0, processes=True, host="127.0.0.1",
                                  dashboard_address=":0") as c:
        msg = _one_line_error(capsys, ["run", "li2012", "--runs", "2", "--scheduler", c.scheduler_address,
                                       "--connect-timeout", "1", "--out", str(tmp_path)])
    assert "has no worker" in msg and "dask worker" in msg


def test_worker_with_another_environment_is_refused(cluster, capsys, tmp_path, monkeypatch):
    """A worker whose pfrepro differs from this process's (here: this process pretends to run
    other sources) could compute other numbers: refused before any work, in one line."""
    real = cli._worker_environment_probe

    def here_differs():
        probe = real()
        state = {"calls": 0}

        def wrapped():
            env = probe()
            state["calls"] += 1
            if state["calls"] == 1:                  # the first call is the local one
                env["pfrepro source"] = "0" * 12
            return env
        return wrapped

    monkeypatch.setattr(cli, "_worker_environment_probe", here_differs)
    msg = _one_line_error(capsys, ["run", "li2012", "--runs", "2", "--scheduler", cluster.scheduler_address,
                                   "--out", str(tmp_path)])
    assert "another environment" in msg and "pfrepro source" in msg and "pip install -e ." in msg
