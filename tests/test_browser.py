"""The served dashboard in headless Chromium, used as an analyst would."""

import time
from pathlib import Path
from urllib.parse import urlencode

import numpy as np
import pytest

from support.page import (
    MAPS_JS,
    PLOTS_WALK,
    VIEWPORT,
    chromium_missing,
    maps,
    select,
    type_value,
    value_of,
    wait_count,
    wait_maps,
    wait_value,
)

playwright = pytest.importorskip("playwright.sync_api")

pytestmark = pytest.mark.skipif(
    chromium_missing(),
    reason="Debian's chromium is not installed (CI installs it; there this test must run)",
)

#: Per plot: [RGBA bytes of the map layer as drawn, how many differ from the image's real values
#: (the sent image is normalised to the colour range: app/tabs/maps/figures.py) mapped through the
#: plot's colour bar mapper].
COLOURS_JS = """() => {
""" + PLOTS_WALK + """
  return views.map(pv => {
    const r = pv.model.renderers.find(r => r.data_source && r.data_source.data.image);
    const canvas = pv.renderer_views.get(r).glyph.image_data[0];
    const px = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
    const bar = [...pv.model.right, ...pv.model.below].find(m => m.color_mapper).color_mapper;
    const real = Array.from(r.data_source.data.image[0], v => bar.low + v * (bar.high - bar.low));
    const want = bar.rgba_mapper.v_compute(real);
    let bad = 0; for (let i = 0; i < want.length; i++) if (want[i] !== px[i]) bad++;
    return [px.length, bad];
  });
}"""
#: Per plot: how many pixels of its veil are unobservable (veil codes 1 and 2: app/tabs/maps/figures.py).
VEILED_JS = """() => {
""" + PLOTS_WALK + """
  return plots.map(p => { const r = p.renderers.filter(r => r.data_source && r.data_source.data.image)[1];
    let n = 0; for (const c of r.data_source.data.image[0]) if (c == 1 || c == 2) n++; return n; });
}"""
AXES_JS = """() => {
  const out = [];
  for (const m of Bokeh.documents[0].all_models)
    if (m.axis_label !== undefined && m.axis_label) out.push(m.axis_label);
  return out;
}"""


def values(drawn):
    """The map layer's fingerprint of each plot (A, B, difference)."""
    return [layers[0] for _, layers in drawn]


def changed(before):
    """Predicate: all three maps show new values."""
    return lambda drawn: len(drawn) == 3 and all(a != b for a, b in zip(values(drawn), values(before)))


def test_page_loads_with_three_maps_and_units(page):
    drawn = maps(page)
    assert len(drawn) == 3 and all(len(layers) == 2 for _, layers in drawn)  # map + veil
    labels = page.evaluate(AXES_JS)
    assert labels.count("x (m)") == 3 and labels.count("y (m)") == 3
    assert "round-off" in drawn[0][0]  # the single-station map says what it is
    veiled = page.evaluate(VEILED_JS)
    assert veiled[0] == 200 * 200  # and is veiled everywhere (rank 6)
    assert veiled[1] == 0  # the dual map nowhere
    # the page says where to start (issue 25: a newcomer took the hatched maps for broken), and
    # only as it opens
    page.locator(".w-start").get_by_text("one station cannot tell range from source strength").wait_for(timeout=5_000)


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
    # each image is coloured as its colour bar says: its real values (normalised in float32 and
    # back) through the bar's mapper; a value within float32 round-off (~1e-7 of the range) of a
    # bin edge of the 256 colours may land in the neighbouring bin: at most 0.1 % of the bytes
    for n_pixels, bad in page.evaluate(COLOURS_JS):
        assert n_pixels == 4 * 200 * 200 and bad <= 0.001 * n_pixels
    # and the spinner has stopped
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
    page.wait_for_function(f"() => ({AXES_JS})().filter(l => l.startsWith('z (m)')).length === 3", timeout=30_000)
    before = maps(page)
    select(page, "measure", "CRLB position error (m)")
    wait_maps(page, changed(before))
    assert sum(label.startswith("z (m)") for label in page.evaluate(AXES_JS)) == 3


SPINNING_JS = """() => Array.from(Bokeh.documents[0].all_models).some(
  m => (m.css_classes || []).includes('loader') && m.css_classes.includes('spin'))"""


def test_slow_change_shows_the_busy_spinner_until_its_maps_are_drawn(chromium, server):
    # CRLB maps of 10 instants at 400 × 400 take several tenths of a second (fast changes do not
    # flash the spinner: app/page.py BUSY_AFTER)
    query = urlencode({"measure": "CRLB position error (m)", "steps": 10, "resolution": 400})
    pg = chromium.new_page(viewport=VIEWPORT)
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


def test_the_fig5_preset_draws_its_maps(page):
    """The README's Fig. 5 view (its picture: python -m support.screenshots --out docs fig5)."""
    page.get_by_role("button", name="Fig. 2").click()  # somewhere else first, so Fig. 5 is a change
    before = wait_maps(page, lambda drawn: "P = (100, 100)" in drawn[1][0])
    page.get_by_role("button", name="Fig. 5").click()
    wait_maps(page, lambda drawn: drawn[1][0] == "B: dual, d = 15 m" and changed(before)(drawn))


def test_layout_design_click_adds_a_station_at_depth_h_and_best_spacing_compares_fairly(page):
    page.get_by_text("Layout design", exact=True).click()
    rows = page.locator(".w-station-table .tabulator-row")
    wait_count(rows, 2)  # the paper's pair
    canvas = page.locator("canvas").filter(visible=True).first
    box = canvas.bounding_box()
    page.mouse.click(box["x"] + box["width"] * 0.25, box["y"] + box["height"] * 0.3)
    wait_count(rows, 3)  # a click on the map added a station ...
    depth = rows.nth(2).locator('.tabulator-cell[tabulator-field="z (m)"]')
    deadline = time.time() + 10
    while depth.inner_text().strip() != "100.0":  # ... at the station depth h (was z = 0)
        assert time.time() < deadline, f"new station at z = {depth.inner_text()}"
        time.sleep(0.2)
    # the sensor noise reads as a number (was "+0.000" for 1e-7)
    page.get_by_text("Advanced", exact=True).click()
    assert float(value_of(page, "noise")) == 1e-7 and "e-" in value_of(page, "noise")
    type_value(page, "noise", "2e-7")
    deadline = time.time() + 10
    while float(value_of(page, "noise")) != 2e-7:
        assert time.time() < deadline, f"noise box shows {value_of(page, 'noise')!r}"
        time.sleep(0.2)
    page.get_by_role("button", name="Find best spacing").click()
    page.wait_for_function(f"() => ({MAPS_JS})().some(([t]) => t.startsWith('Best: d ='))", timeout=60_000)
    time.sleep(1.0)
    plots = {p["title"]: p for p in layers(page)}
    best = next(p for t, p in plots.items() if t.startswith("Best: d ="))
    paper = plots["Paper: d = 15 m"]
    assert best["clim"] == paper["clim"]  # one colour scale: the side-by-side comparison is fair
    # nothing runs off to the side (the Paper map was cut off; the main area scrolled sideways)
    overflow = page.evaluate("""() => [document.scrollingElement.scrollWidth - window.innerWidth,
        ...Array.from(document.querySelectorAll('#main, .main')).map(e => e.scrollWidth - e.clientWidth)]""")
    assert max(overflow) <= 1, overflow
    # (a table entry with z < 0 is refused by Scenario.stations: tests/test_scenario.py; typing
    # into a Tabulator cell from Playwright was not reliable enough to test here)


def test_a_pasted_link_reopens_the_view(chromium, server):
    pg = chromium.new_page(viewport=VIEWPORT)
    pg.goto(server + "/app?Ph=300.0&plane=x%E2%80%93z&d=40.0")
    pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
    wait_maps(pg, lambda drawn: len(drawn) == 3 and drawn[1][0] == "B: dual, d = 40 m")
    wait_value(pg, "Ph", 300.0)
    assert pg.locator(".w-plane select").first.input_value() == "x–z"
    assert sum(label.startswith("z (m)") for label in pg.evaluate(AXES_JS)) == 3
    # and changing a value writes it back into the address bar
    type_value(pg, "Pv", "55")
    pg.wait_for_function("() => window.location.search.includes('Pv=55')", timeout=15_000)
    pg.close()


# -- issue 16: what a new analyst met ------------------------------------------------------------

#: Per plot: the rectangle (x, y, dw, dh) of each image layer (map, veil), the y range, the
#: colour bar's title, each image's colour-bar low and high.
LAYERS_JS = """() => {
""" + PLOTS_WALK + """
  return plots.map(p => {
    const bar = [...p.right, ...p.below].find(m => m.color_mapper);  // the maps': below
    return {title: p.title.text,
      layers: p.renderers.filter(r => r.data_source && r.data_source.data.image).map(r => {
        const d = r.data_source.data; return [d.x[0], d.y[0], d.dw[0], d.dh[0]]; }),
      y: [p.y_range.start, p.y_range.end], bar: bar ? bar.title : null,
      clim: bar ? [bar.color_mapper.low, bar.color_mapper.high] : null};
  });
}"""


def layers(pg):
    return pg.evaluate(LAYERS_JS)


def test_every_layer_of_a_map_covers_the_same_rectangle_after_plane_changes(page):
    # defect 1: after x–z, the veil of A and C covered z 100–300 only; back in x–y, y 100–300 only
    for plane in ("x–z", "x–y", "x–z"):
        select(page, "plane", plane)
        page.wait_for_function(f"() => ({AXES_JS})().filter(l => l.startsWith('{plane[-1]} (m)')).length === 3",
                               timeout=30_000)
        time.sleep(0.5)  # the veils come with the maps' patch
        for plot in layers(page):
            assert len(plot["layers"]) == 2 and plot["layers"][0] == plot["layers"][1], plot
    page.get_by_role("button", name="Fig. 2").click()
    wait_maps(page, lambda drawn: "P = (100, 100)" in drawn[1][0])
    page.get_by_role("button", name="Fig. 3").click()
    wait_maps(page, lambda drawn: "moments × 10" in drawn[1][0])
    time.sleep(0.5)
    for plot in layers(page):
        assert plot["layers"][0] == plot["layers"][1], plot


def test_x_z_maps_have_depth_increasing_downwards_with_the_stations_in_view(page):
    select(page, "plane", "x–z")
    page.wait_for_function(f"() => ({AXES_JS})().filter(l => l.startsWith('z (m)')).length === 3", timeout=30_000)
    bottom, top = layers(page)[0]["y"]  # a Bokeh range starts at the bottom of the plot
    assert top < 100.0 < 400.0 <= bottom  # deep down; z = 100 m (the stations, h = z from) below the top


def _tooltip(pg, plot, fx, fy):
    """Hover plot number ``plot`` at fractions (fx, fy) of its canvas; the tooltip's text."""
    canvas = pg.locator("canvas").filter(visible=True).nth(2 * plot)  # a plot has two: primary, overlay
    box = canvas.bounding_box()
    pg.mouse.move(box["x"] + fx * box["width"], box["y"] + fy * box["height"], steps=3)
    tip = pg.locator(".bk-tooltip-content").filter(visible=True).first
    tip.wait_for(timeout=10_000)
    return tip.text_content()


def test_crlb_maps_are_in_log_metres_and_say_where_a_value_is_missing(page):
    # defect 2: a linear 0–18 000 m scale, hover "Infinity m" and NaN without explanation
    select(page, "measure", "CRLB position error (m)")
    page.wait_for_function(f"() => ({LAYERS_JS})().every(p => (p.bar || '').includes('CRLB') "
                           "|| (p.bar || '').includes('σ_B'))", timeout=30_000)
    plots = layers(page)
    assert all("log scale" in p["bar"] for p in plots[:2])
    low, high = plots[1]["clim"]
    assert high - low > 1 and high < 6  # decades of metres (log10), not 0 … 18 000 m
    assert len(plots[2]["title"]) <= 40  # the difference map's title fits (was cut: "…B locates bette")
    text = _tooltip(page, 0, 0.45, 0.3)  # map A: one station, unobservable everywhere
    assert "unobservable (rank 6)" in text and "Infinity" not in text
    text = _tooltip(page, 1, 0.45, 0.3)  # map B: a distance in metres
    assert " m" in text and "NaN" not in text and "Infinity" not in text


def test_a_crlb_far_from_the_stations_is_hatched_and_not_quoted_as_an_error(page):
    # issue 18: where the CRLB exceeds 30 % of the range, the linearised bound runs away
    select(page, "measure", "CRLB position error (m)")
    page.wait_for_function(f"() => ({LAYERS_JS})()[1].bar.includes('CRLB')", timeout=30_000)
    far = _tooltip(page, 1, 0.2, 0.15)  # towards map B's corner: ~340 m from the stations
    assert " m" in far and "far-field runaway" in far
    near = _tooltip(page, 1, 0.47, 0.33)  # ~55 m from the stations (frame above its colour bar): trusted
    assert " m" in near and "runaway" not in near
    # the legend's entry: the panes under the maps follow the maps' own message (app/tabs/maps/maps.py)
    page.get_by_text("far-field runaway)").first.wait_for(state="visible", timeout=15_000)
    note = page.locator(".w-note").first
    assert "not trackable from these stations" in note.locator(".alert").text_content()


def test_a_veiled_point_hovers_as_unobservable_not_a_number(page):
    # defect 8: the default view's map A (one station: rank 6) hovered as a number
    text = _tooltip(page, 0, 0.4, 0.4)
    assert "unobservable (rank 6)" in text


def _message_near(pg, name):
    """A refusal of ``name``'s input is said right under it, where the user typed (it was at the
    top of the sidebar, out of sight when typing in Stations or Advanced)."""
    msg = pg.locator(f".w-message-{name}").filter(visible=True).first
    msg.wait_for(timeout=15_000)
    box, inp = msg.bounding_box(), pg.locator(f".w-{name} input").first.bounding_box()
    assert 0 <= box["y"] - (inp["y"] + inp["height"]) <= 80, (box, inp)  # just below the input
    msg.scroll_into_view_if_needed()
    return msg.locator(".alert").text_content()  # the pane's text is in its shadow root


def test_a_typed_depth_above_the_surface_is_refused_where_the_user_typed_it(page):
    # defects 3 and 4: h = -5 was accepted; refusals showed at the top of the sidebar
    type_value(page, "h", "-5")
    text = _message_near(page, "h")
    assert "above the sea surface" in text
    wait_value(page, "h", 100.0)


def test_a_refusal_in_the_advanced_section_shows_next_to_the_input(page):
    page.get_by_text("Advanced", exact=True).click()
    box = page.locator(".w-T input").first
    box.scroll_into_view_if_needed()
    type_value(page, "T", "1e9")
    text = _message_near(page, "T")
    assert "outside the accepted range" in text


def test_a_link_with_refused_values_says_so_and_leaves_the_address_bar(chromium, server):
    # defect 3: ?h=-5 accepted silently; ?resolution=100000 ignored silently; both stayed in the URL
    pg = chromium.new_page(viewport=VIEWPORT)
    try:
        pg.goto(server + "/app?h=-5&resolution=100000&Ph=150.0")
        pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
        wait_maps(pg, lambda drawn: len(drawn) == 3)
        msg = pg.locator(".w-message").filter(visible=True).first
        msg.wait_for(timeout=15_000)
        text = msg.locator(".alert").text_content()
        assert "h:" in text and "above the sea surface" in text and "resolution:" in text
        wait_value(pg, "h", 100.0)
        # a refused link is refused whole (issue 40 defect 1): Ph = 150 is not set either, and
        # the address bar shows the view, the defaults
        wait_value(pg, "Ph", 100.0)
        pg.wait_for_function("() => window.location.search === ''", timeout=15_000)
    finally:
        pg.close()


def test_maps_fill_the_width_and_widen_when_the_sidebar_collapses(page):
    # defect 5: fixed 270 px frames, map A's y label clipped, no wider with the sidebar collapsed
    def widths():  # of the three maps' canvases (each plot has two: primary and overlay)
        canvases = page.locator("canvas").filter(visible=True)
        boxes = [canvases.nth(i).bounding_box() for i in range(0, min(canvases.count(), 6), 2)]
        return [(b["x"], b["width"]) for b in boxes]
    main = page.locator("#main").bounding_box()
    before = widths()
    assert len(before) == 3 and sum(w for _, w in before) >= 0.85 * main["width"]
    assert min(left for left, _ in before) >= main["x"] - 1  # nothing cut at the left
    page.locator("#sidebar-toggle").click()
    deadline = time.time() + 15
    while sum(w for _, w in widths()) < sum(w for _, w in before) * 1.15:
        assert time.time() < deadline, f"maps did not widen: {before} -> {widths()}"
        time.sleep(0.3)


def test_fig1_visibly_identifies_the_paper_figure(page):
    # defect 8: from the default view Fig. 1 changed nothing visible
    before = [t for t, _ in maps(page)]
    page.get_by_role("button", name="Fig. 1").click()
    drawn = wait_maps(page, lambda d: "(paper)" in d[0][0])
    assert [t for t, _ in drawn] != before
    # the banner's change is a message of its own after the maps' (app/kit/offloop.py, changes)
    page.locator(".w-paper").filter(visible=True).first.locator(".alert").filter(
        has_text="Fig. 1").wait_for(timeout=15_000)


def test_remedy_buttons_show_only_where_they_apply(page):
    known, crlb = page.locator(".w-remedy-known"), page.locator(".w-remedy-crlb")
    assert known.first.is_visible() and crlb.first.is_visible()  # map A is veiled
    crlb.first.locator("button").click()
    page.wait_for_function(f"() => ({LAYERS_JS})()[1].bar.includes('CRLB')", timeout=30_000)
    crlb.first.wait_for(state="hidden", timeout=15_000)  # CRLB is shown already
    page.get_by_role("button", name="Fig. 6").click()  # dual vs dual: nothing veiled
    wait_maps(page, lambda drawn: drawn[1][0] == "B: dual, d = 50 m")
    # hidden once the page has the new state (a busy machine may take more than half a second)
    known.first.wait_for(state="hidden", timeout=15_000)
    crlb.first.wait_for(state="hidden", timeout=15_000)


def test_controls_that_do_not_apply_are_hidden(page):
    # defect 8: Fixed y in x–y, target depth in x–z, the maps' controls on the Layout design tab
    assert not page.locator(".w-y").first.is_visible() and page.locator(".w-z").first.is_visible()
    select(page, "plane", "x–z")
    page.locator(".w-y").first.wait_for(state="visible", timeout=60_000)
    page.locator(".w-z").first.wait_for(state="hidden", timeout=60_000)
    page.get_by_text("Layout design", exact=True).click()
    page.locator(".w-measure").first.wait_for(state="hidden", timeout=60_000)
    page.locator(".w-z").first.wait_for(state="visible", timeout=60_000)  # the design maps' depth
    assert not page.locator(".w-y").first.is_visible()


def test_the_idle_spinner_is_not_shown(page):
    # defect 8: a permanent hollow ring looked stalled
    shown = page.evaluate("""() => Array.from(Bokeh.documents[0].all_models)
        .filter(m => (m.css_classes || []).includes('loader')).map(m => m.visible)""")
    assert shown == [False]


def test_a_saved_png_is_named_after_the_scenario_opaque_with_labels_and_caption(page):
    import io

    from PIL import Image

    canvas = page.locator("canvas").filter(visible=True).first
    box = canvas.bounding_box()
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)  # shows the toolbar
    save = page.locator(".bk-tool-icon-save").filter(visible=True).first
    with page.expect_download(timeout=30_000) as info:
        save.click()
    download = info.value
    assert download.suggested_filename == "fig_5_x_y_log10_det_A.png"
    img = Image.open(io.BytesIO(Path(download.path()).read_bytes())).convert("RGBA")
    # opaque (it was transparent): the figure's CSS size is fractional when it fills the page,
    # so pixels at the canvas's edges may be part-covered by the fill (anti-aliasing: alpha a
    # few units under 255); none is more than slightly see-through, and ≥ 99 % are fully opaque
    w, h = img.size
    alpha = np.asarray(img.getchannel("A"))
    assert alpha[2:-2, 2:-2].min() >= 240, "the PNG has transparent pixels"
    assert (alpha == 255).mean() >= 0.99
    grey = img.convert("L")
    # the y label, rotated, in the leftmost strip; the caption's lines in the bottom strip
    left = grey.crop((0, h // 4, max(1, w // 25), 3 * h // 4))
    bottom = grey.crop((w // 10, int(0.9 * h), 9 * w // 10, h))
    assert left.getextrema()[0] < 128, "no y label in the saved PNG"
    assert bottom.getextrema()[0] < 128, "no caption in the saved PNG"
