"""A closed session leaves nothing behind on the server (issue 15: memory back to its baseline
after the sessions close).

Panel's ``EditableFloatSlider`` registered a ``jscallback`` in Panel's ``Callback.registry``, which
then kept every closed session's whole page alive (~9 MB each: the served app grew from 371 to
470 MB over 12 sessions that came and went). The probe below runs the app in a Bokeh server in a
process of its own, opens and closes sessions one after the other through a websocket client (as
a browser: the page is pulled, announced ready, a slider released), lets the server destroy them,
and counts the sessions' Scenario objects still alive.
"""

import gc
import subprocess
import sys
import time

from support import ROOT

#: Runs alone, after the rest (``pytest -m serial``; tests/conftest.py):
SERIAL = "it measures the server's resident memory across sessions"

SESSIONS = 4


def probe(sessions=SESSIONS):
    """Print the number of live Scenario objects after each closed session."""
    import panel as pn

    from app.page import create_app, panel_extension
    from app.serve import threads as server_threads
    from app.state.scenario import Scenario
    from bench.load_test import Client
    from support.server import close_client, free_port, on_thread

    server_threads.configure()
    panel_extension()
    port = free_port()
    pn.serve({"app": create_app}, port=port, address="127.0.0.1", threaded=True, show=False,
             websocket_origin=[f"127.0.0.1:{port}"], check_unused_sessions_milliseconds=300,
             unused_session_lifetime_milliseconds=600, num_threads=4)
    url = f"http://127.0.0.1:{port}"

    def session():
        client = Client(url)
        client.change(client.ph, "value_throttled", 50.0, client.maps_done)
        close_client(client)

    for _ in range(sessions):
        on_thread(session)
        time.sleep(3)  # destroyed within ~1 s
        gc.collect()
        print("live", sum(isinstance(o, Scenario) for o in gc.get_objects()), flush=True)


def test_closed_sessions_are_freed():
    out = subprocess.run([sys.executable, "-m", "tests.test_server_memory"], cwd=ROOT,
                         capture_output=True, text=True, timeout=900)
    counts = [int(line.split()[1]) for line in out.stdout.splitlines() if line.startswith("live ")]
    assert len(counts) == SESSIONS, out.stdout + out.stderr[-3000:]
    # At most one: Panel's process-wide busy-counter cleanup (a PeriodicCallback started by
    # whichever session first needs it) keeps the context, hence the page, of that one session.
    # Before the fix every session stayed: 1, 2, 3, 4.
    assert max(counts) <= 1, f"live Scenario objects after each closed session: {counts}"


if __name__ == "__main__":
    from support.server import probe_main

    probe_main(probe)
