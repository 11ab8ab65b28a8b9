"""Smoke test of the served dashboard in headless Chromium: the one browser test CI also runs on
the lowest declared versions (``pytest -m smoke``, .ci/run with the constraints file)."""

import pytest

from support.page import chromium_browser
from support.server import served_app
from support.page import type_value, value_of, wait_maps


@pytest.mark.smoke
def test_the_page_draws_three_maps_and_a_typed_value_redraws_them():
    with served_app() as (url, _), chromium_browser() as browser:
        page = browser.new_page(viewport={"width": 1700, "height": 1100})
        errors = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.goto(url + "/app", timeout=120_000)
        page.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=120_000)
        before = wait_maps(page, lambda drawn: len(drawn) == 3, timeout=60)
        type_value(page, "Ph", "250")
        after = wait_maps(page, lambda drawn: len(drawn) == 3 and drawn[0][1] != before[0][1], timeout=60)
        assert float(value_of(page, "Ph")) == 250.0
        # the same maps (a paper figure's map is marked "(paper)" only while its preset holds:
        # P_h = 250 is no longer the paper's Fig. 5)
        plain = lambda drawn: [title.removesuffix(" (paper)") for title, _ in drawn]  # noqa: E731
        assert plain(after) == plain(before)
        page.close()
        assert errors == [], f"browser console errors: {errors}"
