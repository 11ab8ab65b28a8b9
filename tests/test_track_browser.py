"""The dashboard's Track tab in headless Chromium: it draws, has units, and follows a changed
tracker."""

import html
import os
import re
import time

import pytest

from tests.server import CHROMIUM, chromium_browser, served_app

pytest.importorskip("playwright.sync_api")
pytestmark = pytest.mark.skipif(
    not os.path.exists(CHROMIUM) and not os.environ.get("CI"),
    reason="Debian's chromium is not installed (CI installs it; there this test must run)",
)

#: Titles and renderer counts of the plots, every axis label, and the text of the panes that
#: mention runs (the summary line): read from the live Bokeh document (Panel draws in shadow DOM).
PLOTS_JS = """() => {
  const out = [];
  for (const m of Bokeh.documents[0].all_models)
    if (m.renderers !== undefined && m.title !== undefined && m.title && m.title.text)
      out.push([m.title.text, m.renderers.length]);
  const labels = [];
  for (const m of Bokeh.documents[0].all_models)
    if (m.axis_label !== undefined && m.axis_label) labels.push(m.axis_label);
  const texts = [];
  for (const m of Bokeh.documents[0].all_models)
    if (typeof m.text === "string" && m.text.includes("runs")) texts.push(m.text);
  return [out, labels, texts.join(" ")];
}"""


@pytest.fixture(scope="module")
def server():
    """The dashboard itself: the tab is tested where users meet it."""
    with served_app(timeout=240) as (url, _):
        yield url + "/app"


def _wait(pg, predicate, timeout=90.0):
    deadline = time.time() + timeout
    while True:
        got = pg.evaluate(PLOTS_JS)
        text = re.sub(r"<[^>]+>", "", html.unescape(html.unescape(got[2])))  # markdown's HTML
        if predicate(got, text):
            return got, text
        if time.time() > deadline:
            raise AssertionError(f"the tab did not reach the expected state: {got} / {text[:300]}")
        time.sleep(0.3)


def test_track_tab_draws_with_units_and_follows_the_tracker(server):
    with chromium_browser() as browser:
        pg = browser.new_page(viewport={"width": 1500, "height": 1100})
        errors = []
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.goto(server)
        pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=120_000)
        pg.get_by_text("Track", exact=True).first.click()
        (plots, labels, _), text = _wait(pg, lambda got, text: len(got[0]) >= 2 and "bank" in text)
        titles = [t for t, _ in plots]
        assert "TRMSE vs PCRLB" in titles
        assert any(t.startswith("Track, PCRLB") for t in titles)
        for label in ("x (m)", "y (m)", "time (s)", "position error (m)"):
            assert label in labels, labels
        assert "ML winner" in text  # the bank's winner is named
        pg.locator("select:has(option[value='puekf'])").first.select_option("ekf")
        _, text = _wait(pg, lambda got, text: "ekf, 5 runs" in text and "ML winner" not in text)
        assert "mean NEES" in text
        pg.close()
    assert errors == [], errors
