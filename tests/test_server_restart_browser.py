"""A page left open across a server restart (issue 46, defect 1), in headless Chromium.

The defect: with P_h = 150 set, the server stopped and started again, the old page took 170 and
180 in its box for minutes without a word, its maps still at 150. Now the page says at once that
the server is gone, what to do and that the address keeps the scenario; when the server is back
it offers the reload, which brings back the last applied scenario (P_h = 150, not 180).
"""

import time
from urllib.parse import parse_qs

import pytest

from app.kit.connection import BACK, BANNER_CLASS, RELOAD
from support.page import open_page, type_value, wait_maps, wait_value
from support.server import free_port, served_app, stop

SERIAL = "stops and restarts a server of its own on a fixed port"

#: Seconds the banner may take to appear after the server stops: the websocket closes at once
#: (BokehJS fires connection_lost on its close); 10 s leaves room for a loaded machine.
SAY_AT_ONCE_S = 10.0


def _query(pg):
    return parse_qs(pg.evaluate("() => window.location.search").lstrip("?"))


def test_a_page_left_open_across_a_restart_says_so_and_reloads_the_last_applied_scenario(chromium):
    port = free_port()
    errors = []
    with served_app(port=port) as (url, proc):
        pg = open_page(chromium, url + "/app", errors, console=False)
        wait_maps(pg, lambda maps: len(maps) == 3)
        type_value(pg, "Ph", 150)
        deadline = time.time() + 30
        while _query(pg).get("Ph") != ["150"]:
            assert time.time() < deadline, f"the address did not take Ph=150: {_query(pg)}"
            time.sleep(0.2)
        stop(proc)
        banner = pg.locator(f".{BANNER_CLASS}")
        banner.wait_for(timeout=SAY_AT_ONCE_S * 1000)
        said = banner.inner_text()
        assert "server is gone" in said and "Reload" in said and "address keeps" in said, said
        assert "Ph=150" in said  # the scenario the reload brings back
        type_value(pg, "Ph", 180)  # typed into a dead page: never applied
        assert pg.get_by_role("button", name=RELOAD).count() == 0  # nothing to reload from yet
    with served_app(port=port):
        button = pg.get_by_role("button", name=RELOAD)
        button.wait_for(timeout=60_000)
        assert BACK in banner.inner_text() and "Ph=150" in banner.inner_text()
        button.click()
        pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
        wait_maps(pg, lambda maps: len(maps) == 3)
        wait_value(pg, "Ph", 150.0)  # the last applied scenario, not the 180 typed meanwhile
        assert _query(pg).get("Ph") == ["150"]
        assert pg.locator(f".{BANNER_CLASS}").count() == 0
        pg.close()
    assert errors == [], errors  # no uncaught error in the page, through the restart
