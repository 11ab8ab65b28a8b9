"""Issue 40 in headless Chromium: the Track and Layout design tabs as a new analyst meets them —
typed values, refusals said at once, a track that is computed or says why, plans drawn to scale,
the station depth h on every station, the design map filling its row."""

from __future__ import annotations

import time

import pytest

from support.page import (SMALL_VIEWPORT, VIEWPORT, chromium_missing, type_value,
                          value_of, wait_count, wait_plots)

pytest.importorskip("playwright.sync_api")
pytestmark = pytest.mark.skipif(chromium_missing(), reason="Debian's chromium is not installed")

#: Per plot whose title starts with the argument: [inner width, inner height (px, Bokeh's
#: read-only Plot.inner_width/inner_height), x span, y span (m)].
SCALE_JS = """(title) => {
  for (const m of Bokeh.documents[0].all_models)
    if (m.inner_width !== undefined && m.title && m.title.text && m.title.text.startsWith(title)
        && m.x_range && m.y_range)
      return [m.inner_width, m.inner_height, m.x_range.end - m.x_range.start,
              m.y_range.end - m.y_range.start];
  return null;
}"""

#: The text of the Bokeh model carrying CSS class ``css`` ('' if none).
TEXT_JS = """(css) => {
  const out = [];
  for (const m of Bokeh.documents[0].all_models)
    if ((m.css_classes || []).includes(css) && typeof m.text === "string") out.push(m.text);
  return out.join(" ");
}"""

#: Whether any model carrying CSS class ``css`` is busy (Panel's spinner: ``loading``).
LOADING_JS = """(css) => Array.from(Bokeh.documents[0].all_models).some(
  m => m.loading === true && m.children !== undefined
       && m.children.some(c => (c.css_classes || []).includes(css)))"""


#: Whether a drawn data source has a point at y = the argument (a station layer's).
STATION_AT_JS = """(y) => Array.from(Bokeh.documents[0].all_models).some(
  m => m.data && m.data.y && m.data.x && m.data.x.length <= 9 && Array.from(m.data.y).includes(y))"""


@pytest.fixture(scope="module")
def app_url(server):
    """The dashboard's page on conftest's served app."""
    return server + "/app"


def _open(chromium, url, viewport=VIEWPORT):
    pg = chromium.new_page(viewport=viewport)
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    pg.goto(url)
    pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=120_000)
    return pg, errors


def _text(pg, css):
    return pg.evaluate(TEXT_JS, css)


def _until(fn, what, timeout=30.0):
    deadline = time.time() + timeout
    while True:
        got = fn()
        if got:
            return got
        if time.time() > deadline:
            said = what() if callable(what) else what  # a callable says the state at the end
            raise AssertionError(f"{said}: not reached in {timeout:g} s")
        time.sleep(0.2)


def test_the_track_inputs_take_typed_values_and_say_a_refusal(chromium, app_url):
    # defects 13 and 5: the Track sliders took no typed value (a start of −100 m took 1,500 key
    # presses) and the α box dropped −1, 200 and abc without a word
    pg, errors = _open(chromium, app_url + "?tab=Track")
    try:
        for name, value in (("track_x0", "-100"), ("track_y0", "37.5"), ("track_heading", "-33"),
                            ("track_speed", "3.5"), ("track_duration", "120"),
                            ("track_sigma_a", "0.25"), ("track_runs", "3"), ("track_alpha", "0.002")):
            pg.locator(f".w-{name} input").first.wait_for(timeout=60_000)
            type_value(pg, name, value)
            _until(lambda: f"{name}={value}" in pg.evaluate("() => window.location.search"),
                   f"{name}={value} in the link")
        _until(lambda: "3 runs" in _text(pg, "w-track-summary"), "the summary of 3 runs", 120)
        for typed, why in (("-1", "outside the accepted range"), ("200", "outside the accepted range"),
                           ("abc", "is not a number")):
            type_value(pg, "track_alpha", typed)
            said = _until(lambda: why in _text(pg, "w-message-track") and _text(pg, "w-message-track"),
                          f"the refusal of α = {typed}")
            assert "α" in said, said
            _until(lambda: value_of(pg, "track_alpha") == "0.002",
                   lambda: f"α back to its last good value 0.002 (the box shows {value_of(pg, 'track_alpha')!r})")
        # and Optimise: stations N on the Layout design tab
        pg.get_by_text("Layout design", exact=True).first.click()
        pg.locator(".w-n_stations input").first.wait_for(timeout=60_000)
        type_value(pg, "n_stations", "6")
        _until(lambda: "n_stations=6" in pg.evaluate("() => window.location.search"), "n_stations=6")
        type_value(pg, "n_stations", "9")
        _until(lambda: "outside the accepted range" in _text(pg, "w-design-message"), "N = 9 refused")
        _until(lambda: value_of(pg, "n_stations") == "6", "N back to 6")
    finally:
        pg.close()
    assert errors == [], errors


def test_a_short_track_is_computed_and_a_refused_one_says_none_is(chromium, app_url):
    # defect 9: ?track_duration=5&tab=Track said "init_steps must be an integer in [1, 3]; got 10"
    # under "Computing the track …" for good
    pg, errors = _open(chromium, app_url + "?track_duration=5&tab=Track")
    try:
        _, text = wait_plots(pg, lambda got, text: "bank, 5 runs" in text, timeout=120)
        assert "init_steps" not in text + _text(pg, "w-track-problem")
        # a magnetometer with the bank: a track is computed (the bank runs on every kind), no
        # spinner left and no internal wording
        pg.locator(".w-sensor select").first.select_option("magnetometer (B, nT)")
        _, text = wait_plots(pg, lambda got, text: "bank, 5 runs" in text and "8 states" in text,
                             timeout=120)
        assert "core." not in text + _text(pg, "w-track-problem")
    finally:
        pg.close()
    # a first track refused before it is computed (6,001 steps): no track was ever shown
    pg, more = _open(chromium, app_url + "?T=0.1&track_duration=600&tab=Track")
    errors += more
    try:
        _until(lambda: "No track computed yet" in _text(pg, "w-track-summary"), "No track computed yet", 60)
        problem = _text(pg, "w-track-problem")
        assert "at most 2001" in problem and "last computed track" not in problem, problem
        time.sleep(2.0)  # and no spinner stays over the tab
        assert not pg.evaluate(LOADING_JS, "w-track-summary")
        assert "Computing the track" not in _text(pg, "w-track-summary")
    finally:
        pg.close()
    assert errors == [], errors


@pytest.mark.parametrize("viewport", [VIEWPORT, SMALL_VIEWPORT], ids=["1600", "1280"])
def test_the_plan_views_are_drawn_to_scale(chromium, app_url, viewport):
    # defect 8: 1.333 px/m in x against 0.785 in y at 1600 × 1000 (a 25° track looked like 15°);
    # and the Layout design map was 320 × 320 px with ~200 px blank under it
    pg, errors = _open(chromium, app_url + "?tab=Track", viewport)
    try:
        w, h, xs, ys = _until(lambda: (lambda g: g if g and g[0] > 0 else None)(
            pg.evaluate(SCALE_JS, "Track, PCRLB")), "the plan view drawn", 120)
        # one pixel of rounding in the frame over ~440 px
        assert (w / xs) == pytest.approx(h / ys, rel=0.01), (w, h, xs, ys)
        pg.get_by_text("Layout design", exact=True).first.click()
        w, h, xs, ys = _until(lambda: (lambda g: g if g and g[0] > 0 else None)(
            pg.evaluate(SCALE_JS, "Custom layout")), "the design map drawn", 60)
        assert (w / xs) == pytest.approx(h / ys, rel=0.01), (w, h, xs, ys)
        assert h >= 440, (w, h)  # was 320
        if viewport == VIEWPORT:  # the table's column beside it: no tall blank under the map
            plot = pg.locator(".bk-Figure, .bk-Canvas").filter(visible=True).first.bounding_box()
            column = pg.locator(".w-ellipse-text").first.bounding_box()
            assert column["x"] > plot["x"] + plot["width"] - 5, (plot, column)  # beside it
            blank = column["y"] + column["height"] - (plot["y"] + plot["height"])
            assert blank < 120, (plot, column)  # measured ~200 px with the 320 px map
    finally:
        pg.close()
    assert errors == [], errors


def _cells(rows, field):
    return [rows.nth(i).locator(f'.tabulator-cell[tabulator-field="{field}"]').inner_text().strip()
            for i in range(rows.count())]


def _edit(pg, rows, row, field, text):
    cell = rows.nth(row).locator(f'.tabulator-cell[tabulator-field="{field}"]')
    cell.dblclick()
    box = cell.locator("input")
    box.wait_for(timeout=5_000)
    box.fill(text)
    box.press("Enter")


def test_a_refused_table_edit_is_reverted_at_once_and_the_next_one_kept(chromium, app_url):
    # defect 4: z = −5 sat in the table with no message for 16 s; then y = 130 was lost
    pg, errors = _open(chromium, app_url + "?tab=Layout+design")
    try:
        rows = pg.locator(".w-station-table .tabulator-row")
        wait_count(rows, 2, timeout=60)
        start = time.time()
        _edit(pg, rows, 1, "z (m)", "-5")
        _until(lambda: "above the sea surface" in _text(pg, "w-design-message"), "the refusal said")
        _until(lambda: _cells(rows, "z (m)") == ["100.0", "100.0"], "z reverted")
        assert time.time() - start < 10  # "at once": it was 16 s (generous for a busy machine)
        _edit(pg, rows, 1, "y (m)", "130")
        _until(lambda: _cells(rows, "y (m)") == ["0.0", "130.0"], "y = 130 shown")
        # taken by the server: its map's station layer is redrawn with it
        _until(lambda: pg.evaluate(STATION_AT_JS, 130.0), "y = 130 on the map", 15)
        time.sleep(2.0)  # and it stays
        assert _cells(rows, "y (m)") == ["0.0", "130.0"]
        assert "above the sea surface" not in _text(pg, "w-design-message")
        _edit(pg, rows, 0, "y (m)", "6000")  # beyond the region's limits: refused as well
        _until(lambda: "6000" in _text(pg, "w-design-message"), "y = 6000 refused")
        _until(lambda: _cells(rows, "y (m)") == ["0.0", "130.0"], "y = 6000 reverted")
    finally:
        pg.close()
    assert errors == [], errors


def test_the_station_depth_h_moves_the_design_and_track_stations(chromium, app_url):
    # defect 6: h = 120 moved no custom station; clicked ones then sat at 120 m beside 100 m
    pg, errors = _open(chromium, app_url + "?tab=Layout+design")
    try:
        rows = pg.locator(".w-station-table .tabulator-row")
        wait_count(rows, 2, timeout=60)
        type_value(pg, "h", "120")
        _until(lambda: _cells(rows, "z (m)") == ["120.0", "120.0"], "the stations at h = 120 m", 15)
        canvas = pg.locator("canvas").filter(visible=True).first
        box = canvas.bounding_box()
        for n, (fx, fy) in enumerate([(0.2, 0.25), (0.3, 0.75), (0.6, 0.2)], start=3):
            pg.mouse.click(box["x"] + box["width"] * fx, box["y"] + box["height"] * fy)
            wait_count(rows, n)
            time.sleep(1.5)  # the server's answer to this edit, before the next click
        _until(lambda: _cells(rows, "z (m)") == ["120.0"] * 5, "five stations at 120 m")
        pg.get_by_text("Track", exact=True).first.click()
        # the Track tab tracks over these five stations, at 120 m (its plan's station layer)
        _until(lambda: pg.evaluate("""() => Array.from(Bokeh.documents[0].all_models).some(
            m => m.data && m.data.x && m.data.x.length === 5 && m.data.y && m.data.y.length === 5)"""),
               "five stations on the Track plan", 120)
    finally:
        pg.close()
    assert errors == [], errors
