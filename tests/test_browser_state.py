"""Issue 25 in headless Chromium: every number on the page right (the worst three defects)."""

import html
import os
import re
import time

import pytest

from support.page import CHROMIUM, MAPS_JS, PLOTS_WALK, VIEWPORT, wait_count, wait_maps, wait_value

playwright = pytest.importorskip("playwright.sync_api")

pytestmark = pytest.mark.skipif(
    not os.path.exists(CHROMIUM) and not os.environ.get("CI"),
    reason="Debian's chromium is not installed (CI installs it; there this test must run)",
)

#: Per plot: [title, caption (the Title below the map: also in its saved PNG)].
CAPTIONS_JS = """() => {
""" + PLOTS_WALK + """
  return plots.map(p => [p.title.text, p.below.filter(m => m.text !== undefined).map(m => m.text).join(' ')]);
}"""


def depths(rows):
    return [rows.nth(i).locator('.tabulator-cell[tabulator-field="z (m)"]').inner_text().strip()
            for i in range(rows.count())]


def test_stations_added_by_clicks_keep_the_station_depth(page):
    # defect 1: each clicked station was rewritten to z = 0 when the next one was added
    page.get_by_text("Layout design", exact=True).click()
    rows = page.locator(".w-station-table .tabulator-row")
    wait_count(rows, 2)
    canvas = page.locator("canvas").filter(visible=True).first
    box = canvas.bounding_box()
    for n, (fx, fy) in enumerate([(0.2, 0.25), (0.3, 0.75), (0.6, 0.2)], start=3):
        page.mouse.click(box["x"] + box["width"] * fx, box["y"] + box["height"] * fy)
        wait_count(rows, n)
        time.sleep(1.5)  # the server's answer to this edit (a re-drawn layer), before the next click
    deadline = time.time() + 10
    while depths(rows) != ["100.0"] * 5:
        assert time.time() < deadline, f"station depths {depths(rows)}, expected h = 100 m for all"
        time.sleep(0.2)
    time.sleep(1.0)  # and they stay there
    assert depths(rows) == ["100.0"] * 5


def expected_readout(presets, x, y, z=None):
    """The ellipse text at (x, y) after the ``presets`` applied in turn, from the library."""
    from app.kit import views
    from app.kit.runaway import nearest_range
    from app.state.scenario import Scenario
    from app.tabs.design import compute as design_compute
    from app.tabs.maps.compute import Snapshot

    s = Scenario(resolution=21)
    for preset in presets:
        s.apply_preset(preset)
    if z is not None:
        s.target.z = z
    snap = Snapshot.of(s, design_compute.ERROR_MAP_READS)
    rng = float(nearest_range([x, y, s.target.z], s.stations.stations))
    column = s.medium.sea_depth if s.medium.sea_model == "layered" else None  # the water column
    return views.error_ellipse(design_compute.error_at(snap, x, y), x, y, s.region.extent, rng,
                               column)[1]


def ended_at(pg):
    """The preset whose values the page's address holds (None: none's)."""
    from urllib.parse import parse_qsl, urlsplit

    from app.state import url
    from app.state.scenario import Scenario

    s = Scenario()
    url.read_link(s, {k: [v.encode()] for k, v in parse_qsl(urlsplit(pg.url).query)})
    return s.active_preset()


def readout(pg):
    return pg.get_by_text("1-σ horizontal error ellipse").first.inner_text().strip()


def wait_readout(pg, want, timeout=20.0):
    deadline = time.time() + timeout
    while True:
        got = readout(pg)
        # Markdown renders the same plain text (no markup in it)
        if re.sub(r"\s+", " ", got) == re.sub(r"\s+", " ", want):
            return
        if time.time() > deadline:
            raise AssertionError(f"readout {got!r}, expected {want!r}")
        time.sleep(0.2)


def test_the_error_ellipse_readout_follows_presets_and_the_target_depth(page):
    # defect 2: after Seed 001 sea trial → Fig. 5 the text still read the trial's numbers, and a
    # new z on the tab redrew the ellipse, not its text
    page.get_by_text("Layout design", exact=True).click()
    page.get_by_text("1-σ horizontal error ellipse").first.wait_for(timeout=30_000)
    page.get_by_role("button", name="Seed 001 sea trial").click()
    trial = ["Seed 001 sea trial"]
    wait_readout(page, expected_readout(trial, 100.0, 100.0))
    page.get_by_role("button", name="Fig. 5").click()
    want = expected_readout(trial + ["Fig. 5"], 100.0, 100.0)
    assert want != expected_readout(trial, 100.0, 100.0)
    wait_readout(page, want)
    box = page.locator(".w-z input").first
    box.fill("150")
    box.press("Enter")
    wait_readout(page, expected_readout(trial + ["Fig. 5"], 100.0, 100.0, z=150.0))


@pytest.mark.parametrize("session", range(3))
def test_every_message_reaches_the_page_in_the_order_it_was_made(page, session):
    # CI failed on "reference p4070 isn't known" after a preset on Layout design: the maps'
    # message (made on the loop, queued by Panel's own path while the socket was busy) was
    # overtaken by a later change from Panel's threads to another pane that used a stylesheet
    # the overtaken message was first to send; the browser dropped that change (app/kit/offloop.py,
    # changes). That race needs a busy socket: with both cores of this machine loaded, the
    # module's first two tests failed so in 3 of 22 runs before the fix, 0 of 10 after. Here each
    # new session (the stylesheets are sent on a pane's first update) goes through every preset
    # on Layout design, whose readout and maps change together; the fixture fails on any console
    # error. The same burst found two more: the readout left at an older preset's numbers (a
    # slower evaluation on another thread ended last: 2 of 3 runs; app/tabs/design/design.py ellipse_text)
    # and two presets' updates interleaved on two threads (app/state/scenario.py Scenario.update).
    from app.state.scenario import PRESETS

    page.get_by_text("Layout design", exact=True).click()
    page.get_by_text("1-σ horizontal error ellipse").first.wait_for(timeout=30_000)
    for name in PRESETS:
        page.get_by_role("button", name=name).click()
        page.wait_for_timeout(150)
    # The scenario ends at one preset, whole (not a mix), and the readout is that preset's. It is
    # the last one clicked in most runs, not all: Panel hands a click that arrives while changes
    # from the browser are pending to its thread pool after them, and a click 150 ms later can
    # then be applied first (docs/dashboard.md; 1 run of 3 ended at the one before the last).
    deadline = time.time() + 20.0
    while True:
        final = ended_at(page)
        try:
            assert final in PRESETS, f"the page ends at no preset: {page.url}"
            wait_readout(page, expected_readout([final], 100.0, 100.0), timeout=1.0)
            break
        except AssertionError:
            if time.time() > deadline:
                raise


def captions(pg):
    return pg.evaluate(CAPTIONS_JS)


def test_map_b_is_titled_and_captioned_with_its_own_moments(page):
    # defect 3: in Fig. 2, B's title said P = (100, 100), its caption and PNG P = (100, 20)
    page.get_by_role("button", name="Fig. 2").click()
    wait_maps(page, lambda drawn: "P = (100, 100)" in drawn[1][0])
    # the collapsed card's inputs, built when it is first opened, show the preset's values
    assert page.locator(".w-Pv_b").count() == 0
    page.get_by_text("Scenario B of Figs. 3, 4, 6", exact=True).click()
    wait_value(page, "Pv_b", 100.0)
    (title_a, cap_a), (title_b, cap_b), (_, cap_d) = captions(page)[:3]
    flat = [re.sub(r"\s+", " ", c) for c in (cap_a, cap_b, cap_d)]
    assert "P = (100, 20) A·m" in title_a and "P = (100, 20) A·m" in flat[0]
    assert "P = (100, 100) A·m" in title_b and "P = (100, 100) A·m" in flat[1], flat[1]
    assert "P_A = (100, 20) A·m" in flat[2] and "P_B = (100, 100) A·m" in flat[2]


def test_map_bs_note_gives_bs_own_unobservable_direction(page):
    # defect 3: Figs. 3 and 4: B's "unobservable direction" was A's vector
    from app.state.scenario import Scenario
    from app.tabs.maps.compute import Snapshot, compute

    for name in ("Fig. 3", "Fig. 4"):
        page.get_by_role("button", name=name).click()
        s = Scenario(resolution=21)
        s.apply_preset(name)
        want = compute(Snapshot.of(s)).note  # the direction itself: tests/test_scenario.py
        b_line = next(line for line in want.splitlines() if line.startswith("B:"))
        vector = b_line[b_line.index("Unobservable direction"):]
        note = page.locator(".w-note .alert").first
        deadline = time.time() + 30
        while vector not in re.sub(r"\s+", " ", note.inner_text()):
            assert time.time() < deadline, f"{name}: B's direction {vector!r} not in {note.inner_text()!r}"
            time.sleep(0.2)
        assert page.evaluate(MAPS_JS)  # the maps are still there


def test_no_request_leaves_the_server(chromium, server):
    # issue 25 Offline: after a preset, loading.css and markdown.css came from cdn.holoviz.org
    # (Panel's dynamic Tabs had detached the visited, hidden tabs' models from the document;
    # a change to them patched the page's shared stylesheets to its CDN)
    pg = chromium.new_page(viewport=VIEWPORT)
    outside = []
    pg.on("request", lambda r: outside.append(r.url)
          if not r.url.startswith((server, "blob:" + server, "data:")) else None)
    try:
        pg.goto(server + "/app")
        pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
        wait_maps(pg, lambda maps: len(maps) == 3)
        for tab in ("Layout design", "Track", "Calibration", "Maps"):
            pg.get_by_text(tab, exact=True).click()
            time.sleep(4)
        pg.get_by_role("button", name="Seed 001 sea trial").click()
        time.sleep(3)
        pg.get_by_text("Layout design", exact=True).click()
        time.sleep(3)
        pg.get_by_role("button", name="Fig. 5").click()
        time.sleep(3)
        assert outside == [], f"requests that left the server: {outside}"
    finally:
        pg.close()


def cells(rows, field):
    return [rows.nth(i).locator(f'.tabulator-cell[tabulator-field="{field}"]').inner_text().strip()
            for i in range(rows.count())]


def test_a_preset_after_another_shows_its_own_complete_scenario(page):
    # issue 25: Fig. 5 after the sea trial kept the trial's stations on the seabed at 8.4 m
    page.get_by_text("Layout design", exact=True).click()
    rows = page.locator(".w-station-table .tabulator-row")
    wait_count(rows, 2)
    page.get_by_role("button", name="Seed 001 sea trial").click()
    deadline = time.time() + 15
    while cells(rows, "z (m)") != ["8.4", "8.4"]:
        assert time.time() < deadline, cells(rows, "z (m)")
        time.sleep(0.2)
    page.get_by_role("button", name="Fig. 5").click()
    deadline = time.time() + 15
    while (cells(rows, "x (m)"), cells(rows, "z (m)")) != (["0.0", "15.0"], ["100.0", "100.0"]):
        assert time.time() < deadline, (cells(rows, "x (m)"), cells(rows, "z (m)"))
        time.sleep(0.2)
    page.get_by_text("Maps", exact=True).click()
    wait_maps(page, lambda drawn: any(title == "B: dual, d = 15 m" for title, _ in drawn))
    assert page.locator(".w-sea_model select").first.input_value() == "whole space"


def active_tab(pg):
    return pg.locator(".bk-tab.bk-active").first.inner_text().strip()


def test_a_link_of_every_tab_reopens_the_same_view(chromium, server):
    # issue 25: a link carried neither the Track nor the Calibration state (?track_heading=33 was
    # ignored), nor the tab shown; here a link is copied on each tab and opened in a new page
    first = chromium.new_page(viewport=VIEWPORT)
    try:
        # a layered sea by the link (its rule moves h to the seabed, D = 50 m), the Track's
        # heading by the link, the Calibration's inputs by hand
        first.goto(server + "/app?sea_model=layered&sea_depth=50&track_heading=33")
        first.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
        wait_maps(first, lambda maps: len(maps) == 3)
        wait_value(first, "h", 50.0)
        first.get_by_text("Calibration", exact=True).click()
        first.locator(".w-cal_source select").first.select_option("Designed manoeuvre")
        first.wait_for_function("() => window.location.search.includes('cal_source=Designed')",
                                timeout=15_000)
        headings = first.locator(".w-cal_headings input").first
        headings.fill("0, 45, 90")
        headings.press("Tab")
        first.wait_for_function("() => window.location.search.includes('cal_headings=')", timeout=15_000)
        links = {}
        for tab in ("Calibration", "Track", "Layout design", "Maps"):
            first.get_by_text(tab, exact=True).click()
            # a tab's first visit builds it before the link's watcher runs: on two test workers
            # and a busy core the link said tab=Track 15 s after the click on Layout design
            deadline = time.time() + 60
            want = "" if tab == "Maps" else "tab=" + tab.replace(" ", "+")
            while ((want or "tab=") in first.evaluate("() => window.location.search")) != bool(want):
                assert time.time() < deadline, first.evaluate("() => window.location.search")
                time.sleep(0.2)
            links[tab] = first.evaluate("() => window.location.search")
    finally:
        first.close()
    for tab, link in links.items():
        assert "track_heading=33" in link and "cal_headings=0%2C+45%2C+90" in link, link
        assert "h=50" in link, link
        pg = chromium.new_page(viewport=VIEWPORT)
        try:
            pg.goto(server + "/app" + link)
            pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
            pg.locator(".bk-tab.bk-active").first.wait_for(timeout=30_000)
            assert active_tab(pg) == tab
            pg.get_by_text("Maps", exact=True).click()
            wait_value(pg, "sea_depth", 50.0)
            wait_value(pg, "h", 50.0)  # moved by the layered sea's rule, and kept in the link
            pg.get_by_text("Track", exact=True).click()
            pg.locator(".w-track_heading input").first.wait_for(timeout=30_000)
            wait_value(pg, "track_heading", 33.0)  # a typed box above its slider (issue 40)
            pg.get_by_text("Calibration", exact=True).click()
            box = pg.locator(".w-cal_headings input").first
            box.wait_for(timeout=15_000)
            assert box.input_value() == "0, 45, 90"
        finally:
            pg.close()


def test_a_ninth_station_is_refused_not_swapped_for_the_oldest(page):
    # issue 25: with 8 stations a click silently deleted the oldest
    page.get_by_text("Layout design", exact=True).click()
    rows = page.locator(".w-station-table .tabulator-row")
    wait_count(rows, 2)
    canvas = page.locator("canvas").filter(visible=True).first
    box = canvas.bounding_box()
    # inside the frame: away from the title, the toolbar and the colour bar on the right
    spots = [(0.2, 0.3), (0.55, 0.3), (0.2, 0.75), (0.55, 0.75), (0.38, 0.3), (0.2, 0.52),
             (0.38, 0.75)]
    for n, (fx, fy) in enumerate(spots[:6], start=3):
        page.mouse.click(box["x"] + box["width"] * fx, box["y"] + box["height"] * fy)
        wait_count(rows, n)
        time.sleep(1.0)
    before = cells(rows, "x (m)")
    page.mouse.click(box["x"] + box["width"] * spots[6][0], box["y"] + box["height"] * spots[6][1])
    page.locator(".w-design-message").get_by_text("At most 8 stations").wait_for(timeout=15_000)
    time.sleep(1.0)
    assert rows.count() == 8 and cells(rows, "x (m)") == before  # the oldest is still there


def test_the_ellipse_point_is_its_own_input(page):
    # issue 25: a click both added a station and (said the text) moved the ellipse point
    page.get_by_text("Layout design", exact=True).click()
    page.get_by_text("1-σ horizontal error ellipse").first.wait_for(timeout=30_000)
    box = page.locator(".w-ellipse_x input").first
    box.fill("-40")
    box.press("Enter")
    deadline = time.time() + 15
    while "Target at (-40, 100) m" not in readout(page):
        assert time.time() < deadline, readout(page)
        time.sleep(0.2)


def test_the_noise_box_takes_any_accepted_value_and_says_why_it_refuses_one(page):
    # issue 25: 1e-3 (inside the accepted 1e-12 … 1e-2) was refused without a word, and so was -1
    page.get_by_text("Advanced", exact=True).click()
    box = page.locator(".w-noise input").first
    box.fill("1e-3")
    box.press("Enter")
    deadline = time.time() + 15
    while float(box.input_value()) != 1e-3:
        assert time.time() < deadline, box.input_value()
        time.sleep(0.2)
    page.wait_for_function("() => window.location.search.includes('noise=0.001')", timeout=15_000)
    box.fill("-1")
    box.press("Enter")
    page.locator(".w-message-noise").get_by_text("outside the accepted range").wait_for(timeout=15_000)
    # the message is sent as the owner refuses; the box shows the kept value on the loop's next
    # tick (app/kit/number_box.settle), so it may still read -1 when the message arrives (it did on CI)
    deadline = time.time() + 15
    while box.input_value() != "0.001":
        assert time.time() < deadline, f"the box shows {box.input_value()!r}, expected '0.001'"
        time.sleep(0.2)
    assert "noise=0.001" in page.evaluate("() => window.location.search")


def test_the_maps_do_not_jump_when_the_paper_banner_comes_and_goes(page):
    # issue 25 (Maps): the maps moved ~45 px down and up as the banner was shown and hidden
    canvas = page.locator("canvas").filter(visible=True).first
    with_banner = canvas.bounding_box()["y"]
    box = page.locator(".w-Ph input").first
    box.fill("123")
    box.press("Enter")
    page.wait_for_function("() => window.location.search.includes('Ph=123')", timeout=15_000)
    time.sleep(1.0)
    assert page.locator(".w-paper .alert").count() == 0  # no paper figure any more
    assert not page.locator(".w-start").is_visible()  # nor the opening's "Start here"
    assert abs(canvas.bounding_box()["y"] - with_banner) <= 1


#: The Maps tab's paper banner and note (their text, "" while hidden) and the address's query,
#: read from the live Bokeh document (Panel draws in shadow DOM).
TEXTS_JS = """() => {
  const out = {url: window.location.search};
  for (const m of Bokeh.documents[0].all_models)
    if (m.css_classes !== undefined && typeof m.text === "string")
      for (const c of ["w-paper", "w-note"])
        if (m.css_classes.includes(c)) out[c] = m.visible ? m.text : "";
  return out;
}"""

#: The Track tab's PCRLB plot is drawn.
TRACK_DRAWN_JS = """() => Array.from(Bokeh.documents[0].all_models).some(m => m.title && m.title.text
  && m.title.text.startsWith('Track, PCRLB'))"""

#: Seconds within which the banner, the note and the address follow the maps of a preset. They
#: are sent ~0.1 s after the maps (app/tabs/maps/maps.py, URL_AFTER) when nothing holds them; this bound
#: leaves the rest for a loaded machine (2 cores shared with other work), far below the defect's
#: 20-30 s.
TEXT_AFTER_MAPS_S = 8.0


def plain(text):
    """An HTML pane's model text as shown: Panel sends the pane's HTML escaped once; unescaped,
    its tags out (the note's own "<" is still "&lt;" then), its entities resolved, runs of space
    as one."""
    markup = html.unescape(text or "")
    return re.sub(r"\s+", " ", html.unescape(re.sub(r"<[^>]+>", " ", markup))).strip()


def expected_texts(presets):
    """(paper banner, note, query) as the page should show them after ``presets`` applied in turn
    on a fresh page: from the library, in this process."""
    from app.state import url
    from app.state.scenario import Scenario
    from app.tabs.maps.compute import Snapshot, compute
    from app.tabs.maps.maps import _paper_line, alert

    s = Scenario()
    for preset in presets:
        s.apply_preset(preset)
    p = compute(Snapshot.of(s))
    note = "\n".join(t for t in (p.note, p.far_note) if t)
    # as the page's panes hold them (app/tabs/maps/maps.py): alerts, which Panel sends escaped
    return (plain(html.escape(_paper_line(p))), plain(html.escape(alert(note, "warning"))),
            url.query(s))


def test_the_text_and_link_follow_a_preset_with_the_maps_after_other_tabs_were_opened(chromium, server):
    # issue 40 defect 3: with Layout design, Track, Calibration and Shape opened once, a preset
    # clicked on the Maps tab redrew the maps at ~5 s while the banner, the yellow note and the
    # address kept the previous scenario's for 24-33 s (the hidden tabs recomputed on the click's
    # thread). Hidden tabs now compute nothing until shown.
    from urllib.parse import parse_qsl

    from support.page import SMALL_VIEWPORT

    pg = chromium.new_page(viewport=SMALL_VIEWPORT)
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    try:
        pg.goto(server + "/app")
        pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
        wait_maps(pg, lambda maps: len(maps) == 3)
        for tab in ("Layout design", "Track", "Calibration", "Shape"):
            pg.get_by_text(tab, exact=True).click()
            wait_count(pg.locator(".w-tab-opening").filter(visible=True), 0)  # built
            if tab == "Track":  # its first track drawn: the tab holds results to redo
                pg.wait_for_function(TRACK_DRAWN_JS, timeout=180_000)
            time.sleep(1.0)
        pg.get_by_text("Maps", exact=True).click()
        presets = []
        for name in ("Seed 001 sea trial", "Seed 003 sensors"):
            presets.append(name)
            paper, note, query = expected_texts(presets)
            before = pg.evaluate(MAPS_JS)[:3]  # the Maps tab's (the other tabs' plots follow)
            pg.get_by_role("button", name=name).click()
            drawn = wait_maps(pg, lambda maps: maps[:3] != before, timeout=60.0)[:3]
            t_maps = time.time()
            while True:
                got = pg.evaluate(TEXTS_JS)
                now = (plain(got.get("w-paper")), plain(got.get("w-note")),
                       sorted(parse_qsl(got["url"].lstrip("?"))))
                want = (paper, note, sorted(parse_qsl(query.lstrip("?"))))
                if now == want:
                    break
                assert time.time() - t_maps < TEXT_AFTER_MAPS_S, (
                    f"{name}: {TEXT_AFTER_MAPS_S} s after its maps were drawn the page still shows "
                    f"{now}, expected {want}")
                time.sleep(0.1)
            assert pg.evaluate(MAPS_JS)[:3] == drawn  # the maps of this preset, drawn once
        # a tab hidden during the presets shows them once opened: the Layout design's readout
        pg.get_by_text("Layout design", exact=True).click()
        wait_readout(pg, expected_readout(presets, 100.0, 100.0), timeout=60.0)
    finally:
        pg.close()
    assert errors == [], errors
