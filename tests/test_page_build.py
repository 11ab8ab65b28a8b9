"""A new session's page (issue 40 item 3): built in parts, carrying only what it shows.

Bokeh runs a new session's script in one step of the server's event loop, which every other
session of the process waits for. The page's first step builds the Maps tab and the frame of the
page; the sidebar's parts (the paper-figure buttons, each card, the downloads) are built after it,
one per turn of the loop (``app.page.in_parts``). The served page is still whole when the
client has it. Nothing here is timed: ``python -m bench.bench_page_build`` measures the steps.
"""

from __future__ import annotations

import panel as pn
import pytest

from app.page import SECTIONS, create_app, panel_extension
from app.state.applies import MAPS_TAB, applies
from app.state.scenario import Scenario

#: Runs alone, after the rest (``pytest -m serial``; tests/conftest.py):
SERIAL = "it measures what a page build holds the event loop for"

#: The Bokeh models of a new page (the client's document once the page is complete). Measured
#: 316 with Panel 1.9.4 / Bokeh 3.9.2 (340 with the maps' preview layers, now made on the first
#: drag; 368 when every input of the open cards was built, those that do not apply hidden); the
#: bound leaves room for a small addition, not for the 24 models of the preview layers or the ~28
#: of the inputs that do not apply to come back.
MAX_MODELS = 330


def probe():
    """Serve the page in this process, open one session as a client does (bench.load_test's
    Client: pulled, announced ready, until every input of the open cards and the three maps are
    there) and print what the checks read. In a process of its own: the server's threads would
    meet pytest's warnings-as-errors."""
    from bench.bench_page_build import wait_served
    from bench.load_test import SIDEBAR_INPUTS, Client
    from support.server import close_client, free_port, on_thread, report

    panel_extension()
    first_step = []

    def app():
        template = create_app()
        # what the session's script built before returning: the sidebar comes in later turns
        first_step.append(len(template.built_later.objects))
        return template

    port = free_port()
    server = pn.serve({"app": app}, port=port, address="127.0.0.1", threaded=True, show=False,
                      websocket_origin=[f"127.0.0.1:{port}"], num_threads=4)
    wait_served(f"http://127.0.0.1:{port}/app", timeout=300)  # the server thread is listening
    first_step.clear()  # that request's session is not the one checked
    client = on_thread(Client, f"http://127.0.0.1:{port}")
    out = {"first_step": first_step, "complete": client is not None}
    if client is not None:
        present = {c for m in client.doc.models for c in (getattr(m, "css_classes", None) or [])}
        out.update(models=len(list(client.doc.models)),
                   missing=[n for n in SIDEBAR_INPUTS if f"w-{n}" not in present],
                   presets="w-preset-5" in present, downloads="w-download-csv" in present,
                   previews=sum(getattr(m, "name", None) == "map-preview" for m in client.doc.models))
        on_thread(close_client, client)
    report(out)
    server.stop()


def test_a_served_page_builds_its_sidebar_after_the_first_step_and_arrives_whole():
    from support.server import run_probe

    out = run_probe("tests.test_page_build")
    assert out["first_step"] == [0]
    assert out["missing"] == [] and out["presets"] and out["downloads"]
    assert out["models"] <= MAX_MODELS, out["models"]
    # the maps' preview layers are made on the first drag (app/tabs/maps/figures.add_previews; a drag
    # draws into them: tests/test_live.py, tests/test_drag_browser.py)
    assert out["previews"] == 0


@pytest.mark.filterwarnings(  # Panel 1.9 deprecates button_type/button_style (as test_visuals)
    "ignore:.*deprecated and will be removed in version 2.0:PendingDeprecationWarning")
def test_outside_a_server_the_page_is_built_at_once():
    template = create_app()
    assert len(template.built_later.objects) == len(SECTIONS) + 4  # presets, message, cards, downloads, study
    s = Scenario().snapshot()
    shown = [n for _, names, collapsed in SECTIONS if not collapsed for n in names if applies(n, s, MAPS_TAB)]
    classes = {c for o in pn.Column(*template.sidebar).select() for c in (getattr(o, "css_classes", None) or [])}
    assert all(f"w-{n}" in classes for n in shown)


if __name__ == "__main__":
    from support.server import probe_main

    probe_main(probe)
