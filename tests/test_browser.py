"""The served dashboard in headless Chromium, used as an analyst would."""

import os
import time
from pathlib import Path
from urllib.parse import urlencode

import pytest

from tests.server import CHROMIUM, chromium_browser, served_app

playwright = pytest.importorskip("playwright.sync_api")
DOCS = Path(__file__).resolve().parents[1] / "docs"

pytestmark = pytest.mark.skipif(
    not os.path.exists(CHROMIUM) and not os.environ.get("CI"),
    reason="Debian's chromium is not installed (CI installs it; there this test must run)",
)

#: For every plot on screen: [title, [sum of each image layer's finite values]] (map, veil):
#: a fingerprint of what is drawn, read from the live Bokeh views.
MAPS_JS = """() => {
  const plots = [];
  const walk = (v) => {
    if (!v) return;
    if (v.model && v.model.renderers !== undefined && v.model.title !== undefined) plots.push(v.model);
    for (const c of (v.child_views ? Array.from(v.child_views) : [])) walk(c);
  };
  for (const v of Object.values(Bokeh.index)) walk(v);
  return plots.map(p => [p.title ? p.title.text : "",
    p.renderers.filter(r => r.data_source && r.data_source.data.image).map(r => {
      let s = 0; const a = r.data_source.data.image[0];
      for (let i = 0; i < a.length; i++) if (!isNaN(a[i])) s += a[i];
      return s; })]);
}"""
#: Per plot: [RGBA bytes of the map layer as drawn, how many differ from the image mapped through
#: the plot's colour bar mapper, the colour bar's low, the image mapper's low].
COLOURS_JS = """() => {
  const out = [];
  const walk = (v) => { if (!v) return;
    if (v.model && v.model.renderers !== undefined && v.model.title !== undefined) out.push(v);
    for (const c of (v.child_views ? Array.from(v.child_views) : [])) walk(c); };
  for (const v of Object.values(Bokeh.index)) walk(v);
  return out.map(pv => {
    const r = pv.model.renderers.find(r => r.data_source && r.data_source.data.image);
    const canvas = pv.renderer_views.get(r).glyph.image_data[0];
    const px = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
    const bar = pv.model.right.find(m => m.color_mapper).color_mapper;
    const want = bar.rgba_mapper.v_compute(r.data_source.data.image[0]);
    let bad = 0; for (let i = 0; i < want.length; i++) if (want[i] !== px[i]) bad++;
    return [px.length, bad, bar.low, r.glyph.color_mapper.low];
  });
}"""
AXES_JS = """() => {
  const out = [];
  for (const m of Bokeh.documents[0].all_models)
    if (m.axis_label !== undefined && m.axis_label) out.push(m.axis_label);
  return out;
}"""


@pytest.fixture(scope="module")
def server():
    with served_app() as (url, _):
        yield url


@pytest.fixture(scope="module")
def chromium():
    with chromium_browser() as browser:
        yield browser


@pytest.fixture
def page(chromium, server):
    pg = chromium.new_page(viewport={"width": 1700, "height": 1100})
    errors = []
    pg.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.goto(server + "/app")
    pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
    wait_maps(pg, lambda maps: len(maps) == 3)
    yield pg
    pg.close()
    assert errors == [], f"browser console errors: {errors}"


def maps(pg):
    return pg.evaluate(MAPS_JS)


def wait_maps(pg, predicate, timeout=30.0):
    """Poll what is drawn until ``predicate(maps)`` holds; return it."""
    deadline = time.time() + timeout
    while True:
        drawn = maps(pg)
        if predicate(drawn):
            return drawn
        if time.time() > deadline:
            raise AssertionError(f"the maps did not reach the expected state: {drawn}")
        time.sleep(0.2)


def values(drawn):
    """The map layer's fingerprint of each plot (A, B, difference)."""
    return [layers[0] for _, layers in drawn]


def changed(before):
    """Predicate: all three maps show new values."""
    return lambda drawn: len(drawn) == 3 and all(a != b for a, b in zip(values(drawn), values(before)))


def value_of(pg, name):
    return pg.locator(f".w-{name} input").first.input_value()


def wait_value(pg, name, expected, timeout=15.0):
    deadline = time.time() + timeout
    while float(value_of(pg, name)) != expected:
        if time.time() > deadline:
            raise AssertionError(f"{name} shows {value_of(pg, name)}, expected {expected}")
        time.sleep(0.1)


def select(pg, name, option):
    pg.locator(f".w-{name} select").first.select_option(option)


def type_value(pg, name, value):
    box = pg.locator(f".w-{name} input").first
    box.fill(str(value))
    box.press("Enter")


def test_page_loads_with_three_maps_and_units(page):
    drawn = maps(page)
    assert len(drawn) == 3 and all(len(layers) == 2 for _, layers in drawn)  # map + veil
    labels = page.evaluate(AXES_JS)
    assert labels.count("x (m)") == 3 and labels.count("y (m)") == 3
    assert "round-off" in drawn[0][0]  # the single-station map says what it is
    assert drawn[0][1][1] == 200 * 200  # and is veiled everywhere (rank 6)
    assert drawn[1][1][1] == 0  # the dual map nowhere


def test_dragging_the_ph_slider_changes_the_maps(page):
    before = maps(page)
    handle = page.locator(".w-Ph .noUi-handle").first
    box = handle.bounding_box()
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    page.mouse.down()
    page.mouse.move(box["x"] + 120, box["y"] + box["height"] / 2, steps=8)
    page.mouse.up()
    wait_maps(page, changed(before))
    assert float(value_of(page, "Ph")) > 100.0
    # each image is coloured with its colour bar's range (the browser copies the range into the
    # images' mapper: app/map_figures.py), pixel for pixel, and the spinner has stopped
    for n_pixels, bad, bar_low, img_low in page.evaluate(COLOURS_JS):
        assert n_pixels == 4 * 200 * 200 and bad == 0 and bar_low == img_low
    page.wait_for_function("""() => { const s = Array.from(Bokeh.documents[0].all_models)
        .filter(m => (m.css_classes || []).includes('loader'));
        return s.length === 1 && !s[0].css_classes.includes('spin'); }""", timeout=5_000)


def test_preset_click_changes_parameters_and_maps(page):
    before = maps(page)
    page.get_by_role("button", name="Fig. 6").click()
    after = wait_maps(page, changed(before))
    wait_value(page, "d", 50.0)
    assert [t for t, _ in after][:2] == ["A: dual, d = 10 m", "B: dual, d = 50 m"]


def test_switching_plane_and_measure(page):
    select(page, "plane", "x–z")
    page.wait_for_function(f"() => ({AXES_JS})().filter(l => l === 'z (m)').length === 3", timeout=30_000)
    before = maps(page)
    select(page, "measure", "CRLB position error (m)")
    wait_maps(page, changed(before))
    assert page.evaluate(AXES_JS).count("z (m)") == 3


SPINNING_JS = """() => Array.from(Bokeh.documents[0].all_models).some(
  m => (m.css_classes || []).includes('loader') && m.css_classes.includes('spin'))"""


def test_slow_change_shows_the_busy_spinner_until_its_maps_are_drawn(chromium, server):
    # CRLB maps of 10 instants at 400 × 400 take several tenths of a second (fast changes do not
    # flash the spinner: app/dashboard.py BUSY_AFTER)
    query = urlencode({"measure": "CRLB position error (m)", "steps": 10, "resolution": 400})
    pg = chromium.new_page(viewport={"width": 1700, "height": 1100})
    try:
        pg.goto(f"{server}/app?{query}")
        pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
        before = wait_maps(pg, lambda drawn: len(drawn) == 3)
        assert pg.locator(".w-measure select").first.input_value() == "CRLB position error (m)"
        type_value(pg, "Ph", 150)
        pg.wait_for_function(SPINNING_JS, polling="raf", timeout=15_000)
        wait_maps(pg, lambda drawn: values(drawn)[1] != values(before)[1])  # A: single, all +inf
        pg.wait_for_function(f"() => !({SPINNING_JS})()", timeout=15_000)
    finally:
        pg.close()


def test_out_of_range_value_shows_message_and_keeps_maps(page):
    before = maps(page)
    type_value(page, "Ph", "1e9")
    page.wait_for_selector("text=outside the accepted range", timeout=15_000)
    time.sleep(1.0)
    assert maps(page) == before
    wait_value(page, "Ph", 100.0)


def test_screenshots_for_the_readme(page):
    DOCS.mkdir(exist_ok=True)
    page.screenshot(path=str(DOCS / "screenshot-default.png"))
    page.get_by_role("button", name="Fig. 2").click()  # somewhere else first, so Fig. 5 is a change
    wait_value(page, "Pv_b", 100.0)
    before = wait_maps(page, lambda drawn: "P = (100, 100)" in drawn[1][0])
    page.get_by_role("button", name="Fig. 5").click()
    wait_maps(page, lambda drawn: drawn[1][0] == "B: dual, d = 15 m" and changed(before)(drawn))
    time.sleep(1.0)
    page.screenshot(path=str(DOCS / "screenshot-fig5.png"))
    assert (DOCS / "screenshot-fig5.png").stat().st_size > 50_000


def wait_count(locator, n, timeout=30.0):
    deadline = time.time() + timeout
    while locator.count() != n:
        if time.time() > deadline:
            raise AssertionError(f"expected {n} of {locator}, found {locator.count()}")
        time.sleep(0.2)


def test_layout_design_click_adds_a_station_and_best_spacing_runs(page):
    page.get_by_text("Layout design").click()
    rows = page.locator(".w-station-table .tabulator-row")
    wait_count(rows, 2)  # the paper's pair
    canvas = page.locator("canvas").filter(visible=True).first
    box = canvas.bounding_box()
    page.mouse.click(box["x"] + box["width"] * 0.25, box["y"] + box["height"] * 0.3)
    wait_count(rows, 3)  # a click on the map added a station
    page.get_by_role("button", name="Find best spacing").click()
    page.wait_for_function(f"() => ({MAPS_JS})().some(([t]) => t.startsWith('Best: d ='))", timeout=60_000)
    titles = [t for t, _ in maps(page)]
    assert "Paper: d = 15 m" in titles


def test_a_pasted_link_reopens_the_view(chromium, server):
    pg = chromium.new_page(viewport={"width": 1700, "height": 1100})
    pg.goto(server + "/app?Ph=300.0&plane=x%E2%80%93z&d=40.0")
    pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
    wait_maps(pg, lambda drawn: len(drawn) == 3 and drawn[1][0] == "B: dual, d = 40 m")
    wait_value(pg, "Ph", 300.0)
    assert pg.locator(".w-plane select").first.input_value() == "x–z"
    assert pg.evaluate(AXES_JS).count("z (m)") == 3
    # and changing a value writes it back into the address bar
    type_value(pg, "Pv", "55")
    pg.wait_for_function("() => window.location.search.includes('Pv=55')", timeout=15_000)
    pg.close()
