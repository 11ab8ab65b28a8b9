"""Where a new session's page spends the server's event loop (issue 40 item 3).

    python -m bench.bench_page_build [--pages 5] [--top 30] [--floor] [--out build.json]

Serves ``app/main.py`` in this process (Panel's ``get_server``, ``--num-threads 4`` as the
README's command; every kernel compiled first, as ``support.server.served_app`` waits for) and
opens ``--pages`` sessions one after the other with ``bench.load_test.Client`` (websocket, the
server builds the page, the document pulled, ``DocumentReady`` sent, until the page is complete),
each kept open until all are measured (a closing session's cost would fall into the next one's).
Two passes, after one unmeasured session (the first page computes the default maps):

1. **loop steps**: a callback on the server's event loop every ``--tick-ms`` records how late it
   runs. The longest lateness while the pages are built is the longest single step that held the
   loop (Bokeh runs the app's script for a session in one step; the pull of the document is
   another); also the sum of the steps over 50 ms, per page.
2. **split**: ``cProfile`` on the loop's thread over another ``--pages`` sessions: the
   cumulative time per page of the build's parts (the app's ``create_app`` and its pieces,
   Panel's models, Bokeh's document and its pull), and the functions with the most own time.
   The profiler roughly doubles the Python it sees, so read the parts as shares, not times.

``--floor`` serves the minimal Panel app of ``bench.bench_floor`` (bench/floor/panel_app.py: three
maps, one slider, the same template) instead, for its own longest step and split.

Also the Bokeh models of a page (the client's document) and each session's wall time until its
page was complete. Everything here is the server's loop thread; the clients run in this process
on threads of their own (not profiled). ``bench.bench_floor`` gives the page's server CPU as a
ratio to the minimal Panel app's.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import threading
import time
import urllib.request
from pathlib import Path

from support import ROOT
from support.server import free_port

#: The build's parts reported in the split: (label, file suffix, function name). Cumulative
#: times (a part's callees included), so the rows overlap: indented rows are inside the row above.
PARTS = (
    ("a session made (Bokeh: the app's script run for it)", "bokeh/server/contexts.py", "create_session_if_needed"),
    ("  the page's Python objects: app.page.create_app", "app/page.py", "create_app"),
    ("    Scenario()", "app/state/scenario.py", "__init__"),
    ("    the link read (app.state.url.read_link)", "app/state/url.py", "read_link"),
    ("    Maps tab (app.tabs.maps.maps.maps_tab)", "app/tabs/maps/maps.py", "maps_tab"),
    ("      its three figures (app.tabs.maps.figures.build)", "app/tabs/maps/figures.py", "build"),
    ("      their first maps written (map_figures.fill)", "app/tabs/maps/figures.py", "fill"),
    ("      the drag follower (app.tabs.maps.live.Live)", "app/tabs/maps/live.py", "__init__"),
    ("    sidebar cards (app.page._section)", "app/page.py", "_section"),
    ("      number inputs (app.kit.inputs.number_input)", "app/kit/inputs.py", "number_input"),
    ("      number boxes (app.kit.number_box.number_box)", "app/kit/number_box.py", "number_box"),
    ("    URL sync (app.state.url.sync_url)", "app/state/url.py", "sync_url"),
    ("    the template (Panel BootstrapTemplate)", "panel/template/bootstrap/__init__.py", "__init__"),
    ("  servable: Panel's models of the page (Template.server_doc)", "panel/template/base.py", "server_doc"),
    ("    Panel get_root (every root)", "panel/viewable.py", "get_root"),
    ("    Bokeh Document.add_root", "bokeh/document/document.py", "add_root"),
    ("  models frozen: Bokeh re-walks the graph (Models.recompute)", "bokeh/document/models.py", "recompute"),
    ("the document pulled (Bokeh: PULL-DOC-REPLY built)", "bokeh/protocol/messages/pull_doc_reply.py", "create"),
    ("  serialised (Bokeh Serializer)", "bokeh/core/serialization.py", "serialize"),
    ("Panel's onload callbacks (after DocumentReady)", "panel/io/state.py", "_schedule_on_load"),
    ("param watchers run (param's call_watcher)", "param/parameterized.py", "_call_watcher"),
    ("Panel Syncable._update_model (model updates)", "panel/reactive.py", "_update_model"),
)


class LoopTicker:
    """A callback on ``io_loop`` every ``tick`` s recording how late it runs (the step before it)."""

    def __init__(self, io_loop, tick):
        self.io_loop, self.tick = io_loop, tick
        self.late = []  # (time the step ended, its lateness in s)
        self.on = False

    def start(self):
        self.on = True
        self.io_loop.add_callback(self._arm)

    def _arm(self):
        self.expected = time.perf_counter() + self.tick
        self.io_loop.call_later(self.tick, self._fire)

    def _fire(self):
        now = time.perf_counter()
        self.late.append((now, now - self.expected))
        if self.on:
            self._arm()

    def stop(self):
        self.on = False


def wait_served(url, timeout=600):
    deadline = time.time() + timeout
    while True:
        try:
            with urllib.request.urlopen(url, timeout=timeout) as page:
                page.read()
            return
        except OSError:
            if time.time() > deadline:
                raise
            time.sleep(0.3)


class FloorClient:
    """A session of the minimal Panel app (bench/floor/panel_app.py): pulled, announced ready."""

    def __init__(self, url):
        from bokeh.client import pull_session
        from bokeh.document.events import MessageSentEvent
        from bokeh.events import DocumentReady

        self.session = pull_session(url=url + "/app")
        self.conn = self.session._connection
        self.doc = self.session.document
        self.conn._send_patch_document(self.session.id, MessageSentEvent(self.doc, "bokeh_event", DocumentReady()))

    def close(self):
        try:
            self.session.close()
            self.conn.loop_until_closed()
        finally:
            self.conn._loop.close(all_fds=True)


def open_pages(url, n, floor=False):
    """``n`` sessions one after the other, kept open: (clients, seconds each, models each)."""
    from bench.load_test import Client

    clients, seconds, models = [], [], []
    for _ in range(n):
        t0 = time.perf_counter()
        c = FloorClient(url) if floor else Client(url)
        seconds.append(time.perf_counter() - t0)
        models.append(len(list(c.doc.models)))
        clients.append(c)
    return clients, seconds, models


def close_all(clients):
    for c in clients:
        try:
            c.close()
        except Exception:  # noqa: BLE001 - a benchmark's cleanup
            pass


def on_loop(io_loop, fn):
    """Run ``fn()`` on the loop's thread and wait for it."""
    done = threading.Event()

    def run():
        try:
            fn()
        finally:
            done.set()

    io_loop.add_callback(run)
    done.wait(60)


def split(stats, pages):
    """The PARTS rows: (label, ms per page, calls per page)."""
    rows = []
    for label, suffix, func in PARTS:
        ct = nc = 0
        for (file, _, name), (_, n, _, cum, _) in stats.stats.items():
            if name == func and file.replace(os.sep, "/").endswith(suffix):
                ct, nc = ct + cum, nc + n
        rows.append((label, 1e3 * ct / pages, nc / pages))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pages", type=int, default=5, help="sessions measured per pass")
    ap.add_argument("--tick-ms", type=float, default=2.0, help="the loop ticker's period")
    ap.add_argument("--top", type=int, default=30, help="functions listed by own time")
    ap.add_argument("--floor", action="store_true",
                    help="serve the minimal Panel app (bench/floor/panel_app.py) instead: its steps")
    ap.add_argument("--callers", default=None, help="also list the callers of functions matching this")
    ap.add_argument("--out", default=None, help="write the figures as JSON here")
    args = ap.parse_args(argv)
    os.environ.setdefault("QUIET_SERVER", "1")
    print(f"machine: {os.cpu_count()} cores, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())} at start", flush=True)

    import panel as pn

    from app.page import freeze_startup_objects
    from app.serve.warmup import WARMUP

    WARMUP.start()  # as app/server_lifecycle.py does for ``panel serve app``
    for done in WARMUP.done:
        done.wait(900)
    freeze_startup_objects()
    pn.config.nthreads = 4  # ``--num-threads 4``
    port = free_port()
    script = ROOT / "bench" / "floor" / "panel_app.py" if args.floor else ROOT / "app" / "main.py"
    server = pn.serve({"app": str(script)}, port=port, address="127.0.0.1",
                      websocket_origin=[f"127.0.0.1:{port}"], show=False,
                      start=False, liveness=True)
    io_loop = server.io_loop
    url = f"http://127.0.0.1:{port}"
    out, failure = {}, []
    profile = cProfile.Profile()

    def work():
        try:
            wait_served(url + "/app")
            warm, _, _ = open_pages(url, 1, args.floor)  # the first page computes the default maps
            close_all(warm)
            time.sleep(1.0)
            ticker = LoopTicker(io_loop, args.tick_ms / 1e3)
            ticker.start()
            time.sleep(0.5)
            t0 = time.perf_counter()
            clients, seconds, models = open_pages(url, args.pages, args.floor)
            t1 = time.perf_counter()
            time.sleep(0.5)
            ticker.stop()
            close_all(clients)
            steps = [late for t, late in ticker.late if t0 <= t <= t1 + 0.5]
            out["loop"] = {"longest_step_ms": 1e3 * max(steps),
                           "steps_over_50ms_per_page": sum(s > 0.05 for s in steps) / args.pages,
                           "held_in_steps_over_50ms_per_page_ms": 1e3 * sum(s for s in steps if s > 0.05) / args.pages,
                           "five_longest_ms": [round(1e3 * s) for s in sorted(steps)[-5:]],
                           "page_complete_s": seconds, "models": models}
            time.sleep(1.0)
            on_loop(io_loop, profile.enable)
            clients, _, _ = open_pages(url, args.pages, args.floor)
            on_loop(io_loop, profile.disable)
            close_all(clients)
        except Exception as exc:  # noqa: BLE001 - reported below
            failure.append(exc)
        finally:
            io_loop.add_callback(server.stop)
            io_loop.add_callback(io_loop.stop)

    thread = threading.Thread(target=work, daemon=True)
    server.start()
    thread.start()
    io_loop.start()
    thread.join(60)
    if failure:
        raise failure[0]
    loop = out["loop"]
    print(f"\nBokeh models per page: {loop['models']}")
    print("session until its page is complete (s): " + ", ".join(f"{s:.2f}" for s in loop["page_complete_s"]))
    print(f"longest single step holding the server's event loop while {args.pages} pages were built: "
          f"{loop['longest_step_ms']:.0f} ms (five longest: {loop['five_longest_ms']} ms); "
          f"steps over 50 ms per page: {loop['steps_over_50ms_per_page']:.1f}, "
          f"{loop['held_in_steps_over_50ms_per_page_ms']:.0f} ms of loop")
    stats = pstats.Stats(profile)
    rows = split(stats, args.pages)
    out["split"] = [{"part": label.strip(), "ms_per_page": ms, "calls_per_page": n} for label, ms, n in rows]
    print("\nthe build's parts, cumulative ms per page on the loop thread (under cProfile: read as shares)")
    print("| part | ms per page | calls per page |\n|---|---|---|")
    for label, ms, n in rows:
        print(f"| {label.replace('  ', '· ')} | {ms:.0f} | {n:.1f} |")
    total = sum(v[2] for v in stats.stats.values())
    print(f"\nloop thread's profiled time per page: {1e3 * total / args.pages:.0f} ms; by own time:")
    stats.sort_stats("tottime").print_stats(args.top)
    if args.callers:
        stats.print_callers(args.callers)
    print(f"load average at end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    if args.out:
        Path(args.out).write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
