"""Start `panel serve app` on a free loopback port, for tests and benchmarks alike.

The browser that drives it is :mod:`support.page`'s; this module imports no browser."""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

from support import ROOT

#: The server's environment as in the container (Dockerfile ENV): see the note there.
SERVER_ENV = {"PYTHONMALLOC": "malloc"}


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


#: What the server prints when every stage of its warm-up is done, or failed (app/serve/warmup.py).
WARM = "[warm-up] all kernels ready"
WARM_FAILED = "[warm-up] FAILED"


def stop(proc, grace=10.0):
    """Terminate a server process, kill it if it has not ended within ``grace`` seconds (a busy
    machine: Tornado's shutdown can take longer), and reap it (a Popen left running warns,
    ResourceWarning, in a later test)."""
    proc.terminate()
    try:
        proc.wait(grace)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


@contextlib.contextmanager
def served_app(*extra, port=None, timeout=600, log=None):
    """Yield the base URL of a running dashboard; stop it afterwards. ``log``: a path that gets
    the server's output (else a temporary file, echoed unless QUIET_SERVER is set).
    ``timeout``: seconds until the server's warm-up has compiled every numba kernel (it serves
    from the start, app/server_lifecycle.py; 2-4 min on 2 cores when the cache is cold): tests
    start on a warm server, as a user does after the first start."""
    port = port or free_port()
    cmd = [sys.executable, "-m", "panel", "serve", "app", "--port", str(port), "--address", "127.0.0.1",
           "--allow-websocket-origin", f"127.0.0.1:{port}", "--liveness", "--num-threads", "4", *extra]
    with contextlib.ExitStack() as stack:
        path = Path(log) if log is not None else Path(stack.enter_context(
            tempfile.TemporaryDirectory(prefix="served-app-"))) / "server.log"
        with open(path, "w") as fh:  # the child keeps its own descriptor
            proc = subprocess.Popen(cmd, cwd=ROOT, stdout=fh, stderr=subprocess.STDOUT,
                                    env={**os.environ, **SERVER_ENV})
        url = f"http://127.0.0.1:{port}"
        try:
            deadline = time.time() + timeout
            while True:
                text = path.read_text(errors="replace")
                if proc.poll() is not None or WARM_FAILED in text:
                    raise RuntimeError(f"panel serve failed ({proc.returncode}):\n{text[-3000:]}")
                if WARM in text:
                    break
                if time.time() > deadline:
                    raise TimeoutError(f"the dashboard did not warm up in {timeout} s:\n{text[-3000:]}")
                time.sleep(0.3)
            # The first page builds the app; do it here, once, rather than inside a test's timeout.
            with urllib.request.urlopen(url + "/app", timeout=timeout) as page:
                page.read()
            yield url, proc
        finally:
            stop(proc)
            if log is None and not os.environ.get("QUIET_SERVER"):
                sys.stderr.write(path.read_text(errors="replace"))


async def close_websocket(conn, timeout=10.0):
    """Close a Tornado websocket client and wait until its socket is closed: one still open when
    the event loop ends is reported much later, by whichever test is running, as a ResourceWarning."""
    stream = conn.protocol.stream if conn.protocol is not None else None
    conn.close()
    deadline = time.monotonic() + timeout
    while stream is not None and not stream.closed() and time.monotonic() < deadline:
        await asyncio.sleep(0.01)


def on_thread(fn, *args, timeout=300):
    """``fn(*args)`` on a thread of its own: a websocket client (bench.load_test.Client) made
    there has an event loop of its own, which its close closes (one made on the main thread
    would share the main thread's, left open)."""
    out = []
    t = threading.Thread(target=lambda: out.append(fn(*args)))
    t.start()
    t.join(timeout)
    return out[0] if out else None


def close_client(client):
    """Close a bench.load_test.Client (call with :func:`on_thread`)."""
    asyncio.set_event_loop(client.conn._loop.asyncio_loop)  # the client's own, for its last writes
    client.close()


#: The line on which a probe (a test module run as ``python -m tests.NAME``, serving the app in
#: a process of its own) prints its result as JSON.
PROBE = "probe "


def report(out):
    """Print a probe's result ``out`` (a dict with ``complete``) for :func:`run_probe`."""
    print(PROBE + json.dumps(out), flush=True)


def probe_main(probe):
    """A probe module's ``__main__``: run ``probe()``, then leave at once (the served app's
    server thread is not a daemon, and would keep the process)."""
    probe()
    sys.stdout.flush()
    os._exit(0)


def run_probe(module, timeout=900):
    """Run the probe ``python -m module`` at the repository root; its result (the last probe
    line), which must say it completed."""
    run = subprocess.run([sys.executable, "-m", module], cwd=ROOT, capture_output=True, text=True,
                         timeout=timeout)
    lines = [line for line in run.stdout.splitlines() if line.startswith(PROBE)]
    assert lines, run.stdout + run.stderr[-3000:]
    out = json.loads(lines[-1].removeprefix(PROBE))
    assert out["complete"], run.stderr[-3000:]
    return out
