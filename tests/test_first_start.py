"""A first start (no compiled kernels yet): the server answers at once, says on the terminal that
it compiles and what, and the page says so and reloads itself into the dashboard when ready."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import panel as pn

from app.serve.warming import warming_page
from app.serve.warmup import STAGES, WARMING_MARK, Warmup
from support.page import chromium_browser
from support.server import ROOT, SERVER_ENV, free_port, stop

#: Runs alone, after the rest (``pytest -m serial``; tests/conftest.py):
SERIAL = "it times starts of the server (compiles and warm-ups) against the page's polls"

#: Seconds within which a cold server must answer /app (issue 29's bar: 15 s on this machine).
ANSWER_WITHIN_S = 15.0


def _get(url, timeout=5.0):
    with urllib.request.urlopen(url, timeout=timeout) as reply:
        return reply.read()


def test_a_cold_server_answers_at_once_with_the_warming_page_and_says_it_compiles(tmp_path):
    """An empty numba cache (NUMBA_CACHE_DIR) is a first start: before this change the server
    compiled for minutes before it listened, and printed nothing about it."""
    port = free_port()
    log = tmp_path / "server.log"
    cmd = [sys.executable, "-m", "panel", "serve", "app", "--port", str(port), "--address",
           "127.0.0.1", "--allow-websocket-origin", f"127.0.0.1:{port}", "--liveness"]
    env = {**os.environ, **SERVER_ENV, "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
    t0 = time.monotonic()
    with open(log, "w") as fh:
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=fh, stderr=subprocess.STDOUT, env=env)
    try:
        page = None
        while time.monotonic() - t0 < ANSWER_WITHIN_S:
            assert proc.poll() is None, log.read_text()
            try:
                page = _get(f"http://127.0.0.1:{port}/app")
                break
            except OSError:
                time.sleep(0.2)
        answered = time.monotonic() - t0
        assert page is not None, f"/app did not answer in {ANSWER_WITHIN_S} s:\n{log.read_text()}"
        assert WARMING_MARK.encode() in page, "a cold server served the dashboard before compiling"
        text = log.read_text()
        assert "[warm-up] compiling the numba kernels: first start" in text, text
        # The first stage's line comes from the child process once it has imported the core (a
        # few seconds, longer on a loaded machine): waited for, not assumed.
        first_stage = f"1/{len(STAGES)}: {STAGES[0][0]} ..."
        while first_stage not in text and time.monotonic() - t0 < ANSWER_WITHIN_S + 45:
            assert proc.poll() is None, text
            time.sleep(0.2)
            text = log.read_text()
        assert first_stage in text, text
        assert "ready in" not in text  # nothing of the default page can be compiled this fast
        print(f"cold server: /app answered in {answered:.1f} s")
    finally:
        stop(proc)


def test_the_warming_page_shows_progress_and_reloads_into_the_dashboard_when_ready():
    """The real warming page and Warmup class, served by Panel, in Chromium: its stage 0 is held
    by an event so that the test decides when the kernels are 'ready'."""
    release = threading.Event()
    warmup = Warmup(stages=(("held stage", release.wait), ("second", lambda: None)),
                    out=open(os.devnull, "w"))
    warmup.start()

    def page():
        if not warmup.ready(0):
            return warming_page(warmup)
        return pn.pane.Markdown("dashboard served", css_classes=["served-after-reload"])

    port = free_port()
    server = pn.serve({"app": page}, port=port, address="127.0.0.1", show=False, threaded=True,
                      websocket_origin=[f"127.0.0.1:{port}"])
    try:
        with chromium_browser() as browser:
            tab = browser.new_page(viewport={"width": 1280, "height": 800})
            tab.goto(f"http://127.0.0.1:{port}/app?d=20", timeout=60_000)
            status = tab.locator(".warmup-status p")  # Panel renders its panes in shadow roots
            status.wait_for(timeout=30_000)
            first = status.inner_text()
            assert "stage 1 of 2: held stage" in first
            # the elapsed seconds move: the page is alive, not a blank screen
            deadline = time.monotonic() + 10
            while status.inner_text() == first:
                assert time.monotonic() < deadline, "the warming page stood still"
                time.sleep(0.2)
            release.set()
            tab.locator(".served-after-reload").wait_for(timeout=30_000)
            assert tab.url.endswith("/app?d=20")  # same address after the reload
            tab.close()
    finally:
        release.set()
        server.stop()
        warmup.out.close()


def test_a_page_whose_browser_connects_after_the_warm_up_ended_still_reloads():
    """The race of issue 40 (a page opened as the warm-up ends stood on "loading the dashboard…"
    for good): the kernels are ready right after the warming page is built, and the browser is
    held back (its Panel bundle delayed 3 s) so that it connects only after the server's first
    poll. A reload asked for before the browser had connected came as the page's initial state,
    which the browser does not act on."""
    release = threading.Event()
    warmup = Warmup(stages=(("held stage", release.wait),), out=open(os.devnull, "w"))
    warmup.start()

    def page():
        if not warmup.ready(0):
            shown = warming_page(warmup)
            release.set()  # ready before this page's browser has even loaded its scripts
            return shown
        return pn.pane.Markdown("dashboard served", css_classes=["served-after-reload"])

    port = free_port()
    server = pn.serve({"app": page}, port=port, address="127.0.0.1", show=False, threaded=True,
                      websocket_origin=[f"127.0.0.1:{port}"])

    def slow(route):
        time.sleep(3.0)  # > POLL_S: the server's poll has seen the kernels ready by then
        route.continue_()

    try:
        with chromium_browser() as browser:
            tab = browser.new_page(viewport={"width": 1280, "height": 800})
            tab.route("**/panel.min.js*", slow)
            tab.goto(f"http://127.0.0.1:{port}/app?d=20", timeout=60_000)
            tab.locator(".served-after-reload").wait_for(timeout=30_000)
            assert tab.url.endswith("/app?d=20")
            tab.close()
    finally:
        release.set()
        server.stop()
        warmup.out.close()


#: Seconds a page opened at a start may take to show the dashboard's three maps: a warm start
#: loads the kernels in seconds; the bound leaves room for a machine loaded by other work (the
#: issue saw 16 s to the first answer at load 5-8).
DASHBOARD_WITHIN_S = 180.0


def starts_reach_the_dashboard(starts, env=None, browser=None, cold=None, within=DASHBOARD_WITHIN_S):
    """Start `panel serve app` ``starts`` times in a row; each time open /app in Chromium as soon
    as /liveness answers, touch nothing, and wait for the dashboard's three maps. Returns the
    seconds from the start to the maps, per start; raises on a page that never gets there (after
    ``within`` s). ``cold``: a folder in which each start gets an empty numba cache of its own
    (NUMBA_CACHE_DIR): a first start, which compiles every kernel."""
    from support.page import maps

    times = []
    env = {**os.environ, **SERVER_ENV, **(env or {})}
    for start in range(starts):
        if cold is not None:
            env["NUMBA_CACHE_DIR"] = str(Path(cold) / f"numba-cache-{start}")
        port = free_port()
        cmd = [sys.executable, "-m", "panel", "serve", "app", "--port", str(port), "--address",
               "127.0.0.1", "--allow-websocket-origin", f"127.0.0.1:{port}", "--liveness"]
        t0 = time.monotonic()
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                env=env)
        try:
            while True:
                assert proc.poll() is None, "the server ended"
                try:
                    _get(f"http://127.0.0.1:{port}/liveness", timeout=2.0)
                    break
                except OSError:
                    time.sleep(0.05)
            tab = browser.new_page(viewport={"width": 1280, "height": 800})
            try:
                tab.goto(f"http://127.0.0.1:{port}/app", timeout=120_000)
                while len(_maps_or_none(tab, maps) or []) != 3:
                    assert time.monotonic() - t0 < within, (
                        f"start {len(times) + 1}: no dashboard after {within} s "
                        f"(page: {tab.inner_text('body')[:200]!r})")
                    time.sleep(0.25)
            finally:
                tab.close()
            times.append(time.monotonic() - t0)
        finally:
            stop(proc)
    return times


def _maps_or_none(tab, maps):
    try:  # a page that is reloading, or the warming page, has no maps to read
        return maps(tab) if tab.evaluate("() => !!(window.Bokeh && Bokeh.index)") else None
    except Exception:  # noqa: BLE001 (Playwright: the execution context was destroyed)
        return None


def test_ten_starts_in_a_row_each_reach_the_dashboard_with_a_warm_cache():
    """Issue 40: a page opened as soon as /liveness answers, on a fresh server with the numba
    cache warm, stood on the warming page for good in 2 of 8 and 5 of 5 starts."""
    with chromium_browser() as browser:
        times = starts_reach_the_dashboard(10, browser=browser)
    print("seconds from the start to the maps, per start:", [round(t, 1) for t in times])
    assert len(times) == 10


#: Cold starts in a row (each compiles the default page's kernels, ~1.5-5 min on 2 cores; the
#: issue asks for ten: COLD_STARTS=10), and the seconds each may take to show the maps (the
#: issue saw 5.2 min at load 5-8; the bound leaves room beyond it).
COLD_STARTS = int(os.environ.get("COLD_STARTS", "1"))
COLD_DASHBOARD_WITHIN_S = 900.0


def test_starts_with_a_cold_cache_each_reach_the_dashboard(tmp_path):
    """Issue 40: the same as a warm start, from an empty numba cache each time: the page opened as
    soon as /liveness answers is the warming page, which must reload itself into the dashboard."""
    with chromium_browser() as browser:
        times = starts_reach_the_dashboard(COLD_STARTS, browser=browser, cold=tmp_path,
                                           within=COLD_DASHBOARD_WITHIN_S)
    print("cold cache: seconds from the start to the maps, per start:", [round(t, 1) for t in times])
    assert len(times) == COLD_STARTS
