"""Maps that follow the hand (issue 38), in headless Chromium: previews while a slider is dragged
(electric and magnetic maps), the exact maps of the final value on release (app/tabs/maps/live.py); the
Layout design map while a station is dragged, its exact map on the drop (app/tabs/design/live.py)."""

import math
import re
import time

import numpy as np
import pytest

from support.drag import (COLLECT_JS, DESIGN_COLLECT_JS, DESIGN_INSTALL_JS, DESIGN_XY_JS, INSTALL_JS,
                          MAP_TEXTS_JS, design_settled, drag, handle_track, settled, station_path, sweep)
from support.page import chromium_missing, open_page
from support.server import served_app

#: Runs alone, after the rest (``pytest -m serial``; tests/conftest.py):
SERIAL = "it counts the previews drawn per second of a drag"

playwright = pytest.importorskip("playwright.sync_api")

pytestmark = pytest.mark.skipif(
    chromium_missing(), reason="Debian's chromium is not installed (CI installs it; there this test must run)")


def open_at_maps(chromium, server, errors):
    pg = open_page(chromium, server + "/app", errors)
    pg.wait_for_selector(".w-Ph .noUi-handle", timeout=60_000)
    time.sleep(1.0)  # the page's first paints and deferred updates
    return pg


def open_maps(chromium, server, errors):
    pg = open_at_maps(chromium, server, errors)
    # the map and veil layers of three maps (their preview layers come with the first preview)
    assert pg.evaluate(INSTALL_JS, "w-Ph") == 6
    return pg


def expected(value, name="Ph", sensor=None):
    """The maps' images and texts as the server sends them for input ``name`` = ``value`` (with
    the sidebar's ``sensor``, if given), computed here."""
    from app.state.scenario import Scenario
    from app.tabs.maps import data as map_data
    from app.tabs.maps.compute import Snapshot, compute

    sc = Scenario()
    if sensor is not None:
        sc.update(sensor=sensor)
    setattr(sc.target, name, value)
    return map_data.prepare(compute(Snapshot.of(sc)))


def exact_map(log, want, which):
    """The last image change of map ``which`` in the page's ``log`` (support.drag), asserted to
    be ``want``'s (:func:`expected`): its finite values' count, and their sum. The page sums
    the same float32 numbers in float64: equal but for the summation's round-off (~1e-16 per
    term), and for the kernels compiled here against those in the server's cache (~1e-12
    relative across processes: docs/guide), both far below 1e-9."""
    last = [c for c in log["changes"] if c[2] == "map-image" and c[3] == which][-1]
    img = want.images[which].astype(float)
    assert last[5] == int(np.isfinite(img).sum())
    assert last[4] == pytest.approx(float(np.nansum(img)), rel=1e-9, abs=1e-9)
    return last


def test_the_maps_follow_a_dragged_slider_and_end_exact(chromium, server, tmp_path):
    errors = []
    page = open_maps(chromium, server, errors)
    start = page.evaluate(COLLECT_JS)["value"]
    mid = {}

    def middle(pg):  # what the maps say halfway through the drag, and how they look
        time.sleep(0.3)  # a preview of the hand's place arrives meanwhile
        mid["texts"] = pg.evaluate(MAP_TEXTS_JS)
        pg.screenshot(path=str(tmp_path / "mid-drag.png"))

    # ~2.5 s of a hand going right and back, a move every 40 ms
    drag(page, sweep(0.2, 0.55, 60), step_s=0.04, mid=middle)
    log = settled(page, check=lambda lg: not any(t[2] for t in page.evaluate(MAP_TEXTS_JS)))
    value = log["value"]
    assert value != start
    down = next(t for t, kind in log["pointer"] if kind == "pointerdown")
    up = next(t for t, kind in log["pointer"] if kind == "pointerup")

    # during the drag, every map's preview layer was redrawn, with different values, and shown
    for which in range(3):
        during = [c for c in log["changes"] if c[2] == "map-preview" and c[3] == which and down < c[0] <= up]
        assert len({c[4] for c in during}) >= 3, f"map {which}: {len(during)} previews while dragging"
        # n² levels of one byte each (uint8), n ≤ 100 (fewer only if a preview took > 60 ms)
        assert all(c[5] == c[7] and math.isqrt(c[5]) ** 2 == c[5] and c[5] <= 100 * 100 for c in during)
    for title, caption, shown, *_ in mid["texts"]:
        grid = re.search(r"grid (\d+) × (\d+)", caption.replace("\n", " "))
        assert shown and title.endswith("— preview") and grid and int(grid[1]) <= 100, mid["texts"]
    assert (tmp_path / "mid-drag.png").stat().st_size > 10_000

    # after the release: the exact maps of the final value, every one redrawn after the release
    want = expected(value)
    texts = page.evaluate(MAP_TEXTS_JS)
    for which in range(3):
        assert exact_map(log, want, which)[0] > up, f"map {which} was not redrawn after the release"
        title, caption, shown, low, high = texts[which]
        assert shown is False and "preview" not in title
        assert caption.replace(",\n", ", ") == want.panels.captions[which]
        assert f"P = ({value:g}, " in want.panels.captions[which]
        # the colour bars (A and B share one) span the final maps' colour ranges
        assert (low, high) == pytest.approx(want.ranges[which][:2], rel=1e-12)
    page.close()
    assert errors == [], f"browser console errors: {errors}"


def test_a_click_on_the_track_draws_the_exact_maps_and_no_preview(chromium, server):
    # A click is released at once. The page offered its value as a drag's too: a 100² preview
    # was computed beside the exact maps (the server's CPU, shared by every session) and drawn
    # over them until they came. The first click's release also passed before the page's hook
    # for releases was there (BokehJS runs a CustomJS after the change that called it).
    errors = []
    page = open_maps(chromium, server, errors)
    _, cy, left, width = handle_track(page)
    values = []
    for frac in (0.3, 0.7):  # the first click, then one with the hook in place
        before = page.evaluate(COLLECT_JS)["value"]
        page.mouse.click(left + frac * width, cy)
        log = settled(page, check=lambda lg, b=before: lg["value"] != b and any(
            c[2] == "map-image" and c[3] == 0 and c[0] > lg["pointer"][-1][0] for c in lg["changes"]))
        values.append(log["value"])
        exact_map(log, expected(log["value"]), 0)
    previews = [c for c in log["changes"] if c[2] == "map-preview"]
    assert previews == [], f"{len(previews)} preview layers drawn for two clicks at P_h = {values}"
    page.close()
    assert errors == [], f"browser console errors: {errors}"


#: Counts what the page sends to the session's Drag model (app.live): ``window.__sends``.
SENDS_JS = """() => { window.__sends = [];
  for (const m of Bokeh.documents[0].all_models)
    if (m.properties && m.properties.ready && m.properties.state)
      m.connect(m.properties.state.change, () => window.__sends.push(m.state.slice())); }"""


def test_a_typed_value_and_a_preset_compute_the_exact_maps_and_no_preview(chromium, server):
    # issue 46 item 3: a value that is final already (typed, a preset) moved the handle from the
    # server, and the page offered it as a drag's: a message and a check per value, or a preview
    errors = []
    page = open_maps(chromium, server, errors)
    page.evaluate(SENDS_JS)
    box = page.locator(".w-Ph input").first
    box.fill("150")
    box.press("Enter")
    log = settled(page, check=lambda lg: lg["value"] == 150 and any(c[2] == "map-image" for c in lg["changes"]))
    exact_map(log, expected(150.0), 0)
    page.get_by_role("button", name="Fig. 2").click()
    settled(page, check=lambda lg: lg["value"] == 100 and sum(c[2] == "map-image" for c in lg["changes"]) >= 6)
    time.sleep(1.0)  # a send would follow the handle's move within THROTTLE_MS
    log = page.evaluate(COLLECT_JS)
    assert [c for c in log["changes"] if c[2] == "map-preview"] == []
    assert page.evaluate("() => window.__sends") == [], "the page offered a final value as a drag's"
    page.close()
    assert errors == [], f"browser console errors: {errors}"


def test_with_previews_off_a_drag_draws_only_the_exact_maps_of_the_release(chromium, monkeypatch):
    # APP_PREVIEWS=off (app/tabs/maps/live.py): a replica for many analysts on few cores spares the CPU
    monkeypatch.setenv("APP_PREVIEWS", "off")
    with served_app() as (url, _):
        errors = []
        page = open_maps(chromium, url, errors)
        drag(page, sweep(0.2, 0.55, 30), step_s=0.04)  # ~1.2 s: the drag test's maps follow this
        log = settled(page)
        assert [c for c in log["changes"] if c[2] == "map-preview"] == []
        want = expected(log["value"])
        for which in range(3):
            exact_map(log, want, which)
        page.close()
        assert errors == [], f"browser console errors: {errors}"


MAGNETIC = "magnetometer + gradiometer (BG)"


def test_magnetic_maps_follow_a_dragged_slider_and_end_exact(chromium, server):
    errors = []
    page = open_at_maps(chromium, server, errors)
    page.locator(".w-sensor select").first.select_option(MAGNETIC)
    deadline = time.time() + 120  # the magnetic kernels may compile on first use
    while not all("magnetometer + gradiometer" in t[0] for t in page.evaluate(MAP_TEXTS_JS)[:2]):
        assert time.time() < deadline, page.evaluate(MAP_TEXTS_JS)
        time.sleep(0.3)
    page.wait_for_selector(".w-mx .noUi-handle", timeout=30_000)
    time.sleep(1.0)
    assert page.evaluate(INSTALL_JS, "w-mx") == 6
    start = page.evaluate(COLLECT_JS)["value"]
    drag(page, sweep(0.45, 0.75, 60), css="w-mx", step_s=0.05)  # ~3 s of a hand to and fro
    log = settled(page, quiet_ms=1500.0, timeout=120.0,
                  check=lambda lg: not any(t[2] for t in page.evaluate(MAP_TEXTS_JS)))
    value = log["value"]
    assert value != start
    down = next(t for t, kind in log["pointer"] if kind == "pointerdown")
    up = next(t for t, kind in log["pointer"] if kind == "pointerup")
    for which in range(3):  # each map followed the hand: previews of different values
        during = [c for c in log["changes"] if c[2] == "map-preview" and c[3] == which and down < c[0] <= up]
        assert len({c[4] for c in during}) >= 2, f"map {which}: {len(during)} previews while dragging"
    want = expected(value, "mx", MAGNETIC)
    texts = page.evaluate(MAP_TEXTS_JS)
    for which in range(3):
        assert exact_map(log, want, which)[0] > up, f"map {which} was not redrawn after the release"
        assert texts[which][2] is False and "preview" not in texts[which][0]
    page.close()
    assert errors == [], f"browser console errors: {errors}"


def test_a_release_after_a_whole_number_leaves_handle_box_and_maps_at_the_released_value(chromium, server):
    # A link's ?Ph=150 (or a drag released on 151) arrives as a JSON integer. The next release
    # of a value with decimals was rounded by the server (263.2 -> 263) and then set again,
    # unrounded, by Panel's own release: the maps and the box ended at 263.2 and the handle at
    # 263 (bench/bench_browser.py's "drawn map A is not P_h = 263: a stale image?")
    errors = []
    page = open_page(chromium, server + "/app?Ph=150", errors)
    page.wait_for_selector(".w-Ph .noUi-handle", timeout=60_000)
    time.sleep(1.0)
    assert page.evaluate(INSTALL_JS, "w-Ph") == 6
    assert page.evaluate(COLLECT_JS)["value"] == 150
    released = None
    for frac in (0.263, 0.337, 0.412, 0.488):  # a release with decimals (step 0.1: ~9 in 10)
        drag(page, [frac - 0.05, frac], step_s=0.05)
        time.sleep(0.2)
        released = page.evaluate("() => window.__drag.slider.value_throttled")
        if released != round(released):
            break
    assert released != round(released), f"no release with decimals ({released})"
    log = settled(page, check=lambda lg: not any(t[2] for t in page.evaluate(MAP_TEXTS_JS)))
    assert log["value"] == released  # the handle stays where it was released
    assert page.locator(".w-Ph input").first.input_value() == f"{released:g}"
    want = expected(released)
    texts = page.evaluate(MAP_TEXTS_JS)
    for which in range(3):
        exact_map(log, want, which)
        assert texts[which][1].replace(",\n", ", ") == want.panels.captions[which]
        assert texts[which][2] is False
    assert f"P = ({released:g}, 20)" in want.panels.captions[0]
    page.close()
    assert errors == [], f"browser console errors: {errors}"


def test_the_design_map_follows_a_dragged_station_and_ends_exact(chromium, server, tmp_path):
    from app.kit import views
    from app.state.scenario import Scenario
    from app.tabs.design.compute import ERROR_MAP_READS, design
    from app.tabs.maps.compute import Snapshot

    errors = []
    page = open_page(chromium, server + "/app?tab=Layout+design", errors)
    page.wait_for_function("""() => Array.from(Bokeh.documents[0].all_models).some(m => m.title
        && m.title.text && m.title.text.startsWith('Custom layout'))""", timeout=120_000)
    rows = page.locator(".w-station-table .tabulator-row")
    rows.first.wait_for(timeout=60_000)
    time.sleep(1.5)  # the first paint, the ranges fitted
    assert page.evaluate(DESIGN_INSTALL_JS) == 2  # the paper's pair: (0, 0) and (15, 0) at h
    at = None
    for _ in range(50):  # the frame laid out: the same place twice
        now = page.evaluate(DESIGN_XY_JS, [19.0, 0.0])
        if now == at:
            break
        at = now
        time.sleep(0.3)
    # pressed 4 m right of station 2 (15, 0): on its 14 px marker, off station 1's at (0, 0)
    (sx, sy), moves = station_path(page, (19.0, 0.0), (124.0, 90.0), 60)
    page.mouse.move(sx, sy)
    page.mouse.down()
    mid = None
    for k, (x, y) in enumerate(moves):  # ~3 s: station 2 from (15, 0) to about (120, 90) m
        page.mouse.move(x, y)
        if k == len(moves) // 2:
            time.sleep(0.5)  # the hand holds still: a preview of this place arrives meanwhile
            mid = page.evaluate(DESIGN_COLLECT_JS)
            page.screenshot(path=str(tmp_path / "design-mid-drag.png"))
        time.sleep(0.05)
    page.mouse.up()
    log = design_settled(page)
    down = next(t for t, kind in log["pointer"] if kind == "pointerdown")
    up = next(t for t, kind in log["pointer"] if kind == "pointerup")

    # (a) while dragging: previews of different layouts, on a grid of at most 100², shown, and
    # said to be previews; the dragged station stayed under the hand; the exact map untouched
    during = [c for c in log["previews"] if down < c[0] <= up]
    assert len({c[2] for c in during}) >= 3, f"{len(during)} previews while dragging"
    assert all(c[4] <= 100 * 100 for c in during)
    assert mid["preview_shown"] and mid["label"][0] and "Preview while dragging (grid" in mid["label"][1], mid
    assert mid["x"][0] == 0.0 and 15.0 < mid["x"][1] < 120.0, (mid["x"], mid["y"])
    assert not [c for c in log["exact"] if down < c[0] <= up]
    assert (tmp_path / "design-mid-drag.png").stat().st_size > 10_000

    # (b) the drop: the exact map of the dropped layout, redrawn after the release, the colour
    # bar its range, the title and the table its layout
    x, y = log["x"], log["y"]
    assert len(x) == 2 and (x[0], y[0]) == (0.0, 0.0)
    assert abs(x[1] - 120.0) < 5 and abs(y[1] - 90.0) < 5  # where the hand let go (a few px)
    final = log["exact"][-1]
    assert final[0] > up
    sc = Scenario()
    sc.stations.stations = [[0.0, 0.0, sc.stations.h], [x[1], y[1], sc.stations.h]]
    d = design(Snapshot.of(sc, ERROR_MAP_READS))
    values = views._errors(d, sc.design.error_quantity)
    finite = values[np.isfinite(values)]
    assert (final[3], final[4]) == (finite.size, values.size)
    # float64 sums, here pairwise and in the page in order: round-off ~1e-13 relative; the
    # kernels compiled here and loaded from the server's cache differ by up to ~1e-12 (guide)
    assert final[2] == pytest.approx(float(finite.sum()), rel=1e-9)
    assert (log["low"], log["high"]) == pytest.approx(views.error_clim(d, sc.design.error_quantity), rel=1e-9)
    assert log["title"] == "Custom layout: Cramér–Rao error" and not log["label"][0]
    cells = lambda field: [rows.nth(i).locator(f'.tabulator-cell[tabulator-field="{field}"]').inner_text().strip()
                           for i in range(rows.count())]  # noqa: E731
    deadline = time.time() + 15
    while cells("x (m)") != ["0.0", f"{x[1]:.1f}"] or cells("y (m)") != ["0.0", f"{y[1]:.1f}"]:
        assert time.time() < deadline, (cells("x (m)"), cells("y (m)"), x, y)
        time.sleep(0.2)
    assert cells("z (m)") == ["100.0", "100.0"]
    page.close()
    # (c)
    assert errors == [], f"browser console errors: {errors}"
