"""Maps that follow a dragged slider (issue 38): the dashboard beside two floor apps, one run.

    python -m bench.bench_drag [--seconds 4] [--runs 2] [--sessions 1,2,3,4] [--loops closed,open]
                               [--out drag.json]
    python -m bench.bench_drag --design [--seconds 4] [--drags 3] [--screenshot design.png]

Part 1, one analyst, in Debian's headless Chromium: the P_h slider's handle is pressed, moved to
and fro over the track every ~16 ms (a closed loop: the next move does not wait for a redraw)
for ``--seconds``, moved to a last place and released at once. Measured in the page's clock
(support/drag.py: every change of each map's image source and the animation frame after it,
the slider's value changes, the pointer events; the websocket's bytes by bench_browser's
INIT_JS) for

* this project (``panel serve app``): the previews drawn while dragging (app/tabs/maps/live.py);
* the raw-Bokeh floor (bench/floor/drag_bokeh_app.py): three 200² float32 maps recomputed on
  every ``value`` the slider sends (no debounce, no throttle: as short as Bokeh makes it);
* the minimal Panel app (bench/floor/drag_panel_app.py): the same through Panel's ``value``.

Figures per app: redraws per second of each map while dragging (image changes painted between
press and release / the drag's duration); input → painted, p50 and p95 (each redraw of map B
matched to the slider value it shows by its fingerprint, computed here in-process for every
value the slider took: the time from the slider first taking that value, at its latest passage
before the redraw, to the animation frame after the redraw); release → final maps painted (the
last image change of the three maps, checked equal to an in-process computation at the final
value); websocket bytes received during the drag per redraw (the payload of a redraw, with
whatever else the page received meanwhile).

Part 2, several analysts on one replica (the project only): ``--sessions`` lists how many
sessions drag at once (Bokeh websocket clients, bench/load_test.py's ``Client``, each writing
P_h values into its page's Drag model, then the release), each paced as ``--loops`` says:
``closed`` as the page does (the next value once the server answered the previous one,
``Drag.ready``, at most one every 40 ms: app/tabs/maps/live.py), ``open`` one every 40 ms whatever the
server's pace (the page's former throttle); meanwhile another session's cheap event (a refused
value: a message, no maps) is timed, and the server's RSS before the drags and after (5 s after
the last release). Redraws per second per session are the previews the server sent it; the
load average at the end of each case is printed beside it.

Part 3, ``--design`` (instead of parts 1 and 2): a station dragged on the Layout design map
(app/tabs/design/live.py) in Chromium, a closed loop as in part 1 (a mouse move every ~16 ms, station 2
circling over the map, then the release at once). Measured in the page's clock
(support/drag.py's DESIGN_INSTALL_JS): previews painted per second while dragging; input →
preview painted, p50 and p95 (each preview knows the layout it shows: the Drag's ``ready`` in
the message that brought it; the layout left the page at a known time, and the input is the
last pointer move before that, which made it); drop → exact map painted (checked equal to an
in-process computation); websocket bytes received per preview.

Targets: ≥ 10 redraws/s of all three maps (aim 20); input → preview painted p95 ≤ 200 ms;
release → exact maps painted ≤ 1.3× the minimal Panel app; ≤ 150 KB per preview; with 3
sessions dragging, ≥ 5 redraws/s each, the other session's cheap event p95 ≤ 300 ms, memory
back within 10 %.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import threading
import time
from pathlib import Path

import numpy as np

from bench.bench_browser import INIT_JS
from bench.bench_floor import served_floor, started_on
from support.drag import INSTALL_JS, MAP_TEXTS_JS, handle_track, settled
from support.page import chromium_browser
from support.server import served_app

APPS = ("project", "bokeh", "panel")
LABELS = {"project": "this project", "bokeh": "Bokeh floor (value)", "panel": "Panel, minimal (value)"}
TARGETS = dict(redraws=10.0, p95=200.0, release_ratio=1.3, payload_kb=150.0, multi_redraws=5.0,
               cheap_p95=300.0, memory=0.10)


def pct(values, q):
    return float(np.percentile(values, q)) if len(values) else float("nan")


# ----------------------------------------------------------------------------- part 1
def closed_loop_drag(page, seconds, step_s=0.016, lo=0.15, hi=0.75, last=0.62):
    """Press the handle, move it to and fro between ``lo`` and ``hi`` of the track for
    ``seconds`` (a move every ``step_s``), then to ``last`` and release at once."""
    cx, cy, left, width = handle_track(page)
    page.mouse.move(cx, cy)
    page.mouse.down()
    t_end = time.perf_counter() + seconds
    k = 0
    while time.perf_counter() < t_end:
        phase = (k * 0.011) % 2.0  # ~1.6 s one way at a move every 16 ms
        frac = lo + (hi - lo) * (phase if phase <= 1 else 2 - phase)
        page.mouse.move(left + frac * width, cy)
        time.sleep(step_s)
        k += 1
    page.mouse.move(left + last * width, cy)
    page.mouse.up()


class Fingerprints:
    """Map B's fingerprint (sum of its finite values as sent) for a slider value, in-process:
    the project's preview (uint8 levels, at the grid the page got: app/tabs/maps/live.py may coarsen it)
    or the floor's image (float32). Cached."""

    def __init__(self, name):
        self.name, self.cache = name, {}

    def __call__(self, value, count):
        key = (value, count)
        if key not in self.cache:
            if self.name == "project":
                from app.tabs.maps import data as map_data
                from app.tabs.maps.compute import Snapshot, compute
                from app.state.scenario import Scenario

                snap = Snapshot.of_values(Scenario(), {"Ph": value, "resolution": math.isqrt(count)})
                img = map_data.prepare(compute(snap), preview=True).images[1]
                self.cache[key] = float(img.sum(dtype=np.int64))
            else:
                from bench.floor import maps

                self.cache[key] = float(np.nansum(maps.compute(value)[1].astype(float)))
        return self.cache[key]


def final_expected(name, value):
    """The three final images' fingerprints at ``value`` (exact maps), in-process."""
    if name == "project":
        from app.tabs.maps import data as map_data
        from app.tabs.maps.compute import Snapshot, compute
        from app.state.scenario import Scenario

        sc = Scenario()
        sc.target.Ph = value
        images = map_data.prepare(compute(Snapshot.of(sc))).images
    else:
        from bench.floor import maps

        images = maps.compute(value)
    return [float(np.nansum(np.asarray(a, dtype=float))) for a in images]


def analyse(name, log, ws):
    """Part 1's figures from one drag's page log and websocket log."""
    down = next(t for t, kind in log["pointer"] if kind == "pointerdown")
    up = next(t for t, kind in log["pointer"] if kind == "pointerup")
    layer = "map-preview" if name == "project" else "map-image"
    seconds = (up - down) / 1e3
    during = [c for c in log["changes"] if c[2] == layer and down < c[0] <= up]
    per_map = [sum(1 for c in during if c[3] == i) / seconds for i in range(3)]
    # input -> painted, for each redraw of map B during the drag
    values = log["values"]  # [t, value] as the slider took them
    fp, candidates = Fingerprints(name), sorted({v for _, v in values})
    lat, unmatched = [], 0
    for c in (c for c in during if c[3] == 1):
        t_change, t_paint, s = c[0], c[1], c[4]
        match = {v for v in candidates if abs(fp(v, c[5]) - s) <= 1e-9 * max(1.0, abs(s))}
        times = [t for t, v in values if v in match and t <= t_change]
        if not times or t_paint is None:
            unmatched += 1
            continue
        # the slider's latest passage through the value: from the first of its run there
        t_in = max(times)
        for t, v in reversed([x for x in values if x[0] <= t_in]):
            if v not in match:
                break
            t_in = t
        lat.append(t_paint - t_in)
    # release -> the final maps painted
    final = log["value"]
    want = final_expected(name, final)
    last = {}
    for c in log["changes"]:
        if c[2] == "map-image":
            last[c[3]] = c
    exact = all(abs(last[i][4] - want[i]) <= 1e-9 * max(1.0, abs(want[i])) for i in range(3))
    release = max(last[i][1] for i in range(3)) - up
    ws_in = [m for m in ws if m[1] == "in" and down < m[0] <= up]
    redraws_b = sum(1 for c in during if c[3] == 1)
    payload = sum(m[2] for m in ws_in) / max(redraws_b, 1)
    return {"seconds": seconds, "redraws_per_s": per_map, "latency_ms": lat, "unmatched": unmatched,
            "release_ms": release, "final_exact": exact, "final_value": final,
            "payload_bytes": payload, "redraws": redraws_b, "values_sent": len(values)}


def measure_page(name, url, browser, args, screenshot=None):
    page = browser.new_page(viewport={"width": 1600, "height": 1000})
    errors = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.add_init_script(INIT_JS)
    page.goto(url)
    page.wait_for_selector(".w-Ph .noUi-handle", timeout=120_000)
    time.sleep(2.0)
    page.evaluate(INSTALL_JS, "w-Ph")
    results = []
    for k in range(args.drags):
        page.evaluate("() => { window.__drag.changes.length = 0; window.__drag.pointer.length = 0;"
                      " window.__drag.values.length = 0; window.__ws.length = 0; }")
        closed_loop_drag(page, args.seconds, last=0.62 - 0.05 * k)
        check = None
        if name == "project":
            check = lambda lg: not any(t[2] for t in page.evaluate(MAP_TEXTS_JS))  # noqa: E731
        log = settled(page, quiet_ms=1000.0, check=check)
        ws = page.evaluate("() => window.__ws.map(m => [m[0], m[1], m[2]])")
        r = analyse(name, log, ws)
        results.append(r)
        print(f"  {name:8} drag {k + 1}: {r['redraws_per_s'][0]:.1f}/{r['redraws_per_s'][1]:.1f}/"
              f"{r['redraws_per_s'][2]:.1f} redraws/s, input→painted p50 {pct(r['latency_ms'], 50):.0f} "
              f"p95 {pct(r['latency_ms'], 95):.0f} ms ({len(r['latency_ms'])} matched, {r['unmatched']} not), "
              f"release→painted {r['release_ms']:.0f} ms, final exact {r['final_exact']}, "
              f"{r['payload_bytes'] / 1e3:.0f} KB/redraw", flush=True)
    if screenshot:
        mid_drag_screenshot(page, screenshot)
    page.close()
    return {"drags": results, "errors": errors}


def mid_drag_screenshot(page, path):
    """Halfway through a slow drag, a screenshot of the page (docs/)."""
    cx, cy, left, width = handle_track(page)
    page.mouse.move(cx, cy)
    page.mouse.down()
    for k in range(30):
        page.mouse.move(left + (0.62 - 0.3 * k / 30) * width, cy)
        time.sleep(0.04)
    time.sleep(0.4)
    page.screenshot(path=str(path))
    page.mouse.up()
    time.sleep(1.0)


# ----------------------------------------------------------------------------- part 2
def multi(url, proc, sessions, seconds, loop="closed"):
    """``sessions`` sessions dragging at once (part 2): their previews per second, another
    session's cheap event, the server's RSS before and after. ``loop``: "closed", each sends
    its next value once the previous one is answered (``Drag.ready``), as the page does
    (app/tabs/maps/live.py); "open", one every THROTTLE_MS whatever the server's pace."""
    import psutil

    from bench.load_test import Client
    from support.server import close_client, on_thread

    class Dragger(Client):
        def __init__(self, url):
            import app.kit.drag  # noqa: F401  (the Drag model's class, to read the page's document)

            super().__init__(url)
            models = list(self.doc.models)
            # a page opens on the Maps tab (the Layout design tab's drag model is made on its visit)
            self.drag = next(m for m in models if type(m).__name__ == "Drag")

        def drag_for(self, index, seconds, out):
            from bokeh.document.events import ModelChangedEvent

            from app.kit.drag import PATIENCE_MS, THROTTLE_MS

            start = len(self.events)
            t0 = time.perf_counter()
            seq, k = self.drag.ready, 0
            while time.perf_counter() - t0 < seconds:
                phase = (k * 0.02 + index * 0.37) % 2.0
                v = round(60.0 + 800.0 * (phase if phase <= 1 else 2 - phase) + index / 100, 2)
                seq += 1
                sent = time.perf_counter()
                self._send(ModelChangedEvent(self.doc, self.drag, "state", ["Ph", v, seq, False]))
                if loop == "closed":  # as the page: the next value once this one is answered
                    self._pump(lambda: self.drag.ready >= seq, PATIENCE_MS / 1e3)
                rest = THROTTLE_MS / 1e3 - (time.perf_counter() - sent)
                if rest > 0:
                    self._pump(lambda: False, rest)
                k += 1
            dt = time.perf_counter() - t0
            # the preview layers are made on a page's first preview (app/tabs/maps/figures.add_previews):
            # their sources are read after the drag (the first preview, in the new layers, is not
            # a data change: one fewer per map on a page's first drag)
            previews = {m.id for m in self.doc.models if getattr(m, "name", None) == "map-preview"}
            got = [mid for attr, mid, _ in self.events[start:] if attr == "data" and mid in previews]
            final = round(500.0 + index * 3.3 + time.time() % 1, 2)
            n0 = len(self.events)
            t1 = time.perf_counter()
            self._send(ModelChangedEvent(self.doc, self.drag, "state", ["Ph", final, seq + 1, True]))
            ok = self._pump(lambda: self.maps_done(self.events[n0:]), 60)
            out[index] = {"previews_per_s": len(got) / 3 / dt, "values_sent": k,
                          "release_s": time.perf_counter() - t1 if ok else None}

    rss = lambda: psutil.Process(proc.pid).memory_info().rss  # noqa: E731
    draggers = [on_thread(Dragger, url) for _ in range(sessions)]
    prober = on_thread(Client, url)
    time.sleep(3.0)
    before = rss()
    cheap, stop = [], threading.Event()

    def probe():
        n = 0
        while not stop.is_set():
            n += 1
            dt = prober.refuse(-(n + 0.5))
            cheap.append(dt if dt is not None else float("inf"))
            time.sleep(0.2)

    out = {}
    threads = [threading.Thread(target=d.drag_for, args=(i, seconds, out)) for i, d in enumerate(draggers)]
    pt = threading.Thread(target=probe)
    pt.start()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    if not threads:  # no drags: the cheap event on the otherwise idle server, as long
        time.sleep(seconds)
    stop.set()
    pt.join()
    time.sleep(5.0)
    after = rss()
    for c in [*draggers, prober]:
        on_thread(close_client, c)
    return {"sessions": sessions, "loop": loop, "seconds": seconds, "load": os.getloadavg()[0],
            "per_session": [out[i] for i in range(sessions)],
            "cheap_ms": [1e3 * x for x in cheap], "rss_before": before, "rss_after": after}


# ----------------------------------------------------------------------------- part 3
def design_drag(browser, url, seconds, drags, screenshot=None):
    """Part 3: a station dragged on the Layout design map (module docstring)."""
    from support.drag import (DESIGN_COLLECT_JS, DESIGN_INSTALL_JS, DESIGN_XY_JS, design_settled,
                              station_path)

    page = browser.new_page(viewport={"width": 1600, "height": 1000})
    errors = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.add_init_script(INIT_JS)
    page.goto(url + "?tab=Layout+design")
    page.wait_for_function("""() => window.Bokeh && Bokeh.documents.length > 0 &&
        Array.from(Bokeh.documents[0].all_models).some(m => m.title && m.title.text
        && m.title.text.startsWith('Custom layout'))""", timeout=120_000)
    time.sleep(3.0)
    assert page.evaluate(DESIGN_INSTALL_JS) == 2, "the design map has no preview layer"
    results = []
    start = (15.0, 0.0)
    for k in range(drags):
        page.evaluate("() => { const l = window.__design; for (const a of [l.exact, l.previews, l.sends,"
                      " l.pointer]) a.length = 0; window.__ws.length = 0; }")
        # pressed 4 m right of the station (on its marker, off station 1 at (0, 0)), then
        # circles of 70 m about (110, 90) m, ~2 s a turn
        (sx, sy), _ = station_path(page, (start[0] + 4.0, start[1]), (110.0, 90.0), 1)
        page.mouse.move(sx, sy)
        page.mouse.down()
        ox, oy = page.evaluate(DESIGN_XY_JS, [110.0, 90.0])
        ex, _ = page.evaluate(DESIGN_XY_JS, [180.0, 90.0])
        r = ex - ox
        page.mouse.move(sx + 8, sy - 8)  # past the 5 px pan threshold at once
        t0, i = time.perf_counter(), 0
        while time.perf_counter() - t0 < seconds:
            a = 2 * math.pi * i * 0.016 / 2.0 + 0.37 * k
            page.mouse.move(ox + r * math.cos(a), oy - r * math.sin(a))
            time.sleep(0.016)
            i += 1
        page.mouse.up()
        log = design_settled(page, timeout=120.0)
        ws = page.evaluate("() => window.__ws.map(m => [m[0], m[1], m[2]])")
        results.append(design_analyse(log, ws))
        start = (log["x"][1], log["y"][1])
        r_ = results[-1]
        print(f"  design drag {k + 1}: {r_['redraws_per_s']:.1f} previews/s, input→painted p50 "
              f"{pct(r_['latency_ms'], 50):.0f} p95 {pct(r_['latency_ms'], 95):.0f} ms "
              f"({len(r_['latency_ms'])} matched, {r_['unmatched']} not), grid {r_['grid']}, "
              f"drop→exact painted {r_['drop_ms']:.0f} ms, exact {r_['final_exact']}, "
              f"{r_['payload_bytes'] / 1e3:.0f} KB/preview", flush=True)
    if screenshot:
        (sx, sy), moves = station_path(page, (start[0] + 4.0, start[1]), (60.0, -80.0), 30)
        page.mouse.move(sx, sy)
        page.mouse.down()
        for x, y in moves:
            page.mouse.move(x, y)
            time.sleep(0.04)
        time.sleep(0.6)
        page.screenshot(path=str(screenshot))
        page.mouse.up()
        time.sleep(1.0)
    page.close()
    return {"drags": results, "errors": errors}


def design_analyse(log, ws):
    """Part 3's figures from one station drag's page log and websocket log."""
    from app.kit import views
    from app.state.scenario import Scenario
    from app.tabs.design.compute import ERROR_MAP_READS, design
    from app.tabs.maps.compute import Snapshot

    down = next(t for t, kind in log["pointer"] if kind == "pointerdown")
    up = next(t for t, kind in log["pointer"] if kind == "pointerup")
    seconds = (up - down) / 1e3
    during = [c for c in log["previews"] if down < c[0] <= up and c[1] is not None]
    sent = {seq: t for t, seq in log["sends"]}
    moves = [t for t, kind in log["pointer"] if kind == "pointermove"]
    lat, unmatched = [], 0
    for c in during:
        t_send = sent.get(c[5])
        before = [t for t in moves if t_send is not None and t <= t_send]
        if not before:
            unmatched += 1
            continue
        lat.append(c[1] - before[-1])
    sc = Scenario()
    sc.stations.stations = [[0.0, 0.0, sc.stations.h], [log["x"][1], log["y"][1], sc.stations.h]]
    values = views._errors(design(Snapshot.of(sc, ERROR_MAP_READS)), sc.design.error_quantity)
    finite = values[np.isfinite(values)]
    final = log["exact"][-1] if log["exact"] else None
    exact = (final is not None and final[0] > up and final[3] == finite.size
             and abs(final[2] - float(finite.sum())) <= 1e-9 * abs(float(finite.sum())))
    ws_in = [m for m in ws if m[1] == "in" and down < m[0] <= up]
    return {"seconds": seconds, "redraws_per_s": len(during) / seconds, "latency_ms": lat,
            "unmatched": unmatched, "drop_ms": (final[1] - up) if final else float("nan"),
            "final_exact": exact, "payload_bytes": sum(m[2] for m in ws_in) / max(len(during), 1),
            "grid": sorted({math.isqrt(c[4]) for c in during}), "previews": len(during),
            "sends": len([s for s in log["sends"] if down < s[0] <= up])}


def design_table(res):
    drags = res["drags"]
    lat = [x for d in drags for x in d["latency_ms"]]
    rows = [("previews painted per second while dragging (median of drags)",
             f"{statistics.median(d['redraws_per_s'] for d in drags):.1f}"),
            ("input → preview painted p50 / p95 (ms)", f"{pct(lat, 50):.0f} / {pct(lat, 95):.0f} ({len(lat)} previews)"),
            ("preview grid", ", ".join(sorted({f'{g} × {g}' for d in drags for g in d['grid']}))),
            ("drop → exact map painted, median (ms)", f"{statistics.median(d['drop_ms'] for d in drags):.0f}"),
            ("exact map equals the in-process computation", "yes" if all(d["final_exact"] for d in drags) else "NO"),
            ("websocket bytes received per preview (KB)",
             f"{statistics.median(d['payload_bytes'] for d in drags) / 1e3:.0f}")]
    return "\n".join(["| station drag, Layout design map | |", "|---|---|"] + [f"| {a} | {b} |" for a, b in rows])


# ----------------------------------------------------------------------------- report
def summarise(raw):
    out = {}
    for name, runs in raw.items():
        drags = [d for r in runs for d in r["drags"]]
        lat = [x for d in drags for x in d["latency_ms"]]
        out[name] = {
            "redraws_per_s": [statistics.median(d["redraws_per_s"][i] for d in drags) for i in range(3)],
            "latency_p50_ms": pct(lat, 50), "latency_p95_ms": pct(lat, 95),
            "matched": len(lat), "unmatched": sum(d["unmatched"] for d in drags),
            "release_ms": statistics.median(d["release_ms"] for d in drags),
            "final_exact": all(d["final_exact"] for d in drags),
            "payload_kb": statistics.median(d["payload_bytes"] for d in drags) / 1e3,
            "errors": [e for r in runs for e in r["errors"]],
        }
    if "panel" in out:
        for v in out.values():
            v["release_ratio"] = v["release_ms"] / out["panel"]["release_ms"]
    return out


def table(s):
    apps = list(s)
    rows = [("redraws per second while dragging, maps A / B / B vs A",
             lambda v: " / ".join(f"{x:.1f}" for x in v["redraws_per_s"]), f"≥ {TARGETS['redraws']:g} (aim 20)"),
            ("input → painted p50 (ms)", lambda v: f"{v['latency_p50_ms']:.0f}", ""),
            ("input → painted p95 (ms)", lambda v: f"{v['latency_p95_ms']:.0f}", f"≤ {TARGETS['p95']:g}"),
            ("release → final maps painted, median (ms)",
             lambda v: f"{v['release_ms']:.0f}" + (f" ({v['release_ratio']:.2f}×)" if "release_ratio" in v else ""),
             f"≤ {TARGETS['release_ratio']}× Panel"),
            ("final maps equal the in-process computation", lambda v: "yes" if v["final_exact"] else "NO", ""),
            ("websocket bytes in per redraw (KB)", lambda v: f"{v['payload_kb']:.0f}", f"≤ {TARGETS['payload_kb']:g}")]
    lines = ["| | " + " | ".join(LABELS[a] for a in apps) + " | target |", "|---" * (len(apps) + 2) + "|"]
    for label, fmt, target in rows:
        lines.append(f"| {label} | " + " | ".join(fmt(s[a]) for a in apps) + f" | {target} |")
    return "\n".join(lines)


def multi_table(results):
    lines = ["| sessions dragging | loop | previews/s per session (min … max) | values sent/s per session | "
             "release → exact maps (s, max) | another session's cheap event p50 / p95 (ms) | "
             "RSS before → after drags (MB) | load average |",
             "|---|---|---|---|---|---|---|---|"]
    for r in results:
        per = [p["previews_per_s"] for p in r["per_session"]] or [float("nan")]
        rel = [p["release_s"] for p in r["per_session"]] or [float("nan")]
        rel_max = "unanswered" if any(x is None for x in rel) else f"{max(rel):.2f}"
        sent = [p["values_sent"] / r["seconds"] for p in r["per_session"]] or [float("nan")]
        lines.append(f"| {r['sessions']} | {r['loop']} | {min(per):.1f} … {max(per):.1f} | "
                     f"{statistics.median(sent):.1f} | {rel_max} | "
                     f"{pct(r['cheap_ms'], 50):.0f} / {pct(r['cheap_ms'], 95):.0f} | "
                     f"{r['rss_before'] / 2**20:.0f} → {r['rss_after'] / 2**20:.0f} "
                     f"({(r['rss_after'] / r['rss_before'] - 1) * 100:+.1f} %) | {r['load']:.1f} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=4.0, help="length of each drag (s)")
    ap.add_argument("--drags", type=int, default=2, help="drags per app and run")
    ap.add_argument("--runs", type=int, default=1, help="runs (each serves the three apps in turn)")
    ap.add_argument("--apps", default=",".join(APPS))
    ap.add_argument("--sessions", default="0,1,2,3,4",
                    help="part 2: numbers of sessions dragging at once ('' to skip; 0: the cheap "
                         "event with no drag)")
    ap.add_argument("--multi-seconds", type=float, default=8.0)
    ap.add_argument("--loops", default="closed,open",
                    help="part 2: how the dragging clients pace their values (closed: as the page, "
                         "after each answer; open: every THROTTLE_MS)")
    ap.add_argument("--screenshot", default=None, help="a PNG of the page taken mid-drag (project)")
    ap.add_argument("--out", default=None, help="raw values and summary as JSON")
    ap.add_argument("--design", action="store_true",
                    help="part 3 only: a station dragged on the Layout design map")
    args = ap.parse_args(argv)
    if args.design:
        load = [os.getloadavg()]
        with chromium_browser() as browser, served_app() as (url, _):
            res = design_drag(browser, url + "/app", args.seconds, args.drags, args.screenshot)
        load.append(os.getloadavg())
        print()
        print(design_table(res))
        if res["errors"]:
            print(f"page errors: {res['errors']}")
        print("load average (1, 5, 15 min) at start and end: " + "; ".join(
            " ".join(f"{x:.2f}" for x in avg) for avg in load))
        if args.out:
            Path(args.out).write_text(json.dumps({"args": vars(args), "load": load, "design": res}, indent=1))
        return 0
    load, apps, raw = started_on(APPS, args.apps)
    multi_results = []
    with chromium_browser() as browser:
        for run in range(args.runs):
            for name in apps:
                serve = served_app() if name == "project" else served_floor(name, stem=f"drag_{name}")
                with serve as (url, proc):
                    if name == "project":
                        url += "/app"
                    print(f"run {run + 1}/{args.runs}: {LABELS[name]} (load {os.getloadavg()[0]:.2f})",
                          flush=True)
                    shot = args.screenshot if (name == "project" and run == 0) else None
                    raw[name].append(measure_page(name, url, browser, args, screenshot=shot))
                    if name == "project" and run == 0 and args.sessions:
                        base = url.rsplit("/app", 1)[0]
                        for n in (int(x) for x in args.sessions.split(",")):
                            for loop in (args.loops.split(",") if n else ["closed"]):
                                r = multi(base, proc, n, args.multi_seconds, loop)
                                multi_results.append(r)
                                print(multi_table([r]).splitlines()[-1], flush=True)
            load.append(os.getloadavg())
    summary = summarise(raw)
    print()
    print(table(summary))
    if multi_results:
        print()
        print(multi_table(multi_results))
    for a in summary:
        if summary[a]["errors"]:
            print(f"{LABELS[a]}: page errors: {summary[a]['errors']}")
    print("load average (1, 5, 15 min) at start and after each run: " + "; ".join(
        " ".join(f"{x:.2f}" for x in avg) for avg in load))
    if args.out:
        Path(args.out).write_text(json.dumps({"args": vars(args), "load": load, "summary": summary,
                                              "raw": raw, "multi": multi_results}, indent=1))
        print(f"written {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
