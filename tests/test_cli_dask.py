"""`pfrepro run PAPER --scheduler ADDRESS`: a dask.distributed scheduler's workers write the same
bytes as a serial run; a bad or unreachable scheduler is one line on stderr and exit code 2."""
from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from pfrepro import cli, montecarlo

distributed = pytest.importorskip("distributed")


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


def test_scheduler_run_is_byte_identical_to_serial(cluster, tmp_path, capsys):
    """Every output file (tables, figures, claims) of `--scheduler` equals `--jobs 1` byte for byte,
    with the real clock (measured times have a file of their own) and chunks of one run; the runs
    really went to the cluster's workers."""
    with distributed.Client(cluster.scheduler_address) as watcher:
        before = sum(watcher.run(lambda dask_worker: dask_worker.state.executed_count).values())
    outs = {}
    for mode, extra in (("serial", ["--jobs", "1"]), ("dask", ["--scheduler", cluster.scheduler_address])):
        out = tmp_path / mode
        code = cli.main(["run", "li2012", "--runs", "3", "--seed", "7", *extra, "--out", str(out)])
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


def _stopped_run_error(capsys, argv):
    """A run that started (its progress lines on stderr) and was stopped: exit 2, and the error
    is one line, the last, without a traceback."""
    code = cli.main(argv)
    _, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert code == 2, (argv, err)
    assert lines[-1].startswith("pfrepro: error:") and sum("pfrepro: error" in ln for ln in lines) == 1, err
    assert "Traceback" not in err
    return lines[-1]


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
    another source of one module) could compute other numbers: refused before any work, in one line."""
    real = cli._local_environment

    def here_differs():
        env = real()
        env["code"] = dict(env["code"], **{"pfrepro.models.ungm": "0" * 16})
        return env

    monkeypatch.setattr(cli, "_local_environment", here_differs)
    msg = _one_line_error(capsys, ["run", "li2012", "--runs", "2", "--scheduler", cluster.scheduler_address,
                                   "--out", str(tmp_path)])
    assert "another environment" in msg and "pfrepro source of pfrepro.models.ungm" in msg
    assert "pip install -e ." in msg


# -- code identity: other code joining later, and stale imports ---------------------------------
SRC = Path(cli.__file__).resolve().parents[1]           # .../src, holding pfrepro/


def _checkout(root: Path, edit: str = "") -> Path:
    """A copy of this pfrepro under ``root/src`` (a second checkout), ``edit`` appended to models/ungm.py."""
    dst = root / "src" / "pfrepro"
    shutil.copytree(SRC / "pfrepro", dst, ignore=shutil.ignore_patterns("__pycache__"))
    if edit:
        with open(dst / "models" / "ungm.py", "a", encoding="utf-8") as fh:
            fh.write(edit)
    return root / "src"


def _start_worker(address: str, src: Path, cwd: Path) -> subprocess.Popen:
    """A `dask worker` process (no nanny) importing pfrepro from ``src``."""
    env = dict(os.environ, PYTHONPATH=str(src), OPENBLAS_NUM_THREADS="1")
    return subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                             "--no-nanny", "--no-dashboard", "--name", "edited"],
                            env=env, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def _wait_workers(client, n: int, timeout: float = 60.0) -> None:
    t0 = time.monotonic()
    while len(client.scheduler_info(n_workers=-1)["workers"]) != n:
        assert time.monotonic() - t0 < timeout, f"the scheduler did not get to {n} workers"
        time.sleep(0.2)


def _stop(proc: subprocess.Popen) -> None:
    proc.terminate()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:  # pragma: no cover
        proc.kill()


def test_edited_worker_joining_after_the_start_stops_the_run(capsys, tmp_path, monkeypatch):
    """A worker from an edited checkout joins after the connect-time check (and the worker that
    passed it leaves): the first task it gets is refused on the worker, and the command stops with
    one line naming it and the module that differs, exit 2."""
    src = _checkout(tmp_path / "edited", edit="\n# an edit the command's process does not have\n")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=":0", silence_logs=50) as c:
        real = cli._connect_scheduler
        procs = []

        def connect_then_swap(address, timeout):
            client = real(address, timeout)                 # the check passes: one worker, this code
            first = list(client.scheduler_info(n_workers=-1)["workers"])
            procs.append(_start_worker(address, src, tmp_path))
            _wait_workers(client, 2)
            client.retire_workers(first)                    # only the edited worker is left
            _wait_workers(client, 1)
            return client

        monkeypatch.setattr(cli, "_connect_scheduler", connect_then_swap)
        try:
            msg = _stopped_run_error(capsys, ["run", "li2012", "--runs", "2", "--scheduler", c.scheduler_address,
                                              "--out", str(tmp_path / "out")])
        finally:
            for proc in procs:
                _stop(proc)
    assert "runs other code than the process that sent it the task" in msg
    assert "(name edited)" in msg and "pfrepro source of pfrepro.models.ungm" in msg
    assert "pip install -e ." in msg
    assert not (tmp_path / "out" / "claims").exists()       # no result written from other code


def test_worker_with_stale_imports_is_refused(tmp_path):
    """A worker imported pfrepro, then its sources were edited on disk (here: back to this process's
    code). Its files now match this process, but it still runs what it imported: refused at connect
    time (hashing the files on disk, the old check, passed it) and on every task, with a hint to restart it."""
    from pfrepro.montecarlo import CodeIdentityError
    from pfrepro.filters import BootstrapParticleFilter
    from pfrepro.models import UNGM

    src = _checkout(tmp_path / "old", edit="\n# before the edit\n")
    with distributed.LocalCluster(n_workers=0, processes=True, host="127.0.0.1", dashboard_address=":0",
                                  silence_logs=50) as c, distributed.Client(c) as client:
        proc = _start_worker(c.scheduler_address, src, tmp_path)
        try:
            _wait_workers(client, 1)
            assert client.run(lambda: __import__("pfrepro").__file__)      # the worker imports pfrepro now
            shutil.copy2(SRC / "pfrepro" / "models" / "ungm.py", src / "pfrepro" / "models" / "ungm.py")
            with pytest.raises(cli.UsageError, match="imported them before they were edited on disk: restart it") as e:
                cli._connect_scheduler(c.scheduler_address, 5)
            assert "pfrepro.models.ungm" in str(e.value)
            model = UNGM.zhang2016()
            with pytest.raises(CodeIdentityError, match=r"edited.*pfrepro\.models\.ungm.*restart it"):
                montecarlo.run_monte_carlo(model, {"PF": BootstrapParticleFilter(model, 20)}, 5, 2, 1,
                                           executor=montecarlo.dask_executor(client), progress=False)
        finally:
            _stop(proc)


# -- hangs: a port that is not a scheduler, workers that are gone -----------------------------------
@pytest.fixture
def silent_port():
    """A TCP port on 127.0.0.1 that accepts connections and never says anything."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    held = []
    stop = threading.Event()

    def accept():
        srv.settimeout(0.2)
        while not stop.is_set():
            try:
                held.append(srv.accept()[0])
            except OSError:
                pass

    t = threading.Thread(target=accept, daemon=True)
    t.start()
    yield srv.getsockname()[1]
    stop.set()
    t.join(2)
    for conn in held:
        conn.close()
    srv.close()


@pytest.fixture
def http_port():
    """A plain HTTP server on 127.0.0.1 (as a dashboard or any web port answers)."""
    import http.server

    class Quiet(http.server.BaseHTTPRequestHandler):
        def log_message(self, *a):
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
    t = threading.Thread(target=httpd.serve_forever, daemon=True)
    t.start()
    yield httpd.server_address[1]
    httpd.shutdown()
    httpd.server_close()


@pytest.mark.parametrize("port", ["silent_port", "http_port"])
def test_a_port_that_is_not_a_scheduler_is_one_line_within_the_timeout(port, request, capsys, tmp_path):
    address = f"tcp://127.0.0.1:{request.getfixturevalue(port)}"
    t0 = time.perf_counter()
    msg = _one_line_error(capsys, ["run", "li2012", "--runs", "2", "--scheduler", address,
                                   "--connect-timeout", "1", "--out", str(tmp_path)])
    assert time.perf_counter() - t0 < 1 + 6                   # the timeout, plus the probe's grace seconds
    assert "no dask scheduler" in msg and address in msg and "within 1 s" in msg, msg


def test_the_command_ends_after_a_silent_port(silent_port, tmp_path):
    """The whole process exits within the limit: the probe's thread is not joined on the way out."""
    t0 = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "pfrepro", "run", "li2012", "--runs", "2", "--scheduler",
                        f"tcp://127.0.0.1:{silent_port}", "--connect-timeout", "1", "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert time.monotonic() - t0 < 60                          # imports + 1 s; the old probe never returned


def test_every_worker_lost_stops_the_run_with_one_line(capsys, tmp_path, monkeypatch):
    """The workers stop after the connect-time check: the run ends after --worker-timeout
    (plus the client's 2 s refresh of the worker count) with one line and exit 2."""
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=":0", silence_logs=50) as c:
        real = cli._connect_scheduler

        def connect_then_stop_workers(address, timeout):
            client = real(address, timeout)
            c.scale(0)
            _wait_workers(client, 0)
            return client

        monkeypatch.setattr(cli, "_connect_scheduler", connect_then_stop_workers)
        t0 = time.perf_counter()
        msg = _stopped_run_error(capsys, ["run", "li2012", "--runs", "2", "--scheduler", c.scheduler_address,
                                          "--worker-timeout", "1", "--out", str(tmp_path)])
        elapsed = time.perf_counter() - t0
    assert "no worker for 1 s" in msg and "dask worker" in msg
    assert elapsed < 30


def _slow_chunk(start, size):
    time.sleep(0.3)
    return np.arange(start, start + size)


def test_workers_lost_mid_call_raise_within_the_limit():
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=":0", silence_logs=50) as c, distributed.Client(c) as client:
        ex = montecarlo.dask_executor(client, worker_timeout=1)
        np.testing.assert_array_equal(montecarlo.map_runs(_slow_chunk, 3, ex, chunks=3), np.arange(3))
        threading.Timer(0.8, lambda: c.scale(0)).start()        # after a chunk or two of the next call
        t0 = time.perf_counter()
        with pytest.raises(montecarlo.WorkersLostError, match="no worker for 1 s"):
            montecarlo.map_runs(_slow_chunk, 40, ex, chunks=40)
        assert time.perf_counter() - t0 < 20
    with pytest.raises(ValueError, match="worker_timeout"):
        montecarlo.dask_executor(None, worker_timeout=0)
