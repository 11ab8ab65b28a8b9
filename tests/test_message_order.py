"""An input built by a change from Panel's threads reaches the page in order (app/kit/offloop.py soon).

The sidebar builds an input when it first applies (app/page.py): after the default page,
*Fig. 2* builds the ``layout`` and ``y`` inputs, from a watcher on Panel's threads. Made there,
Panel applied that change as a callback of the document inside its own ``hold``, which writes
its message on a path of its own (queued and retried while the socket is busy, so a later
message could overtake it) and never through the document's change callbacks, which Bokeh's
session (its ordered queue of writes) listens on. The browser then got a later change to those
inputs (their ``visible`` on *Fig. 5*) before the models, said "reference p… isn't known" and
dropped the message: a preset's change lost (docs/dashboard.md).

Here a served page (a websocket client, as tests/test_page_build.py) gets *Fig. 2* from a thread
other than the server's loop, as Panel's threads give it, and the new inputs must arrive through
the document's change callbacks (``Document.on_change``, Bokeh's public API: the same events its
session sends in order), and on the client. Nothing here is timed: conditions are waited for
with long timeouts.
"""

from __future__ import annotations

#: The inputs Fig. 2 builds after the default page (checked against app.state.applies below).
NEW_INPUTS = ("layout", "y")


def probe():
    """Serve the page in this process, connect a client, click Fig. 2 from a thread of ours, and
    print which of the new inputs' models went through the document's change callbacks and which
    reached the client. In a process of its own: the server's threads would meet pytest's
    warnings-as-errors."""
    import threading
    import time

    import panel as pn
    from panel.io.state import set_curdoc

    from bench.bench_page_build import wait_served
    from bench.load_test import Client
    from support.server import close_client, free_port, on_thread, report

    from app.page import create_app, panel_extension

    panel_extension()
    sessions = []  # (document, template, inputs seen in its change callbacks)

    def app():
        template = create_app()
        doc, seen = pn.state.curdoc, set()

        def record(event):  # Bokeh calls it for each change its session sends
            if getattr(event, "attr", None) == "children":
                for child in getattr(event, "new", None) or ():
                    for m in child.references():
                        for css in getattr(m, "css_classes", None) or ():
                            if css.startswith("w-"):
                                seen.add(css[2:])

        doc.on_change(record)
        sessions.append((doc, template, seen))
        return template

    port = free_port()
    server = pn.serve({"app": app}, port=port, address="127.0.0.1", threaded=True, show=False,
                      websocket_origin=[f"127.0.0.1:{port}"], num_threads=4)
    wait_served(f"http://127.0.0.1:{port}/app", timeout=300)
    sessions.clear()  # that request's session is not the one checked
    client = on_thread(Client, f"http://127.0.0.1:{port}")
    out = {"complete": client is not None}
    if client is not None:
        doc, template, seen = sessions[-1]
        before = set(seen)
        button = next(b for b in pn.Column(*template.sidebar).select(pn.widgets.Button)
                      if b.name == "Fig. 2")

        def click():  # as Panel's threads run a click's watchers: off the loop, curdoc set
            with set_curdoc(doc):
                button.clicks += 1

        t = threading.Thread(target=click)
        t.start()
        t.join(300)

        def arrived():
            present = {c for m in client.doc.models for c in (getattr(m, "css_classes", None) or [])}
            return all(f"w-{n}" in present for n in NEW_INPUTS)

        deadline = time.time() + 120  # generous: a loaded machine; the condition ends the wait
        got = False
        while time.time() < deadline and not got:
            got = on_thread(lambda: client._pump(arrived, 5.0), timeout=60) or False
        # the change callbacks ran on the server's loop when the client got the models
        out.update(before=sorted(before & set(NEW_INPUTS)), on_client=got,
                   through_document=sorted(seen & set(NEW_INPUTS)))
        on_thread(close_client, client)
    report(out)
    server.stop()


def test_fig2s_new_inputs_reach_the_page_through_the_documents_ordered_changes():
    from app.state.applies import MAPS_TAB, applies
    from app.state.scenario import Scenario
    from support.server import run_probe

    s = Scenario()
    assert not any(applies(n, s.snapshot(), MAPS_TAB) for n in NEW_INPUTS)  # not on the new page
    s.apply_preset("Fig. 2")
    assert all(applies(n, s.snapshot(), MAPS_TAB) for n in NEW_INPUTS)  # built by Fig. 2

    out = run_probe("tests.test_message_order")
    assert out["before"] == []
    assert out["on_client"], out
    assert out["through_document"] == sorted(NEW_INPUTS), out


if __name__ == "__main__":
    from support.server import probe_main

    probe_main(probe)
