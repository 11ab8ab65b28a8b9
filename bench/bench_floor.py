"""The floor (issue 29 item 4): the dashboard against two minimal apps that do the same visible
work, measured one after the other in one run, so every figure is a ratio to the floor measured
that hour.

    python -m bench.bench_floor [--changes 20] [--runs 2] [--pages 3] [--out floor.json]

The floor apps (bench/floor/): three maps of a 200 × 200 float32 image with a veil layer, two
stations, a colour bar and a hover tool, updated in place (data sources' data replaced) from a
slider's ``value_throttled`` with ~10 ms of numpy (bench/floor/maps.py) — ``bokeh_app.py`` in
plain Bokeh (``bokeh serve``), ``panel_app.py`` in Panel with a Bootstrap template. Each run
serves the project (support/server.py's ``served_app``), then the Panel floor, then the Bokeh floor,
and measures for each:

(a) slider release → all three maps painted in Chromium: bench/bench_browser.py's instrumentation
    (INIT_JS, INSTALL_JS, ...) and its mouse drag of the slider with css class ``w-Ph`` (the floor
    apps' sliders carry the same class), ``--changes`` measured changes after ``--warmup``; every
    change is checked: a new slider value never used before, three new image arrays painted, and
    map A as drawn equal to the in-process computation of that value;
(b) server CPU per update: the server process's CPU time (user + system, psutil) over the measured
    changes, minus its idle rate measured just before (× the changes' wall time), divided by the
    number of changes; and, apart, the CPU of computing one update's maps in the bench's own
    process (:func:`compute_cpu_ms`), so the rest (events, drawing, messages) is compared too;
(c) a new session's page: the server's CPU from the request (``page.goto``) until the page's Bokeh
    document is ready (a document with three plot views), minus idle; also until the page's
    websocket has been quiet for ``--quiet-ms`` (work the page triggers after it is shown). The
    new pages stay open until all ``--pages`` are measured (a closing session's cost would fall
    into the next page's window);
(d) the number of Bokeh models in the page (``Bokeh.documents[0].all_models``): a new session's
    page once its websocket is quiet (and, in the JSON, the first page's after its changes).

The table gives absolute values and ratios to the minimal Panel app, with the issue's targets:
release → paint median ≤ 1.3×, CPU per update ≤ 1.3× (with the drag previews, issue 46), new page
CPU ≤ 1.5× (issue 46; ready and quiet: the page's sidebar is built after its maps,
app.page.in_parts).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

import numpy as np
import psutil

from bench.bench_browser import (
    COLLECT_JS,
    INIT_JS,
    INSTALL_JS,
    MAP_A_SUM_JS,
    PH_VALUE_JS,
    RESET_JS,
    analyse,
    drag_to,
    expected_map_a_sum,
    fractions,
    pct,
    scenario,
    wait_redrawn,
)
from support.page import chromium_browser
from support.server import ROOT, SERVER_ENV, free_port, served_app, stop

#: The issues' targets: ratio to the minimal Panel app, measured in the same run (a new page's
#: CPU: issue 29 asked 2×, issue 40 1.2×, issue 46 1.5×, until the page's websocket is quiet as
#: well; CPU per update: issue 40 asked 1.5×, issue 46 1.3× with the previews on).
TARGETS = {"release_paint_median_ms": 1.3, "cpu_per_update_ms": 1.3, "new_page_cpu_ms": 1.5,
           "new_page_cpu_settled_ms": 1.5}

#: The three plot views (bench_browser's INSTALL_JS finds plots the same way).
THREE_PLOTS_JS = ("() => { if (!(window.Bokeh && Bokeh.documents.length > 0)) return false; let n = 0;"
                  " const walk = (v) => { if (!v) return;"
                  " if (v.model && v.model.renderers !== undefined && v.model.title !== undefined) n++;"
                  " for (const c of (v.child_views ? Array.from(v.child_views) : [])) walk(c); };"
                  " for (const v of Object.values(Bokeh.index)) walk(v); return n === 3; }")
MODELS_JS = "() => Array.from(Bokeh.documents[0].all_models).length"
#: Time (page clock) of the last websocket message received.
LAST_IN_JS = ("() => { let t = null; for (const m of (window.__ws || [])) if (m[1] === 'in') t = m[0];"
              " return [performance.now(), t]; }")


def cpu_s(proc):
    """User + system CPU time (s) of the process so far."""
    t = psutil.Process(proc.pid).cpu_times()
    return t.user + t.system


def idle_rate(proc, seconds=2.0):
    """The server's CPU seconds per second while nothing is asked of it."""
    c0, t0 = cpu_s(proc), time.perf_counter()
    time.sleep(seconds)
    return (cpu_s(proc) - c0) / (time.perf_counter() - t0)


def compute_cpu_ms(name, repeat=15):
    """CPU (ms, this process: user + system, every thread) of one update's maps computed
    in-process, the median of ``repeat`` new slider values: the project's ``app.tabs.maps.compute.compute``
    (its kernels on numba's threads, as in the server) or the floor apps' ``bench.floor.maps``.
    The floor's compute was set to the project's *wall* time; on two threads the project's uses
    about twice the CPU, which the server's CPU per update carries."""
    if name == "project":
        from app.tabs.maps.compute import Snapshot, compute

        def one(ph):
            compute(Snapshot.of(scenario(Ph=ph)))
    else:
        from bench.floor import maps

        def one(ph):
            maps.compute(ph)
    one(99.9)  # warm-up (numba loads its kernels)
    times = []
    for k in range(repeat):
        c0 = time.process_time()
        one(100.0 + 13.7 * k)  # a value not computed before (the project caches its maps)
        times.append(time.process_time() - c0)
    return 1e3 * statistics.median(times)


@contextlib.contextmanager
def served_floor(kind, timeout=120, stem=None):
    """Serve bench/floor/{stem}_app.py (``stem`` default ``kind``) with ``{kind} serve`` (bokeh or
    panel); yield (url of the app's page, process). Built once before it is yielded, as
    served_app does for the project."""
    port = free_port()
    stem = stem or kind
    script = f"bench/floor/{stem}_app.py"
    cmd = [sys.executable, "-m", kind, "serve", script, "--port", str(port), "--address", "127.0.0.1",
           "--allow-websocket-origin", f"127.0.0.1:{port}"]
    env = {**os.environ, **SERVER_ENV, "PYTHONPATH": str(ROOT)}
    with tempfile.TemporaryDirectory(prefix="floor-") as tmp:
        log = Path(tmp) / "server.log"
        with open(log, "w") as fh:
            proc = subprocess.Popen(cmd, cwd=ROOT, stdout=fh, stderr=subprocess.STDOUT, env=env)
        url = f"http://127.0.0.1:{port}/{stem}_app"
        try:
            deadline = time.time() + timeout
            while True:
                if proc.poll() is not None:
                    raise RuntimeError(f"{kind} serve failed:\n{log.read_text(errors='replace')[-3000:]}")
                try:
                    with urllib.request.urlopen(url, timeout=timeout) as page:
                        page.read()
                    break
                except OSError:
                    if time.time() > deadline:
                        raise TimeoutError(f"{kind} floor did not answer:\n{log.read_text(errors='replace')[-3000:]}")
                    time.sleep(0.3)
            yield url, proc
        finally:
            stop(proc)


def open_page(browser, url):
    """A new page (its own context: a new session) instrumented as bench_browser's, three plots up."""
    page = browser.new_page(viewport={"width": 1700, "height": 1100})
    page.add_init_script(INIT_JS)
    page.goto(url)
    page.wait_for_function(THREE_PLOTS_JS, timeout=120_000)
    return page


def wait_quiet(page, quiet_ms, timeout=60.0):
    """Until the page's websocket has received nothing for ``quiet_ms``."""
    deadline = time.time() + timeout
    while True:
        now, last = page.evaluate(LAST_IN_JS)
        if last is not None and now - last >= quiet_ms:
            return
        if time.time() > deadline:
            raise TimeoutError("the page's websocket never went quiet")
        time.sleep(0.05)


def settle(page, before_tags, before_value, quiet_ms, timeout=60.0):
    """bench_browser's wait for a redraw, with the slider model's value instead of the project's
    text box (which the floor apps do not have); returns the slider's new value."""
    return wait_redrawn(page, before_tags, lambda pg: pg.evaluate(PH_VALUE_JS), before_value,
                        "the slider", quiet_ms, timeout)


def expected_sum(name, value):
    """Sum and count of the finite values of map A as the app sends it for slider value ``value``."""
    if name == "project":
        return expected_map_a_sum(value)
    from bench.floor import maps

    a = maps.compute(value)[0].astype(float)
    return float(np.nansum(np.where(np.isfinite(a), a, np.nan))), int(np.isfinite(a).sum())


def measure_app(name, url, proc, browser, args):
    """(a)-(d) for one served app; returns a dict of raw values."""
    page = open_page(browser, url)
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.evaluate(INSTALL_JS)
    time.sleep(2.0)  # initial paints, deferred work
    wait_quiet(page, args.quiet_ms)
    positions = [0.9 - 0.05 * i for i in range(args.warmup)] + fractions(args.changes)
    drawn, values, cpu_each, cpu_total, wall_total = [], [], [], 0.0, 0.0
    idle = None
    for k, frac in enumerate(positions):
        warm = k < args.warmup
        if k == args.warmup:
            idle = idle_rate(proc)
        before_value = page.evaluate(PH_VALUE_JS)
        sum_before = page.evaluate(MAP_A_SUM_JS)[0]
        before_tags = page.evaluate(RESET_JS)
        c0, t0 = cpu_s(proc), time.perf_counter()
        drag_to(page, frac)
        value = settle(page, before_tags, before_value, args.quiet_ms)
        c1, t1 = cpu_s(proc), time.perf_counter()
        log = page.evaluate(COLLECT_JS)
        if log["up"] is None:
            raise RuntimeError("no pointerup/mouseup seen by the page")
        got_sum, got_n, _ = page.evaluate(MAP_A_SUM_JS)
        exp_sum, exp_n = expected_sum(name, value)
        if got_n != exp_n or abs(got_sum - exp_sum) > 1e-9 * max(1.0, abs(exp_sum)):
            raise AssertionError(f"{name}: drawn map A (sum {got_sum}, n {got_n}) is not the slider's "
                                 f"{value} (expected {exp_sum}, {exp_n}): a stale image?")
        if got_sum == sum_before:
            raise AssertionError(f"{name}: map A did not change")
        if value in values:
            raise AssertionError(f"{name}: value {value} was used before (a cache could answer)")
        values.append(value)
        r = analyse(log)
        if not warm:
            drawn.append(r["drawn"])
            cpu_total += c1 - c0
            cpu_each.append(1e3 * (c1 - c0))
            wall_total += t1 - t0
        print(f"  {name:8} {'warm-up' if warm else f'{k - args.warmup + 1:7d}'}  value {value:8.2f}  "
              f"drawn {r['drawn']:6.1f} ms  server CPU {1e3 * (c1 - c0):5.0f} ms", flush=True)
    models_after = page.evaluate(MODELS_JS)
    # (c) new sessions' pages, kept open until all are measured
    pages, new_ready, new_settled, models = [], [], [], []
    for _ in range(args.pages):
        wait_quiet(page, args.quiet_ms)
        c0, t0 = cpu_s(proc), time.perf_counter()
        p = open_page(browser, url)
        c1, t1 = cpu_s(proc), time.perf_counter()
        wait_quiet(p, args.quiet_ms)
        c2, t2 = cpu_s(proc), time.perf_counter()
        pages.append(p)
        models.append(p.evaluate(MODELS_JS))
        new_ready.append(1e3 * (c1 - c0 - idle * (t1 - t0)))
        new_settled.append(1e3 * (c2 - c0 - idle * (t2 - t0 - args.quiet_ms / 1e3)))
        print(f"  {name:8} new page: server CPU {new_ready[-1]:6.0f} ms until ready ({t1 - t0:.2f} s), "
              f"{new_settled[-1]:6.0f} ms until quiet; {models[-1]} models", flush=True)
    for p in pages:
        p.close()
    page.close()
    if errors:
        print(f"  {name}: page errors: {errors}")
    return {"drawn_ms": drawn, "cpu_each_ms": cpu_each, "cpu_update_s": cpu_total, "cpu_wall_s": wall_total,
            "changes": len(drawn), "idle_cpu_per_s": idle, "new_page_ready_ms": new_ready,
            "new_page_settled_ms": new_settled,
            "models": models[0], "models_after_changes": models_after, "errors": errors}


APPS = ("project", "panel", "bokeh")
LABELS = {"project": "this project", "panel": "Panel, minimal", "bokeh": "Bokeh, minimal"}


def summarise(raw):
    """Pool the runs: per app, the table's figures (ms, count)."""
    out = {}
    for name in raw:
        runs = raw[name]
        drawn = [x for r in runs for x in r["drawn_ms"]]
        n = sum(r["changes"] for r in runs)
        cpu = sum(r["cpu_update_s"] for r in runs)
        wall = sum(r["cpu_wall_s"] for r in runs)
        idle = statistics.mean(r["idle_cpu_per_s"] for r in runs)
        out[name] = {
            "release_paint_median_ms": statistics.median(drawn),
            "release_paint_p95_ms": pct(drawn, 95),
            "release_paint_run_medians_ms": [statistics.median(r["drawn_ms"]) for r in runs],
            "cpu_per_update_ms": 1e3 * (cpu - sum(r["idle_cpu_per_s"] * r["cpu_wall_s"] for r in runs)) / n,
            "cpu_per_update_raw_ms": 1e3 * cpu / n,
            # robust to a single stall (e.g. a garbage collection) inside one change; 10 ms ticks
            "cpu_per_update_median_ms": statistics.median([x for r in runs for x in r["cpu_each_ms"]]),
            "idle_cpu_ms_per_s": 1e3 * idle,
            "new_page_cpu_ms": statistics.median([x for r in runs for x in r["new_page_ready_ms"]]),
            "new_page_cpu_all_ms": [x for r in runs for x in r["new_page_ready_ms"]],
            "new_page_cpu_settled_ms": statistics.median([x for r in runs for x in r["new_page_settled_ms"]]),
            "models": runs[-1]["models"],
            "compute_cpu_ms": statistics.median(r["compute_cpu_ms"] for r in runs),
            "changes": n,
            "wall_per_change_s": wall / n,
        }
    for v in out.values():  # what the server spends on an update besides computing its maps
        v["cpu_per_update_rest_ms"] = v["cpu_per_update_ms"] - v["compute_cpu_ms"]
    for name in out if "panel" in out else ():  # the ratios need the Panel floor in the run
        out[name]["ratio_to_panel"] = {k: out[name][k] / out["panel"][k] for k in
                                       ("release_paint_median_ms", "release_paint_p95_ms", "cpu_per_update_ms",
                                        "cpu_per_update_median_ms", "compute_cpu_ms", "cpu_per_update_rest_ms",
                                        "new_page_cpu_ms", "new_page_cpu_settled_ms", "models")}
    return out


def table(summary):
    s = summary
    apps = list(s)
    rows = [
        ("slider release → three maps painted, median (ms)", "release_paint_median_ms", "{:.0f}"),
        ("  p95 (ms)", "release_paint_p95_ms", "{:.0f}"),
        ("server CPU per update (ms)", "cpu_per_update_ms", "{:.1f}"),
        ("  median of the changes (10 ms ticks)", "cpu_per_update_median_ms", "{:.0f}"),
        ("  of which computing the maps (in-process CPU, ms)", "compute_cpu_ms", "{:.1f}"),
        ("  the rest: events, drawing, messages (ms)", "cpu_per_update_rest_ms", "{:.1f}"),
        ("a new session's page: server CPU until ready (ms)", "new_page_cpu_ms", "{:.0f}"),
        ("  … until its websocket is quiet (ms)", "new_page_cpu_settled_ms", "{:.0f}"),
        ("Bokeh models in the page", "models", "{:.0f}"),
    ]
    head = "| | " + " | ".join(LABELS[a] for a in apps) + " | target (project / Panel) |"
    lines = [head, "|---" * (len(apps) + 2) + "|"]
    for label, key, fmt in rows:
        cells = []
        for a in apps:
            v = fmt.format(s[a][key])
            ratio = s[a].get("ratio_to_panel")
            cells.append(v if a == "panel" or ratio is None else f"{v} ({ratio[key]:.2f}×)")
        target = TARGETS.get(key)
        verdict = ""
        if target and "project" in s and "panel" in s:
            ok = s["project"]["ratio_to_panel"][key] <= target
            verdict = f"≤ {target}× {'✓' if ok else '✗'}"
        lines.append(f"| {label} | " + " | ".join(cells) + f" | {verdict} |")
    return "\n".join(lines)


def started_on(known, chosen):
    """A browser benchmark's start (this one's and bench/bench_drag.py's): quiet servers, the
    machine's load average said and kept (a list, one entry per run follows), the apps of
    ``known`` named in ``chosen`` (comma-separated) in their order, and an empty list of raw
    values per app: (load, apps, raw)."""
    os.environ.setdefault("QUIET_SERVER", "1")
    load = [os.getloadavg()]
    print(f"machine: {os.cpu_count()} cores, load average {' '.join(f'{x:.2f}' for x in load[0])} at start")
    apps = [a for a in known if a in chosen.split(",")]
    return load, apps, {a: [] for a in apps}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--changes", type=int, default=20, help="measured slider changes per app and run")
    ap.add_argument("--runs", type=int, default=2, help="runs (each serves the three apps in turn)")
    ap.add_argument("--warmup", type=int, default=2, help="unmeasured changes first")
    ap.add_argument("--pages", type=int, default=3, help="new sessions' pages measured per app and run")
    ap.add_argument("--quiet-ms", type=float, default=1000.0,
                    help="websocket silence that ends a change (no later image can be missed)")
    ap.add_argument("--apps", default=",".join(APPS), help="which of project,panel,bokeh (panel is the reference)")
    ap.add_argument("--out", default=None, help="write the raw values and the summary as JSON here")
    ap.add_argument("--serve-args", default="",
                    help="extra `panel serve` options for the project only, e.g. '--reuse-sessions warm'")
    args = ap.parse_args(argv)
    load, apps, raw = started_on(APPS, args.apps)
    started = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())
    with chromium_browser() as browser:
        for run in range(args.runs):
            for name in apps:
                serve = served_app(*args.serve_args.split()) if name == "project" else served_floor(name)
                with serve as (url, proc):
                    if name == "project":
                        url += "/app"
                    print(f"run {run + 1}/{args.runs}: {LABELS[name]} at {url} "
                          f"(load {os.getloadavg()[0]:.2f})", flush=True)
                    raw[name].append(measure_app(name, url, proc, browser, args))
                raw[name][-1]["compute_cpu_ms"] = compute_cpu_ms(name)  # here, the server stopped
            load.append(os.getloadavg())
    summary = summarise(raw)
    print()
    print(table(summary))
    print("\nrun medians of release → painted (ms): " + "; ".join(
        f"{LABELS[a]} {', '.join(f'{x:.0f}' for x in summary[a]['release_paint_run_medians_ms'])}" for a in summary))
    print("server idle CPU (ms/s, subtracted): " + ", ".join(
        f"{LABELS[a]} {summary[a]['idle_cpu_ms_per_s']:.1f}" for a in summary))
    print("load average (1, 5, 15 min) at start and after each run: " + "; ".join(
        " ".join(f"{x:.2f}" for x in avg) for avg in load))
    if args.out:
        Path(args.out).write_text(json.dumps({"started": started, "args": vars(args), "load": load,
                                              "summary": summary, "raw": raw}, indent=1))
        print(f"written {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
