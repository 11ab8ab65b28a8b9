"""The study's report opens in Chromium with the network off, and no request leaves the page
(issue 48): every script and style is in the file, and every tab's figures are drawn."""

import pytest

from app.state.scenario import Scenario
from app.report import html as report, results
from support.page import CHROMIUM, chromium_browser, chromium_missing

pytestmark = pytest.mark.skipif(chromium_missing(), reason=f"no Chromium at {CHROMIUM}")

SMALL = dict(resolution=40, track_runs=2, track_duration=60.0, track_filter="ekf", shape_runs=1,
             cal_iterations=50)


def test_the_report_opens_offline_and_no_request_leaves(tmp_path):
    s = Scenario()
    s.update(SMALL)
    c = results.compute(s.values())
    path = tmp_path / "report.html"
    report.write(path, c, results.summary(c), title="offline")
    requests, errors = [], []
    with chromium_browser() as browser:
        context = browser.new_context(viewport={"width": 1600, "height": 1000}, offline=True)
        pg = context.new_page()
        pg.on("request", lambda r: requests.append(r.url))
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        pg.goto(path.as_uri())
        pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
        # every plot drawn: a canvas per figure (the maps, layout, track, calibration, shape)
        pg.wait_for_function("""() => { let n = 0; const walk = (v) => { if (!v) return;
              if (v.model && v.model.renderers !== undefined && v.canvas_view) n++;
              for (const c of (v.child_views ? Array.from(v.child_views) : [])) walk(c); };
            for (const v of Object.values(Bokeh.index)) walk(v); return n >= 14; }""", timeout=60_000)
        # the texts (Bokeh Divs, drawn in shadow DOM): read from the document
        text = pg.evaluate("""() => Array.from(Bokeh.documents[0].all_models)
            .filter(m => typeof m.text === "string").map(m => m.text).join(" ")""")
        context.close()
    assert requests == [path.as_uri()]  # the file itself, nothing else
    assert errors == []
    assert "The numbers" in text and "Warnings and veils" in text and "share ≤ T" in text
