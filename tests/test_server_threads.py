"""Process-wide serving settings (app/server_threads.py)."""

import sys
import threading
import uuid

import panel as pn

from app import server_threads


def test_events_are_not_counted_into_the_process_wide_busy_flag():
    # Panel's counting made every event pay ~5 ms of Python, and two worker threads in it at once
    # made an event fail. After configure() nothing is counted, from any number of threads.
    server_threads.drop_process_wide_busy_flag()
    errors = []

    def hammer():
        try:
            for _ in range(200):
                event = uuid.uuid4().hex
                pn.state._add_busy_event(event)
                assert not pn.state.busy and not pn.state._busy_counter
                pn.state._remove_busy_event(event)
        except Exception as exc:  # noqa: BLE001 - any failure is the test's finding
            errors.append(exc)

    workers = [threading.Thread(target=hammer) for _ in range(4)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    assert errors == []
    assert pn.state.busy is False


def test_switch_interval_is_short():
    before = sys.getswitchinterval()
    try:
        server_threads.configure()
        assert sys.getswitchinterval() == server_threads.SWITCH_INTERVAL <= 0.001
    finally:
        sys.setswitchinterval(before)


def test_websockets_send_without_nagle_delay(monkeypatch):
    # Each Bokeh message is several frames; with Nagle on, every frame after the first waited
    # ~40 ms for the peer's delayed ACK. After configure() a session's socket is set to
    # TCP_NODELAY when it opens, before Bokeh's own open runs.
    from bokeh.server.views.ws import WSHandler

    calls = []

    class Handler:
        def set_nodelay(self, value):
            calls.append(("nodelay", value))

    monkeypatch.setattr(server_threads, "_BOKEH_OPEN", lambda self: calls.append(("bokeh open", self)))
    server_threads.configure()
    handler = Handler()
    WSHandler.open(handler)
    assert calls == [("nodelay", True), ("bokeh open", handler)]
