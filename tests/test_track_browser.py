"""The dashboard's Track tab in headless Chromium: it draws, has units, and follows a changed
tracker."""

import os

import pytest

from support.page import CHROMIUM, wait_plots

pytest.importorskip("playwright.sync_api")
pytestmark = pytest.mark.skipif(
    not os.path.exists(CHROMIUM) and not os.environ.get("CI"),
    reason="Debian's chromium is not installed (CI installs it; there this test must run)",
)

def test_track_tab_draws_with_units_and_follows_the_tracker(chromium, server):
    # the dashboard itself, conftest's (the tab is tested where users meet it)
    pg = chromium.new_page(viewport={"width": 1500, "height": 1100})
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.goto(server + "/app")
    pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=120_000)
    pg.get_by_text("Track", exact=True).first.click()
    # the plots themselves (the Maps tab's titles and the summary's placeholder may come first)
    (plots, labels, _), text = wait_plots(pg, lambda got, text: "bank, 5 runs" in text and any(
        t == "TRMSE vs PCRLB" for t, _ in got[0]))
    titles = [t for t, _ in plots]
    assert "TRMSE vs PCRLB" in titles
    assert any(t.startswith("Track, PCRLB") for t in titles)
    for label in ("x (m)", "y (m)", "time (s)", "position error (m)"):
        assert label in labels, labels
    assert "ML winner" in text  # the bank's winner is named
    pg.locator("select:has(option[value='puekf'])").first.select_option("ekf")
    _, text = wait_plots(pg, lambda got, text: "ekf, 5 runs" in text and "ML winner" not in text)
    assert "mean NEES" in text
    pg.close()
    assert errors == [], errors
