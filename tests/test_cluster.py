"""Replicas behind nginx (app/serve/cluster.py, deploy/nginx.conf), all real, on loopback.

One ``python -m app.serve.cluster --replicas 2`` for the module. The tests run in file order: the
page and a slider change through the proxy; a link too long refused with a page; a browser's page and its websocket reach the same
replica (nginx's access log names the replica of every request); one replica killed, the
sessions on the other carry on and new sessions are served by it; SIGTERM stops everything.
Which replica holds a websocket session is read from the operating system: each replica's
established connections on its port (nginx opens one per websocket, and none else stays open).
"""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path

import psutil
import pytest

from bench.load_test import Client
from support.page import chromium_browser
from support.server import ROOT, close_client, free_port, on_thread

#: Runs alone, after the rest (``pytest -m serial``; tests/conftest.py):
SERIAL = "it runs nginx and replicas and kills one"


class Running:
    """The cluster started by ``python -m app.serve.cluster``, as it describes itself on stdout."""

    def __init__(self, replicas=2):
        self.port = free_port()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "app.serve.cluster", "--replicas", str(replicas), "--port", str(self.port)],
            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        self.replicas, self.lines = [], []  # [(pid, port)]
        self.nginx = self.prefix = self.url = None
        for line in self.proc.stdout:  # until it says it is ready
            self.lines.append(line)
            if m := re.match(r"replica \d+: pid (\d+) at http://127\.0\.0\.1:(\d+)", line):
                self.replicas.append((int(m[1]), int(m[2])))
            elif m := re.match(r"nginx: pid (\d+), prefix (\S+)", line):
                self.nginx, self.prefix = int(m[1]), Path(m[2])
            elif m := re.match(r"dashboard ready at (http://\S+)/app", line):
                self.url = m[1]
                break
        if self.url is None:
            self.proc.wait(30)
            raise RuntimeError("app.serve.cluster did not start: " + "".join(self.lines))
        threading.Thread(target=self.proc.stdout.read, daemon=True).start()  # drain the rest
        self.tree = [psutil.Process(self.proc.pid), *psutil.Process(self.proc.pid).children(recursive=True)]

    def access_log(self):
        return (self.prefix / "logs" / "access.log").read_text()

    def websockets(self):
        """{replica port: number of connections established to it}."""
        count = {}
        for pid, port in self.replicas:
            try:
                conns = psutil.Process(pid).net_connections(kind="tcp")
            except psutil.NoSuchProcess:
                continue
            count[port] = sum(1 for c in conns if c.status == psutil.CONN_ESTABLISHED and c.laddr.port == port)
        return count

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(60)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.proc.stdout.close()


@pytest.fixture(scope="module")
def cluster():
    running = Running(replicas=2)
    try:
        yield running
    finally:
        running.stop()
        for p in running.tree:  # whatever a failed test left
            if p.is_running() and p.status() != psutil.STATUS_ZOMBIE:
                p.kill()


def _connect(cluster):
    """A new websocket session through the proxy, and the replica port it landed on."""
    before = cluster.websockets()
    client = on_thread(Client, cluster.url)
    assert client is not None, "a new session through the proxy did not connect"
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        now = cluster.websockets()
        grown = [port for port in now if now[port] > before.get(port, 0)]
        if len(grown) == 1:
            return client, grown[0]
        time.sleep(0.1)
    on_thread(close_client, client)
    raise AssertionError(f"cannot tell the session's replica: connections {before} -> {now}")


def test_the_page_loads_and_a_slider_change_comes_back_through_the_proxy(cluster):
    with urllib.request.urlopen(cluster.url + "/app", timeout=180) as reply:
        page = reply.read().decode()
        cookie = reply.headers["Set-Cookie"]
    assert "Dipole observability explorer" in page
    assert re.match(r"dashboard_route=[0-9a-f]{32}; Path=/", cookie), cookie
    client = on_thread(Client, cluster.url)
    try:
        assert client.change(client.ph, "value_throttled", 137.25, client.maps_done) is not None
        assert client.refuse(-4.5) is not None  # and a refused value's message
    finally:
        on_thread(close_client, client)


def test_a_link_too_long_gets_a_page_that_says_so(cluster):
    # issue 40 (low): a ~74 KB link got the browser's empty-response error (over 64 KiB of
    # headers Tornado closes the request without a reply); nginx refuses it first, with a page
    link = cluster.url + "/app?" + urllib.parse.urlencode({"Ph": "1" * 74_000})
    with pytest.raises(urllib.error.HTTPError) as refused:
        urllib.request.urlopen(link, timeout=60)
    assert refused.value.code == 414
    page = refused.value.read().decode()
    assert "This link is too long" in page and 'href="/app"' in page, page
    # a link of the page's own size still opens the dashboard
    with urllib.request.urlopen(cluster.url + "/app?Ph=150&tab=Track", timeout=180) as reply:
        assert "Dipole observability explorer" in reply.read().decode()


def test_a_browsers_page_and_its_websocket_reach_the_same_replica(cluster):
    routes = []
    with chromium_browser() as browser:
        for _ in range(2):  # two browsers (own cookies): each must stick to its replica
            context = browser.new_context()
            page = context.new_page()
            page.goto(cluster.url + "/app", timeout=180_000)
            page.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=180_000)
            page.wait_for_function("() => Bokeh.documents[0].roots().length > 3", timeout=60_000)
            routes.append(next(c["value"] for c in context.cookies() if c["name"] == "dashboard_route"))
            context.close()  # closes the websocket: nginx logs it
    deadline = time.monotonic() + 30
    while True:
        log = cluster.access_log()
        found = {route: re.findall(rf'"GET (/app(?:/ws)?)(?:\?\S*)? HTTP/1.1" (\d+) \d+ upstream=(\S+) route={route}',
                                   log) for route in routes}
        if all(any(path == "/app/ws" for path, _, _ in hits) for hits in found.values()):
            break
        assert time.monotonic() < deadline, f"no websocket logged for {routes}:\n{log[-3000:]}"
        time.sleep(0.5)
    for route, hits in found.items():
        page = [up for path, status, up in hits if path == "/app" and status == "200"]
        ws = [up for path, status, up in hits if path == "/app/ws" and status == "101"]
        assert page and ws, hits
        assert set(page) == set(ws), f"route {route}: page from {page}, websocket to {ws}"


def test_a_dead_replica_leaves_rotation_and_the_other_sessions_carry_on(cluster):
    placed = {}
    clients = []
    try:
        while len(placed) < 2 and len(clients) < 12:  # a session on each replica
            client, port = _connect(cluster)
            clients.append(client)
            placed.setdefault(port, client)
        assert len(placed) == 2, f"12 sessions all landed on one replica: {cluster.websockets()}"
        dead_port, live_port = placed
        dead_pid = next(pid for pid, port in cluster.replicas if port == dead_port)
        psutil.Process(dead_pid).kill()
        psutil.Process(dead_pid).wait(30)
        survivor = placed[live_port]
        for k in range(3):  # the survivor's session goes on
            assert survivor.change(survivor.ph, "value_throttled", 210.5 + k, survivor.maps_done) is not None
        for k in range(2):  # new sessions: all served, by the replica that is left
            client, port = _connect(cluster)
            clients.append(client)
            assert port == live_port
            assert client.change(client.ph, "value_throttled", 310.5 + k, client.maps_done) is not None
        for k in range(4):  # and new pages (new cookies: some hash to the dead replica first)
            with urllib.request.urlopen(cluster.url + "/app", timeout=180) as reply:
                assert reply.status == 200
    finally:
        for client in clients:
            on_thread(close_client, client)  # a session of the killed replica is closed already


def test_sigterm_stops_nginx_and_every_replica(cluster):
    tree = [p for p in cluster.tree if p.is_running()]
    assert len(tree) >= 3  # the cluster, nginx, its worker and the replica(s) still alive
    prefix = cluster.prefix
    cluster.proc.send_signal(signal.SIGTERM)
    assert cluster.proc.wait(60) == 0
    gone, alive = psutil.wait_procs(tree, timeout=30)
    assert not alive, f"left behind: {[p.pid for p in alive]}"
    assert not prefix.exists()

