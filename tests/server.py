"""Start `panel serve app` on a free loopback port for tests and benchmarks."""

from __future__ import annotations

import asyncio
import contextlib
import os
import socket
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = "/usr/bin/chromium"
#: The server's environment as in the container (Dockerfile ENV): see the note there.
SERVER_ENV = {"PYTHONMALLOC": "malloc"}
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def served_app(*extra, port=None, timeout=600, log=None):
    """Yield the base URL of a running dashboard; stop it afterwards. ``log``: a path that gets
    the server's output (else it goes to the test's, or nowhere with QUIET_SERVER set).
    ``timeout``: seconds until /liveness answers; the server compiles its numba kernels before it
    listens (app/server_lifecycle.py), 3-6 min on 2 cores when the cache is cold."""
    port = port or free_port()
    cmd = [sys.executable, "-m", "panel", "serve", "app", "--port", str(port), "--address", "127.0.0.1",
           "--allow-websocket-origin", f"127.0.0.1:{port}", "--liveness", "--num-threads", "4", *extra]
    out = subprocess.DEVNULL if os.environ.get("QUIET_SERVER") else None
    if log is not None:
        with open(log, "w") as fh:  # the child keeps its own descriptor
            proc = subprocess.Popen(cmd, cwd=ROOT, stdout=fh, stderr=subprocess.STDOUT,
                                    env={**os.environ, **SERVER_ENV})
    else:
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=out, stderr=out, env={**os.environ, **SERVER_ENV})
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.time() + timeout
        while True:
            if proc.poll() is not None:
                raise RuntimeError(f"panel serve exited with {proc.returncode}")
            try:
                with urllib.request.urlopen(url + "/liveness", timeout=2):  # closed: no socket left
                    break  # for a later test's garbage collection to warn about
            except OSError:
                if time.time() > deadline:
                    raise TimeoutError("the dashboard did not answer /liveness") from None
                time.sleep(0.3)
        # The first page builds the app (and compiles any numba kernel the warm-up does not
        # cover); do it here, once, rather than inside a test's timeout.
        with urllib.request.urlopen(url + "/app", timeout=timeout) as page:
            page.read()
        yield url, proc
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:  # a busy machine: Tornado's shutdown can take longer
            proc.kill()
            proc.wait()  # reaped: a Popen left running warns (ResourceWarning) in a later test


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


@contextlib.contextmanager
def chromium_browser():
    """Debian's headless Chromium driven by Playwright (never a downloaded browser)."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            yield browser
        finally:
            browser.close()
