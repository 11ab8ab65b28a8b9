"""A change made while a first start still compiles kernels (issue 46, defect 2), in Chromium.

The defect: in the warm-up's later stages a preset click changed the URL, the buttons and the
sidebar, but not the maps, for over a minute; only the header's spinner showed. Now the maps say
that they are still the previous scenario's, which kernels are still compiling, and an estimate.
The real Maps tab and Warmup class, served by Panel: a held warm-up stage and a held compute
stand for a first start's compiling, so that the test decides when they end."""

from __future__ import annotations

import os
import threading
import time

import panel as pn
import pytest

from app.tabs.maps import maps
from app.kit.cache import SHARED
from app.page import panel_extension
from app.state.scenario import Scenario
from app.serve.warmup import Warmup
from support.page import chromium_browser, wait_maps
from support.server import free_port

pytestmark = pytest.mark.filterwarnings(  # Panel 1.9 deprecates button_type (as test_live)
    "ignore:.*deprecated and will be removed in version 2.0:PendingDeprecationWarning")

HELD = "layered-sea maps (held by the test)"


class HeldCache:
    """The shared cache, but a session's every compute after its first waits for ``release``."""

    def __init__(self, release):
        self.release, self.first = release, True

    def get(self, snapshot, fn):
        if not self.first:
            assert self.release.wait(120), "the test never released the compute"
        self.first = False
        return SHARED.get(snapshot, fn)


def test_maps_waiting_on_the_warm_up_say_they_are_the_previous_scenarios_and_what_compiles():
    stage, compute = threading.Event(), threading.Event()
    warmup = Warmup(stages=(("the default page's maps", lambda: None), (HELD, stage.wait)),
                    out=open(os.devnull, "w"))
    warmup.start()
    panel_extension()

    def page():
        scenario = Scenario()
        tab = maps.maps_tab(scenario, HeldCache(compute), warmup=warmup)
        go = pn.widgets.Button(name="Fig. 2", css_classes=["go"],
                               on_click=lambda e: scenario.apply_preset("Fig. 2"))
        return pn.Column(go, tab)

    port = free_port()
    server = pn.serve({"app": page}, port=port, address="127.0.0.1", show=False, threaded=True,
                      websocket_origin=[f"127.0.0.1:{port}"])
    try:
        with chromium_browser() as browser:
            pg = browser.new_page(viewport={"width": 1600, "height": 1000})
            pg.goto(f"http://127.0.0.1:{port}/app", timeout=60_000)
            pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
            before = wait_maps(pg, lambda drawn: len(drawn) == 3)
            pg.get_by_role("button", name="Fig. 2").click()
            note = pg.locator(".w-compiling .alert")
            note.wait_for(timeout=30_000)
            said = note.inner_text()
            assert "still the previous scenario's" in said and HELD in said, said
            assert "started" in said and " s ago" in said and "quiet 2-core machine" in said, said
            assert "default page's maps" not in said  # a stage that is done is not listed
            assert wait_maps(pg, lambda drawn: len(drawn) == 3) == before  # still the old maps
            stage.set()
            compute.set()
            wait_maps(pg, lambda drawn: "P = (100, 100)" in drawn[1][0], timeout=60)  # Fig. 2's B
            deadline = time.time() + 15
            while note.count() and note.first.is_visible():
                assert time.time() < deadline, "the note stayed after the maps were drawn"
                time.sleep(0.2)
            pg.close()
    finally:
        stage.set()
        compute.set()
        server.stop()
        warmup.out.close()
