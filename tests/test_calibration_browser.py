"""The dashboard's Calibration tab (app/calibration.py) used in headless Chromium."""

from __future__ import annotations

import os

import numpy as np
import pytest

from tests.server import CHROMIUM, ROOT, chromium_browser, served_app

playwright = pytest.importorskip("playwright.sync_api")
expect = playwright.expect
#: ms to wait for a change to reach the page: 2 cores shared by many processes (load ~10 seen).
SLOW = 90_000
pytestmark = pytest.mark.skipif(
    not os.path.exists(CHROMIUM) and not os.environ.get("CI"),
    reason="Debian's chromium is not installed (CI installs it; there this test must run)",
)

AXES_JS = """() => {
  const out = [];
  for (const d of Bokeh.documents) for (const m of d.all_models)
    if (m.axis_label !== undefined && m.axis_label) out.push(m.axis_label);
  return out;
}"""


def test_calibration_tab_in_chromium(tmp_path):
    from app import calibration as ac
    from app.scenario import Scenario

    log = tmp_path / "server.log"
    bad = tmp_path / "bad.csv"
    bad.write_text("B1,B2,psi,theta,phi\n1,2,0,0,0\n")
    table1 = ROOT / "data" / "seed004_table1.csv"
    with served_app(timeout=240, log=log) as (url, _), chromium_browser() as browser:
        page = browser.new_page(viewport={"width": 1400, "height": 1400})
        page.goto(url + "/app")
        page.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=SLOW)
        page.get_by_text("Calibration", exact=True).first.click()
        page.wait_for_selector("text=Rank of Γ: 12 of 12", timeout=90_000)
        # every axis says what it shows, with units
        page.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0")
        labels = set(page.evaluate(AXES_JS))
        for want in ("Iteration n (log scale)", "K entry (dimensionless)", "Bp (nT)", "Be error (nT)",
                     "Attitude n", "Heading ψ (°)", "Roll θ (°)"):
            assert want in labels, labels
        # seed 004's observability point: the four-heading preset is rank 9, words and all
        page.get_by_role("button", name="Four level headings").click()
        page.wait_for_selector("text=Rank of Γ: 9 of 12", timeout=SLOW)
        page.wait_for_selector("text=K's third column and Bp cannot be told apart", timeout=SLOW)
        expect(page.locator(".w-cal_source select")).to_have_value("Designed manoeuvre", timeout=SLOW)
        expect(page.locator(".w-cal_roll_deg input")).to_have_value("0", timeout=SLOW)
        # a bad upload: a message in the page, nothing else breaks
        page.locator(".w-cal-upload input[type=file]").set_input_files(str(bad))
        page.wait_for_selector("text=lacks column(s) B3", timeout=SLOW)
        expect(page.locator(".w-cal_source select")).to_have_value("Uploaded CSV", timeout=SLOW)
        # Table 1's Be, then Table 1 uploaded: the page shows what compute() gives for it
        page.get_by_role("button", name="Seed 004 Table 1").click()
        page.wait_for_selector("text=Rank of Γ: 12 of 12", timeout=SLOW)
        page.locator(".w-cal_source select").select_option("Uploaded CSV")
        page.locator(".w-cal-upload input[type=file]").set_input_files(str(table1))
        s = Scenario()
        s.update(ac.PRESETS["Seed 004 Table 1"], cal_source="Uploaded CSV")
        res = ac.compute({f: s.value(f) for f in ac.FIELDS}, table1.read_bytes())
        rms = res["be_rms"]["kal"].rms_nt
        assert np.isfinite(rms)
        page.wait_for_selector(f"text=Kalman {rms:.1f} nT", timeout=SLOW)
        # the fit said in words (core.fit_diagnosis): Table 1's residual is ~4.9 × σ = 100 nT
        assert res["diagnosis"].level == "warning"
        page.wait_for_selector("text=the CRLB for σ is optimistic", timeout=SLOW)
        page.wait_for_selector("text=σ̂ = 489 nT", timeout=SLOW)
        assert page.locator(".w-cal-error").inner_text().strip() == ""
    # no exception from the tab's code on the server (a websocket closed by the browser's exit
    # may log Tornado's own WebSocketClosedError: not ours)
    text = log.read_text()
    for ours in ("app/calibration.py", "core/calibration/", "ValueError"):
        assert ours not in text, text[-3000:]
