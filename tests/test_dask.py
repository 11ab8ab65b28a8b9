"""Sweeps and the layout search on a real dask.distributed cluster (core.dask_backend).

The cluster is what docs/dask.md tells users to run on several hosts, here on loopback: a
``dask scheduler`` process and a ``dask worker --nworkers 2 --nthreads 1`` (a nanny with two
worker processes), started as subprocesses. Results must equal the local ones exactly: every
cell and candidate is computed by the same code, point by point, on the same machine.
"""

import csv
import dataclasses
import importlib
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time

import distributed  # the test extra installs it: no skip when it is missing
import numpy as np
import pytest

import core
from core import dask_backend, sweep
from core.cli import sweep as sweep_cli

#: Runs alone, after the rest (``pytest -m serial``; tests/conftest.py):
SERIAL = "it runs a Dask scheduler and workers and kills one"

START_TIMEOUT = 60.0  # s: scheduler up and both workers registered (usually 3–6 s here)


def _stop(proc):
    """SIGTERM the process group we started, SIGKILL it if it lingers."""
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=10)


def _spawn(args, log, env=None):
    """``python -m dask ARGS`` in a session of its own, output to the file ``log``."""
    with open(log, "w") as fh:  # the child keeps its own copy of the descriptor
        return subprocess.Popen([sys.executable, "-m", "dask", *args], stdout=fh,
                                stderr=subprocess.STDOUT, env=env, start_new_session=True)


def _start_scheduler(tmp):
    """A ``dask scheduler`` on a free loopback port: (process, address)."""
    info = tmp / "scheduler.json"
    proc = _spawn(["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                   "--scheduler-file", str(info)], tmp / "scheduler.log")
    deadline = time.monotonic() + START_TIMEOUT
    while not info.exists() or not info.read_text().strip():
        if proc.poll() is not None or time.monotonic() > deadline:
            _stop(proc)
            raise RuntimeError("dask scheduler did not start:\n"
                               + (tmp / "scheduler.log").read_text())
        time.sleep(0.1)
    return proc, json.loads(info.read_text())["address"]


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """Scheduler + two single-threaded worker processes; yields (address, client)."""
    tmp = tmp_path_factory.mktemp("dask")
    scheduler, address = _start_scheduler(tmp)
    env = dict(os.environ, NUMBA_NUM_THREADS="1")  # one numba thread per worker process
    workers = _spawn(["worker", address, "--nworkers", "2", "--nthreads", "1", "--no-dashboard",
                      "--host", "127.0.0.1", "--local-directory", str(tmp / "work"),
                      "--death-timeout", "30"], tmp / "workers.log", env)
    client = None
    try:
        client = distributed.Client(address, timeout=START_TIMEOUT, set_as_default=False)
        client.wait_for_workers(2, timeout=START_TIMEOUT)
        client.run(importlib.import_module, "core.sweep")  # warm: numba, scipy, the JIT cache
        yield address, client
    finally:
        if client is not None:
            client.close()
        _stop(workers)
        _stop(scheduler)


def _evaluate_tasks(records):
    """Task-stream records of core.dask_backend's tasks: one per row / candidate."""
    return [r for r in records if r["key"].startswith("_evaluate-")]


#: Cluster against serial. The same kernel compiled in this process and loaded from numba's cache
#: by a worker (a cold cache: this process compiles and writes it) differ in the last bits: measured
#: up to 6e-15 relative on the sweep's log10 criteria, 3e-16 on the spacing curve, never in which
#: entries are NaN. Bit equality holds only between processes that both load the cache; 1e-12
#: relative is 100x the measured spread and far below any difference a wrong row, station or
#: setting makes (those change the criteria in the third digit or earlier).
RTOL = 1e-12


def assert_same_numbers(actual, desired, err_msg=""):
    """Equal NaN pattern, equal values within :data:`RTOL`."""
    actual, desired = np.asarray(actual), np.asarray(desired)
    np.testing.assert_array_equal(np.isnan(actual), np.isnan(desired), err_msg=err_msg)
    np.testing.assert_allclose(actual, desired, rtol=RTOL, atol=0, err_msg=err_msg)


def assert_same_result(a, b):
    """Two result dataclasses field by field (NaN equals NaN; floats within RTOL)."""
    assert type(a) is type(b)
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if np.asarray(x).dtype.kind == "f":
            assert_same_numbers(x, y, err_msg=f.name)
        else:
            np.testing.assert_array_equal(x, y, err_msg=f.name)


BASE = {k: v[0] for k, v in sweep.PARAMETERS.items()}
#: The CLI's default settings, for the d_optimal measure.
SETTINGS = {"measure": "d_optimal", "layout": "line", "stations": 2, "model": "exact", "steps": 3,
            "region": ((-300.0, 300.0), (-300.0, 300.0), 21), "threshold": 10.0}


@pytest.mark.parametrize("measure, xaxis, yaxis, fixed", [
    # x = y = 0, z = h = 100 puts the target on station 0 (at the origin): a NaN row.
    ("d_optimal", "d=5:45:5", "z=100:200:8", {"x": 0.0, "y": 0.0}),
    ("crlb_semi_major", "noise=1e-8:1e-6:3:log", "heading=0,30,60,90", {}),
    ("mean_dopt", "d=5:100:3", "z=110,150,200,260", {}),
])
def test_sweep_on_cluster_equals_serial(cluster, measure, xaxis, yaxis, fixed):
    _, client = cluster
    settings = dict(SETTINGS, measure=measure, region=((-200.0, 200.0), (-200.0, 200.0), 7))
    x, y, base = sweep.parse_axis(xaxis), sweep.parse_axis(yaxis), dict(BASE, **fixed)
    serial = sweep.run(x, y, settings, base, workers=1, progress=False)
    with distributed.get_task_stream(client) as stream:
        on_cluster = sweep.run(x, y, settings, base, progress=False, client=client)
    assert_same_numbers(on_cluster, serial)  # NaN where NaN
    if fixed:  # station 0 sits at the origin for every d: the z = 100 m row is on it
        assert np.all(np.isnan(serial[0]))
    assert np.all(np.isfinite(serial[1 if fixed else 0:]))  # a real grid elsewhere
    tasks = _evaluate_tasks(stream.data)
    assert len(tasks) == y[1].size  # one task per row, all run on the cluster
    assert {t["worker"] for t in tasks} == set(client.scheduler_info()["workers"])  # both used


def test_worker_error_reaches_the_caller(cluster):
    _, client = cluster
    with pytest.raises(ValueError, match="d must be a finite number > 0"):  # on a worker
        sweep.run(("d", np.array([5.0, -5.0])), ("z", np.array([120.0, 150.0])), SETTINGS,
                  BASE, progress=False, client=client)


def test_layout_search_with_client_equals_without(cluster):
    _, client = cluster
    region = core.Plane("xy", (-200, 200), (-200, 200), 120.0, 9)
    d = np.linspace(5, 300, 7)
    problem = core.LayoutProblem(region)
    assert_same_numbers(core.spacing_curve(d, problem, client=client), core.spacing_curve(d, problem))
    with distributed.get_task_stream(client) as stream:
        remote = core.best_spacing(problem, d_range=(5, 300), n_curve=7, kind="triangle",
                                   n_stations=3, client=client)
    assert len(_evaluate_tasks(stream.data)) == 7  # the coarse curve ran on the cluster
    assert_same_result(remote, core.best_spacing(problem, d_range=(5, 300), n_curve=7,
                                                 kind="triangle", n_stations=3))
    kw = dict(d_range=(5, 300), n_curve=5)
    worst = core.LayoutProblem(region, criterion="worst_dopt")
    assert_same_result(core.optimise_layout("square", 4, worst, client=client, **kw),
                       core.optimise_layout("square", 4, worst, **kw))
    assert_same_result(core.optimise_layout("free", 3, worst, maxfev=60, client=client, **kw),
                       core.optimise_layout("free", 3, worst, maxfev=60, **kw))


def test_client_must_be_a_dask_client():
    region = core.Plane("xy", (-200, 200), (-200, 200), 120.0, 5)
    with pytest.raises(ValueError, match="dask.distributed.Client"):
        core.best_spacing(core.LayoutProblem(region), n_curve=3, client="tcp://127.0.0.1:8786")
    with pytest.raises(ValueError, match="dask.distributed.Client"):
        sweep.run(("d", np.array([5.0])), ("z", np.array([120.0])), SETTINGS, BASE,
                  progress=False, client=object())


def _read_csv(path):
    with open(path) as fh:
        rows = list(csv.reader(fh))
    return rows[0], np.array(rows[1:], dtype=float)


def test_cli_scheduler_end_to_end(cluster, tmp_path):
    address, client = cluster
    client.get_task_stream()  # installs the scheduler's task-stream recorder
    start = time.time()
    cmd = [sys.executable, "-m", "core.sweep", "--x", "d=5:45:3", "--y", "z=110,150,200",
           "--measure", "d_optimal", "--out", str(tmp_path), "--no-progress",
           "--scheduler", address]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    header, table = _read_csv(tmp_path / "sweep.csv")
    assert header == ["d", "z", "d_optimal"] and table.shape == (9, 3)
    serial = sweep.run(sweep.parse_axis("d=5:45:3"), sweep.parse_axis("z=110,150,200"),
                       SETTINGS, BASE, workers=1, progress=False)
    assert_same_numbers(table[:, 2], serial.ravel())  # repr() round-trips floats
    tasks = _evaluate_tasks(client.get_task_stream(start=start))
    assert len(tasks) == 3  # its three rows ran on our cluster, not in a local pool


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_cli_unreachable_scheduler_fails_fast_with_a_message(tmp_path, capsys):
    out = tmp_path / "never"
    address = f"tcp://127.0.0.1:{_free_port()}"  # nothing listens there
    argv = ["--x", "d=5,10", "--y", "z=110,150", "--out", str(out), "--no-progress"]
    t0 = time.monotonic()
    assert sweep_cli.main([*argv, "--scheduler", address, "--connect-timeout", "2"]) == 1
    assert time.monotonic() - t0 < 10  # the 2 s timeout, not a hang
    assert f"cannot reach a Dask scheduler at '{address}' within 2 s" in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(SystemExit) as exc:  # argparse's usage error
        sweep_cli.main([*argv, "--scheduler", "localhost"])
    assert exc.value.code == 2
    assert "bad scheduler address 'localhost'" in capsys.readouterr().err


def test_connect_refuses_what_is_not_a_dask_scheduler():
    with pytest.raises(ValueError, match="unknown address scheme"):
        dask_backend.connect("ftp://127.0.0.1:21")
    with pytest.raises(ValueError, match="timeout"):
        dask_backend.connect("tcp://127.0.0.1:8786", timeout=0)
    # A TCP server that answers with something else (an HTTP error page).
    server = socket.create_server(("127.0.0.1", 0))
    port = server.getsockname()[1]

    def answer():
        with server:
            conn, _ = server.accept()
            with conn:
                conn.sendall(b"HTTP/1.0 400 Bad Request\r\n\r\n" * 64)

    thread = threading.Thread(target=answer, daemon=True)
    thread.start()
    with pytest.raises(ConnectionError, match=f"127.0.0.1:{port}"):
        dask_backend.connect(f"tcp://127.0.0.1:{port}", timeout=2)
    thread.join(timeout=10)


def test_connect_to_a_scheduler_without_workers():
    # A scheduler alone, in this process (cheaper than another subprocess).
    with distributed.LocalCluster(n_workers=0, processes=False, protocol="tcp", host="127.0.0.1",
                                  dashboard_address=":0") as alone:  # any free port
        with pytest.raises(ConnectionError, match="has no worker after 3 s"):
            dask_backend.connect(alone.scheduler_address, timeout=3)  # 3 s: a loaded machine


def test_import_core_does_not_import_dask():
    code = ("import sys, core, core.sweep, core.cli.sweep, core.dask_backend; "
            "print(sorted(m for m in ('dask', 'distributed') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=60, check=True)
    assert done.stdout.strip() == "[]"
