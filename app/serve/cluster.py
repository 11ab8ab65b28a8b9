"""Serve the dashboard from N single-process replicas behind nginx, on one machine.

    python -m app.serve.cluster --replicas 2 --port 8080 [--address 127.0.0.1] [--num-threads 4]
                          [--origin HOST:PORT ...] [-- EXTRA PANEL SERVE ARGUMENTS]

Starts ``--replicas`` ``panel serve app`` processes on free loopback ports, waits until each
answers ``/liveness`` and has built one page (the first page compiles the numba kernels), then
runs Debian's nginx on ``--address:--port`` with ``deploy/nginx.conf`` itself (a symlink to it in a
temporary prefix, next to the ``upstreams.conf`` and ``listen.conf`` written for these replicas;
pid, logs and temporary files stay in that prefix, so no root is needed). Prints the URL and
waits. Ctrl-C or SIGTERM stops nginx and every replica and removes the prefix; the children also
get SIGTERM if this process dies without cleaning up (Linux's parent-death signal). A replica
that exits meanwhile is reported and left out by nginx (passive health checks); if nginx exits,
everything stops.

Several hosts: run ``panel serve app`` on each and nginx with ``deploy/nginx.conf`` and an edited
``deploy/upstreams.conf`` (see there).
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

from app.serve.warmup import WARMING_MARK

#: The repository (this file is app/serve/cluster.py): where `panel serve app` runs and deploy/ is.
ROOT = Path(__file__).resolve().parents[2]
NGINX_CONF = ROOT / "deploy" / "nginx.conf"
NGINX = shutil.which("nginx") or "/usr/sbin/nginx"
#: One failed connection takes a replica out of rotation for this long (see deploy/upstreams.conf).
FAIL_TIMEOUT = "10s"
#: Seconds a stopping process gets before it is killed.
STOP_GRACE = 15.0
_PR_SET_PDEATHSIG = 1


def _die_with_parent():
    """In the child, before exec: SIGTERM when the parent dies (prctl PR_SET_PDEATHSIG)."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


def free_port(address="127.0.0.1"):
    with socket.socket() as s:
        s.bind((address, 0))
        return s.getsockname()[1]


def _get(url, timeout):
    with urllib.request.urlopen(url, timeout=timeout) as reply:
        return reply.read()


def _wait_ready(url, proc, timeout):
    """Wait until ``url``'s ``/liveness`` answers, then until its page is the dashboard."""
    deadline = time.monotonic() + timeout
    while True:
        if proc.poll() is not None:
            raise RuntimeError(f"{url}: the replica exited with {proc.returncode}")
        try:
            _get(url + "/liveness", 2)
            break
        except OSError:
            if time.monotonic() > deadline:
                raise TimeoutError(f"{url} did not answer /liveness in {timeout:.0f} s") from None
            time.sleep(0.3)
    # Then until it serves the dashboard, not the warming-up page of a first start (app/serve/warming.py)
    while WARMING_MARK.encode() in _get(url + "/app", max(10.0, deadline - time.monotonic()) + 180):
        if time.monotonic() > deadline:
            raise TimeoutError(f"{url} still warming up after {timeout:.0f} s")
        time.sleep(1.0)


def _stop(proc, sig=signal.SIGTERM):
    """Signal ``proc``, wait ``STOP_GRACE`` s, kill it if still there; always reaped."""
    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            proc.send_signal(sig)
        try:
            proc.wait(STOP_GRACE)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


class Cluster:
    """N ``panel serve app`` replicas on loopback and nginx in front of them (see the module doc).

    Use as a context manager; ``url`` is the proxy's base URL, ``replicas`` the list of
    ``(Popen, url)``, ``prefix`` nginx's prefix directory (``logs/access.log`` names the replica
    that answered each request)."""

    def __init__(self, replicas=2, port=None, address="127.0.0.1", num_threads=4, origins=(),
                 extra=(), quiet=False, ready_timeout=300.0):
        if not 1 <= replicas <= 32:
            raise ValueError(f"replicas must be 1-32, got {replicas}")
        if port is not None and not 0 < port < 65536:
            raise ValueError(f"port must be 1-65535, got {port}")
        if not os.access(NGINX, os.X_OK):
            raise FileNotFoundError(f"nginx not found at {NGINX} (Debian: apt-get install nginx)")
        self.n, self.address, self.num_threads = replicas, address, num_threads
        self.port = port or free_port(address)
        host = "localhost" if address in ("127.0.0.1", "0.0.0.0", "::") else address
        self.origins = [f"{address}:{self.port}", f"{host}:{self.port}", *origins]
        self.extra, self.quiet, self.ready_timeout = list(extra), quiet, ready_timeout
        self.url = f"http://{address}:{self.port}"
        self.replicas, self.nginx, self.prefix = [], None, None

    def _replica(self, port):
        cmd = [sys.executable, "-m", "panel", "serve", "app", "--address", "127.0.0.1",
               "--port", str(port), "--liveness", "--num-threads", str(self.num_threads),
               "--use-xheaders", *[f"--allow-websocket-origin={o}" for o in self.origins],
               *self.extra]
        out = subprocess.DEVNULL if self.quiet else None
        env = {**os.environ, "PYTHONMALLOC": "malloc"}  # as the Dockerfile: see the note there
        return subprocess.Popen(cmd, cwd=ROOT, stdout=out, stderr=out, env=env,
                                preexec_fn=_die_with_parent)

    def start(self):
        self.prefix = Path(tempfile.mkdtemp(prefix="dipole-cluster-"))
        # nginx's workers run as "nobody" when it is started by root: let them into the prefix.
        self.prefix.chmod(0o755)
        try:
            ports = [free_port() for _ in range(self.n)]
            for port in ports:
                self.replicas.append((self._replica(port), f"http://127.0.0.1:{port}"))
            errors = []

            def ready(proc, url):
                try:
                    _wait_ready(url, proc, self.ready_timeout)
                except Exception as exc:  # noqa: BLE001 - reported below
                    errors.append(f"{url}: {exc}")

            waits = [threading.Thread(target=ready, args=r, daemon=True) for r in self.replicas]
            for t in waits:
                t.start()
            for t in waits:
                t.join()
            if errors:
                raise RuntimeError("replicas not ready: " + "; ".join(errors))
            conf = self.prefix / "conf"
            for sub in ("conf", "logs", "temp"):
                (self.prefix / sub).mkdir()
            (conf / "nginx.conf").symlink_to(NGINX_CONF)
            (conf / "upstreams.conf").write_text("".join(
                f"server 127.0.0.1:{port} max_fails=1 fail_timeout={FAIL_TIMEOUT};\n" for port in ports))
            (conf / "listen.conf").write_text(f"listen {self.address}:{self.port};\n")
            cmd = [NGINX, "-p", f"{self.prefix}/", "-c", str(conf / "nginx.conf"), "-e", "stderr",
                   "-g", "daemon off;"]
            check = subprocess.run([*cmd, "-t", "-q"], capture_output=True, text=True)
            if check.returncode != 0:
                raise RuntimeError(f"nginx -t failed: {check.stderr.strip()}")
            self.nginx = subprocess.Popen(cmd, preexec_fn=_die_with_parent)
            deadline = time.monotonic() + 30
            while True:
                if self.nginx.poll() is not None:
                    raise RuntimeError(f"nginx exited with {self.nginx.returncode}")
                try:
                    _get(self.url + "/liveness", 2)
                    break
                except OSError:
                    if time.monotonic() > deadline:
                        raise TimeoutError(f"nginx did not answer at {self.url}") from None
                    time.sleep(0.2)
        except BaseException:
            self.stop()
            raise
        return self

    def stop(self):
        """Stop nginx (fast shutdown: open websockets are closed) and then every replica."""
        if self.nginx is not None:
            _stop(self.nginx)
        stoppers = [threading.Thread(target=_stop, args=(proc,)) for proc, _ in self.replicas]
        for t in stoppers:
            t.start()
        for t in stoppers:
            t.join()
        if self.prefix is not None:
            shutil.rmtree(self.prefix, ignore_errors=True)
            self.prefix = None

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[:argv.index("--")] if "--" in argv else argv
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--replicas", type=int, default=2, help="panel serve processes (1-32; one per core)")
    ap.add_argument("--port", type=int, default=8080, help="the port nginx listens on")
    ap.add_argument("--address", default="127.0.0.1", help="the address nginx listens on")
    ap.add_argument("--num-threads", type=int, default=4, help="panel serve --num-threads of each replica")
    ap.add_argument("--origin", action="append", default=[],
                    help="another HOST:PORT users reach the proxy at (websocket origin)")
    args = ap.parse_args(argv)
    stopping, started = threading.Event(), threading.Event()

    def on_signal(signum, frame):
        stopping.set()
        if not started.is_set():  # still starting: abandon the start (it stops what it started)
            raise SystemExit(128 + signum)

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    try:
        cluster = Cluster(args.replicas, args.port, args.address, args.num_threads, args.origin, extra)
    except (ValueError, FileNotFoundError) as exc:
        ap.error(str(exc))
    try:
        cluster.start()
        started.set()
        for i, (proc, url) in enumerate(cluster.replicas, 1):
            print(f"replica {i}: pid {proc.pid} at {url}", flush=True)
        print(f"nginx: pid {cluster.nginx.pid}, prefix {cluster.prefix} (logs/access.log: the "
              f"replica of each request)", flush=True)
        print(f"dashboard ready at {cluster.url}/app  (Ctrl-C or SIGTERM stops everything)", flush=True)
        gone = set()
        while not stopping.wait(0.5):
            if cluster.nginx.poll() is not None:
                print(f"nginx exited with {cluster.nginx.returncode}: stopping", file=sys.stderr, flush=True)
                return 1
            for i, (proc, url) in enumerate(cluster.replicas, 1):
                if proc.poll() is not None and i not in gone:
                    gone.add(i)
                    print(f"replica {i} ({url}) exited with {proc.returncode}; nginx routes around it",
                          file=sys.stderr, flush=True)
        print("stopping", flush=True)
        return 0
    finally:
        cluster.stop()


if __name__ == "__main__":
    sys.exit(main())
