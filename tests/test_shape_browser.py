"""The dashboard's Shape tab in headless Chromium: it draws its four plots with units, and a
changed lateral offset changes the closest approach, the verdict and the bound (no ✓ where the
pass cannot size the target)."""

import html
import os
import re
import time

import pytest

from support.page import CHROMIUM

pytest.importorskip("playwright.sync_api")
pytestmark = pytest.mark.skipif(
    not os.path.exists(CHROMIUM) and not os.environ.get("CI"),
    reason="Debian's chromium is not installed (CI installs it; there this test must run)",
)

#: Titles and renderer counts of the plots, every axis label, and the verdict's text: read from
#: the live Bokeh document (Panel draws in shadow DOM).
PLOTS_JS = """() => {
  const out = [], labels = [], texts = [];
  for (const m of Bokeh.documents[0].all_models) {
    if (m.renderers !== undefined && m.title !== undefined && m.title && m.title.text)
      out.push([m.title.text, m.renderers.length]);
    if (m.axis_label !== undefined && m.axis_label) labels.push(m.axis_label);
    if (typeof m.text === "string" && (m.text.includes("Truth") || m.text.includes("Not computed")))
      texts.push(m.text);
  }
  return [out, labels, texts.join(" ")];
}"""


def _wait(pg, predicate, timeout=120.0):
    deadline = time.time() + timeout
    while True:
        got = pg.evaluate(PLOTS_JS)
        text = re.sub(r"<[^>]+>", "", html.unescape(html.unescape(got[2])))
        if predicate(got, text):
            return got, text
        if time.time() > deadline:
            raise AssertionError(f"the tab did not reach the expected state: {got} / {text[:400]}")
        time.sleep(0.3)


def _bound(text):
    """The main scale's bound of the span read, 'span read ± B m' (m), and the closest approach (m)."""
    b = re.search(r"span read ± ([\d.e+-]+) m", text)
    c = re.search(r"closest approach ([\d.e+-]+) m", text)
    return float(b.group(1)), float(c.group(1))


def test_shape_tab_draws_and_follows_the_lateral_offset(chromium, server):
    app = server + "/app"  # conftest's served dashboard and Chromium
    pg = chromium.new_page(viewport={"width": 1600, "height": 1000})
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.goto(app + "?tab=Shape")
    pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=120_000)
    (plots, labels, _), text = _wait(
        pg, lambda got, text: len([t for t, _ in got[0] if t.startswith(("Plan", "Side", "Error", "Bound"))]) == 4
        and "Truth" in text)
    for label in ("x (m)", "y (m)", "z (down) (m)", "platform x (m)", "position error (m)",
                  "closest approach (m)", "1σ bound (m)"):
        assert label in labels, labels
    assert "NHUKF (Huber): line ✓" in text and "Batch fit (whole pass): line ✓" in text
    assert "This pass can size the target" in text
    bound0, cpa0 = _bound(text)
    assert cpa0 == pytest.approx(7.07, abs=0.01)
    box = pg.locator(".w-shape_offset input").first
    box.fill("12")  # 13 m: sizable by the calibrated rule (at 15, 15.8 m, it is borderline)
    box.press("Enter")
    _, text = _wait(pg, lambda got, text: "closest approach 13 m" in text)
    bound1, cpa1 = _bound(text)
    assert cpa1 == pytest.approx(13.0, abs=0.05)
    assert bound1 > 100 * bound0  # the span read's bound grows steeply with the closest approach
    assert "This pass can size the target" in text  # the second-moment read still sizes it
    box.fill("40")
    box.press("Enter")
    _, text = _wait(pg, lambda got, text: "closest approach 40.3 m" in text)
    assert "This pass cannot size the target" in text and "line ✓" not in text
    box.fill("15")
    box.press("Enter")
    _, text = _wait(pg, lambda got, text: "closest approach 15.8 m" in text)
    assert "shape_offset=15" in pg.evaluate("() => window.location.search")
    runs = pg.locator(".w-shape_runs input").first  # 20 passes: long enough to see it busy
    runs.fill("20")
    runs.press("Enter")
    pg.locator(".pn-loading").first.wait_for(state="attached", timeout=10_000)  # busy shown
    _, text = _wait(pg, lambda got, text: "20 passes (medians)" in text)
    # and gone once drawn (the overlay's class is removed by its own message, which may
    # arrive just after the verdict's text on a loaded machine)
    pg.locator(".pn-loading").first.wait_for(state="detached", timeout=15_000)
    narrow = chromium.new_page(viewport={"width": 1280, "height": 800})  # the link reopens it
    narrow.goto(app + pg.evaluate("() => window.location.search"))
    narrow.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=120_000)
    _wait(narrow, lambda got, text: "closest approach 15.8 m" in text)
    narrow.close()
    box.fill("500")  # refused with a message, the last good value kept
    box.press("Enter")
    pg.wait_for_function("() => document.body.innerText.length > 0")
    deadline = time.time() + 30
    while "outside the accepted range" not in pg.evaluate(
            "() => Array.from(Bokeh.documents[0].all_models).filter(m => typeof m.text === 'string')"
            ".map(m => m.text).join(' ')"):
        assert time.time() < deadline, "no refusal message"
        time.sleep(0.3)
    for name, value in (("shape_offset", "0"), ("shape_above", "0.3")):  # through the target
        field = pg.locator(f".w-{name} input").first
        field.fill(value)
        field.press("Enter")
    pg.get_by_text("Not computed: the track passes").first.wait_for(timeout=30_000)
    field = pg.locator(".w-shape_above input").first  # back above it: drawn, message gone
    field.fill("5")
    field.press("Enter")
    _, text = _wait(pg, lambda got, text: "closest approach 5 m" in text and "Not computed" not in text)
    pg.close()
    assert errors == [], errors
