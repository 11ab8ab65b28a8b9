"""The dashboard's Calibration tab (app/tabs/calibration/calibration.py) used in headless Chromium."""

from __future__ import annotations

import itertools
import os
import re

import numpy as np
import pytest

from support.page import CHROMIUM, chromium_browser
from support.server import ROOT, served_app

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


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """The served app (one for the module's tests) and its log."""
    log = tmp_path_factory.mktemp("served") / "server.log"
    with served_app(timeout=240, log=log) as (url, _):
        yield url, log


def no_exception_of_ours(log):
    """No exception from the tab's code on the server (a websocket closed by the browser's exit
    may log Tornado's own WebSocketClosedError: not ours)."""
    text = log.read_text()
    for ours in ("app/tabs/calibration/calibration.py", "core/calibration/", "ValueError"):
        assert ours not in text, text[-3000:]


def test_calibration_tab_in_chromium(tmp_path, served):
    from app.state.scenario import Scenario
    from app.tabs.calibration import calibration as ac

    url, log = served
    bad = tmp_path / "bad.csv"
    bad.write_text("B1,B2,psi,theta,phi\n1,2,0,0,0\n")
    table1 = ROOT / "data" / "seed004_table1.csv"
    with chromium_browser() as browser:
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
    no_exception_of_ours(log)


#: The line colours of the K convergence plot's curves, by legend label (k11 … k33).
K_COLOURS_JS = """() => {
  const out = {};
  for (const d of Bokeh.documents) for (const m of d.all_models)
    if (m.glyph !== undefined && m.name && /^k[123][123]$/.test(m.name) && m.glyph.line_color)
      out[m.name] = typeof m.glyph.line_color === 'string' ? m.glyph.line_color
                    : (m.glyph.line_color.value ?? JSON.stringify(m.glyph.line_color));
  return out;
}"""


def test_calibration_issue_25_in_chromium(served):
    """Issue 25's Calibration items as a user sees them: the paper-figure buttons leave the
    sidebar on this tab; the inputs follow the data source; the Table 1 preset's noise shows
    without float noise; the noise the residuals give and the convention that fits are offered
    and take effect on a click; four level headings read as not identifiable; the nine K curves
    have distinct colours."""
    from tests.test_calibration_tab import MIN_DELTA_E, _lab

    url, log = served
    with chromium_browser() as browser:
        page = browser.new_page(viewport={"width": 1400, "height": 1400})
        page.goto(url + "/app")
        page.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=SLOW)
        figures = page.locator(".w-preset-1").first  # Fig. 1's button, in the sidebar
        expect(figures).to_be_visible(timeout=SLOW)
        page.get_by_text("Calibration", exact=True).first.click()
        page.wait_for_selector("text=Rank of Γ: 12 of 12", timeout=SLOW)
        # 7. the paper's figures set the Maps state: not offered here
        expect(figures).to_be_hidden(timeout=SLOW)
        expect(page.get_by_text("Paper figures")).to_be_hidden(timeout=SLOW)
        # 4. the inputs of the chosen source only (Seed 004 simulation: no design inputs)
        for cls in ("w-cal_headings", "w-cal_roll_deg", "w-cal_pitch_deg"):
            expect(page.locator(f".{cls}")).to_be_hidden(timeout=SLOW)
        expect(page.locator(".w-cal_seed")).to_be_visible(timeout=SLOW)
        page.locator(".w-cal_source select").select_option("Uploaded CSV")
        for cls in ("w-cal_seed", "w-cal_n_attitudes", "w-cal_headings"):
            expect(page.locator(f".{cls}")).to_be_hidden(timeout=SLOW)
        # (issue 28, app/kit/offloop.py) an instant result, the message to upload, leaves no spinner
        # on: it stayed on for good when the spinner's "on" reached the page after the result
        page.wait_for_selector("text=Upload a CSV file", timeout=SLOW)
        page.wait_for_timeout(2000)  # the page's last changes of this result
        expect(page.locator(".pn-loading")).to_have_count(0, timeout=SLOW)
        expect(page.locator(".w-cal_be_n")).to_be_visible(timeout=SLOW)
        page.locator(".w-cal_source select").select_option("Designed manoeuvre")
        for cls in ("w-cal_headings", "w-cal_roll_deg", "w-cal_pitch_deg", "w-cal_seed"):
            expect(page.locator(f".{cls}")).to_be_visible(timeout=SLOW)
        # 6. nine curves of K, each pair far apart in colour
        page.wait_for_function("() => { let n = 0; for (const d of Bokeh.documents) for (const m of "
                               "d.all_models) if (m.glyph && /^k[123][123]$/.test(m.name || '')) n++;"
                               " return n >= 9; }", timeout=SLOW)
        colours = page.evaluate(K_COLOURS_JS)
        assert len(colours) == 9, colours
        for a, b in itertools.combinations(sorted(colours), 2):
            d = np.linalg.norm(_lab(colours[a]) - _lab(colours[b]))
            assert d >= MIN_DELTA_E, (a, colours[a], b, colours[b], d)
        # 5. Table 1's noise bound, 100·√3 nT, without float noise
        page.get_by_role("button", name="Seed 004 Table 1").click()
        expect(page.locator(".w-cal_noise_nt input")).to_have_value("173.2051", timeout=SLOW)
        # 1. its residual: σ̂ = 489 nT; the bound for it in the table, and a button that sets it
        fix = page.locator(".w-cal-fix-noise button")
        expect(fix).to_have_text("Use σ from the residuals (reading error ± 847.7 nT)", timeout=SLOW)
        expect(page.locator(".w-cal-table")).to_contain_text("CRLB σ from residuals", timeout=SLOW)
        fix.click()
        expect(page.locator(".w-cal_noise_nt input")).to_have_value(re.compile(r"^847\.7\d{0,3}$"),
                                                                    timeout=SLOW)
        expect(fix).to_be_hidden(timeout=SLOW)
        expect(page.locator(".w-cal-summary")).to_contain_text("Rank of Γ: 12 of 12", timeout=SLOW)
        expect(page.locator(".w-cal-summary")).not_to_contain_text("optimistic", timeout=SLOW)
        expect(page.locator(".w-cal-table")).not_to_contain_text("CRLB σ from residuals", timeout=SLOW)
        # 2. with σ = 100 nT again, the convention that fits better is offered and used on a click
        page.get_by_role("button", name="Seed 004 Table 1").click()
        conv = page.locator(".w-cal-fix-convention button")
        expect(conv).to_have_text("Use the 'seed004_std_pitch' attitude convention", timeout=SLOW)
        conv.click()
        expect(page.locator(".w-cal_convention select")).to_have_value("seed004_std_pitch", timeout=SLOW)
        page.wait_for_selector("text=The residual RMS is 303 nT", timeout=SLOW)
        # 3. four level headings: not identifiable, no convergence claim
        page.get_by_role("button", name="Four level headings").click()
        page.wait_for_selector("text=Not identifiable: k13, k23, k33, Bp1, Bp2 and Bp3", timeout=SLOW)
        summary = page.locator(".w-cal-summary")  # (expect's text includes the pane's shadow DOM)
        expect(summary).to_contain_text("no convergence to report", timeout=SLOW)
        expect(summary).not_to_contain_text("within one CRLB σ", timeout=SLOW)
        expect(page.locator(".w-cal-table")).to_contain_text("no: not identifiable", timeout=SLOW)
    no_exception_of_ours(log)
