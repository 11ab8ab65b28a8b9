"""The floor apps of bench.bench_floor (issue 29 item 4) serve, draw three maps, and a drag of their
slider (the same code that drives the dashboard's P_h slider) redraws all three with the images
of the new value. Checks that the floor the dashboard is compared against does the same visible
work; the timings are bench.bench_floor's, not a test's."""

import pytest

from bench.bench_browser import INSTALL_JS, MAP_A_SUM_JS, PH_VALUE_JS, RESET_JS, drag_to
from bench.bench_floor import MODELS_JS, expected_sum, open_page, served_floor, settle
from support.page import chromium_browser

#: Runs alone, after the rest (``pytest -m serial``; tests/conftest.py):
SERIAL = "it compares the floor apps' redraws with the dashboard's"


@pytest.mark.parametrize("kind", ["bokeh", "panel"])
def test_a_floor_app_draws_three_maps_and_its_slider_redraws_them(kind):
    with served_floor(kind) as (url, _), chromium_browser() as browser:
        page = open_page(browser, url)  # waits for three plot views
        errors = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.evaluate(INSTALL_JS)
        assert page.evaluate("() => window.__bench.views().length") == 3
        assert 100 < page.evaluate(MODELS_JS) < 300  # a minimal page: ~180 models
        before = page.evaluate(PH_VALUE_JS)
        tags = page.evaluate(RESET_JS)
        drag_to(page, 0.3)
        value = settle(page, tags, before, quiet_ms=300)  # three new images, painted
        got_sum, got_n, kind_ = page.evaluate(MAP_A_SUM_JS)
        exp_sum, exp_n = expected_sum(kind, value)
        assert got_n == exp_n == 200 * 200
        assert got_sum == pytest.approx(exp_sum, rel=1e-9)  # map A is the new value's, as computed here
        assert kind_.endswith("(4 B)")  # float32 images, as the dashboard sends
        assert errors == []
        page.close()
