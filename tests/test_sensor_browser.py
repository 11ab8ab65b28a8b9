"""Sensor kinds in the served dashboard (issue 26 item 5), driven in headless Chromium."""

import os
import time

import pytest

from support.page import CHROMIUM, chromium_browser, wait_plots
from support.server import served_app

playwright = pytest.importorskip("playwright.sync_api")

pytestmark = pytest.mark.skipif(
    not os.path.exists(CHROMIUM) and not os.environ.get("CI"),
    reason="Debian's chromium is not installed (CI installs it; there this test must run)",
)

#: Per map on screen: its title, caption (the Title below it), the Label inside its frame (text,
#: or "" when hidden), its colour bar's title, and how many veil pixels are unobservable.
DRAWN_JS = """() => {
  const plots = [];
  const walk = (v) => { if (!v) return;
    if (v.model && v.model.renderers !== undefined && v.model.title !== undefined) plots.push(v.model);
    for (const c of (v.child_views ? Array.from(v.child_views) : [])) walk(c); };
  for (const v of Object.values(Bokeh.index)) walk(v);
  return plots.map(p => {
    const veil = p.renderers.filter(r => r.data_source && r.data_source.data.image)[1];
    let n = 0; for (const c of veil.data_source.data.image[0]) if (c == 1 || c == 2) n++;
    const label = p.center.find(m => m.text !== undefined && m.x_units !== undefined);
    const caption = p.below.find(m => m.text !== undefined);
    const bar = [...p.right, ...p.below].find(m => m.color_mapper);  // under the map
    return {title: p.title.text, caption: caption ? caption.text : "",
            label: label && label.visible ? label.text : "", bar: bar ? bar.title : "", veiled: n};
  });
}"""


def drawn_when(pg, predicate, timeout=60.0):
    deadline = time.time() + timeout
    while True:
        drawn = pg.evaluate(DRAWN_JS)
        if len(drawn) == 3 and predicate(drawn):
            return drawn
        if time.time() > deadline:
            raise AssertionError(f"the maps did not reach the expected state: {drawn}")
        time.sleep(0.2)


@pytest.fixture(scope="module")
def page():
    with served_app() as (url, _), chromium_browser() as browser:
        pg = browser.new_page(viewport={"width": 1600, "height": 1000})
        errors = []
        pg.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.goto(url + "/app")
        pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
        yield pg
        assert errors == [], f"browser console errors: {errors}"


def test_choosing_gradiometer_then_both_redraws_with_the_kinds_captions_and_veil(page):
    drawn = drawn_when(page, lambda d: d[0]["title"].startswith("A: single station"))
    assert "V/m" in drawn[0]["caption"] and "sensor" not in drawn[0]["caption"]  # the electric default
    assert not page.locator(".w-mx").first.is_visible() and page.locator(".w-Ph").first.is_visible()

    page.locator(".w-sensor select").first.select_option("gradiometer (G, nT/m)")
    drawn = drawn_when(page, lambda d: d[0]["title"].startswith("A: single gradiometer"))
    a, b = drawn[0], drawn[1]
    assert "rank 7 of 8" in a["label"] and "gradiometer" in a["label"]  # said inside its frame
    assert a["veiled"] > 0 and b["veiled"] == 0 and b["label"] == ""
    assert "nT/m" in a["caption"] and "A·m²" in a["caption"] and "V/m" not in a["caption"]
    assert a["bar"] == "CRLB 1σ (m), gradiometer (nT/m), log scale"
    # the inputs follow the kind: the moment vector and the gradiometer's noise, not P_h and V/m
    page.locator(".w-mx").first.wait_for(state="visible", timeout=15_000)
    assert not page.locator(".w-Ph").first.is_visible()
    # the measure moved off the electric paper's square rule, and the page says why
    message = page.locator(".w-message-sensor").filter(visible=True).first
    message.wait_for(timeout=15_000)
    assert "square-Γ rule" in message.locator(".alert").text_content()  # in the pane's shadow root

    page.locator(".w-sensor select").first.select_option("magnetometer + gradiometer (BG)")
    drawn = drawn_when(page, lambda d: d[0]["title"].startswith("A: single magnetometer + gradiometer"))
    a = drawn[0]
    assert a["label"] == "" and a["veiled"] == 0  # B + G at one station is observable (spec §11)
    assert "noise 0.01 nT and 0.01 nT/m" in a["caption"].replace("\n", " ")
    assert a["bar"] == "CRLB 1σ (m), B + G (nT, nT/m), log scale"

    # the Track tab tracks with the chosen kind (issue 26): its banner says which; seed 001's
    # bank (the tab's default tracker) runs on it (issue 36), then the EKF when chosen
    page.get_by_text("Track", exact=True).click()
    banner = page.locator(".w-track-sensor").first
    banner.wait_for(state="visible", timeout=30_000)
    assert "seen by the sidebar's sensor, magnetometer + gradiometer" in \
        banner.locator(".alert").text_content()
    _, text = wait_plots(page, lambda got, text: "bank, 5 runs" in text and "ML winner" in text,
                         timeout=180)
    page.locator("select:has(option[value='puekf'])").first.select_option("ekf")
    _, text = wait_plots(page, lambda got, text: "ekf, 5 runs" in text and "mean NEES" in text, timeout=120)
    assert "ML winner" not in text
