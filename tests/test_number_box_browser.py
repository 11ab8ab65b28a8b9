"""Number boxes in headless Chromium (issue 40 defect 5): the Calibration tab's boxes and the
sidebar's noise box say why they refuse a text, keep the last good value, and an emptied noise
box raises nothing in the server. Bokeh's spinners dropped -3, 500 and abc in the browser
without a word; the emptied noise box logged a server traceback."""

import time

import pytest

from support.page import SMALL_VIEWPORT, VIEWPORT, chromium_missing, wait_maps
from support.server import served_app

playwright = pytest.importorskip("playwright.sync_api")

pytestmark = pytest.mark.skipif(
    chromium_missing(),
    reason="Debian's chromium is not installed (CI installs it; there this test must run)",
)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """The served dashboard, as conftest's, with its log kept (a test reads it for tracebacks)."""
    log = tmp_path_factory.mktemp("server") / "server.log"
    with served_app(log=log) as (url, _):
        yield url, log


@pytest.fixture(scope="module")
def page(server, chromium):
    pg = chromium.new_page(viewport=VIEWPORT)
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.goto(server[0] + "/app")
    pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
    wait_maps(pg, lambda drawn: len(drawn) == 3)
    yield pg
    assert errors == []


def _type(pg, css, text):
    box = pg.locator(f"{css} input").first
    box.scroll_into_view_if_needed()
    box.fill(text)
    box.press("Enter")
    return box


def _wait_text(box, want, timeout=15.0):
    deadline = time.time() + timeout
    # the text exactly: the box once stepped past Panel's echo filter with a trailing space and
    # sometimes kept "100 " (app/kit/number_box.py now sets only the value's own text)
    while box.input_value() != want:
        assert time.time() < deadline, f"the box shows {box.input_value()!r}, expected {want!r}"
        time.sleep(0.2)


@pytest.mark.parametrize("name, text, kept, why", [
    ("cal_noise_nt", "-3", "100", "outside the accepted range 0.1 … 5000 nT"),
    ("cal_n_attitudes", "500", "12", "outside the accepted range 1 … 120 attitudes"),
    ("cal_be_n", "abc", "34000", "“abc” is not a number"),
])
def test_a_calibration_box_says_why_it_refuses_and_shows_the_last_good_value(page, name, text, kept, why):
    page.get_by_text("Calibration", exact=True).first.click()
    page.locator(f".w-{name} input").first.wait_for(timeout=60_000)
    box = _type(page, f".w-{name}", text)
    message = page.locator(".w-message-cal").filter(visible=True).first
    message.get_by_text(why).wait_for(timeout=15_000)
    _wait_text(box, kept)


def test_the_emptied_noise_box_says_so_and_raises_nothing(page, server):
    page.get_by_text("Maps", exact=True).first.click()
    page.get_by_text("Advanced", exact=True).click()
    box = _type(page, ".w-noise", "")
    page.locator(".w-message-noise").get_by_text("empty: type a number").wait_for(timeout=15_000)
    _wait_text(box, "1e-07")
    time.sleep(1.0)  # anything the server raised is in its log by now
    assert "Traceback" not in server[1].read_text(errors="replace")


@pytest.mark.parametrize("tab, inputs, last", [
    ("Calibration", ".w-cal_noise_nt", "(Kalman − truth)/σ"),
    ("Shape", ".w-shape-preset", None),
])
def test_at_1280_by_800_the_tabs_inputs_are_in_the_sidebar_and_nothing_is_cut_off(server, chromium, tab, inputs, last):
    # issue 40 defect 12: a blank 360 px sidebar beside the tab's own inputs cut off the
    # coefficient table ("CRLB σ" clipped, "(Kalman − truth)/σ" out of view) and shrank the
    # Shape views to ~190 × 100 px
    pg = chromium.new_page(viewport=SMALL_VIEWPORT)
    pg.goto(server[0] + "/app")
    pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
    pg.get_by_text(tab, exact=True).first.click()
    box = pg.locator(f"#sidebar {inputs}").first
    box.wait_for(timeout=60_000)
    if last:
        pg.wait_for_selector("text=Rank of Γ: 12 of 12", timeout=120_000)
        header = pg.get_by_text(last, exact=True).first.bounding_box()
        assert header["x"] + header["width"] <= SMALL_VIEWPORT["width"], header
    pg.close()
