"""Process-wide serving settings (app/server_threads.py)."""

import sys
import threading
import uuid

import panel as pn

from app import server_threads


def test_busy_counter_updates_are_serialised_across_threads():
    # Panel's busy counter lifts and restores read-only flags of its whole state: two worker
    # threads in there at once made an event fail. With the fix, a second thread waits.
    server_threads.serialise_busy_counter()
    event = uuid.uuid4().hex
    done = threading.Event()

    def add():
        pn.state._add_busy_event(event)
        done.set()

    with server_threads._BUSY_LOCK:  # another thread is in the counter
        worker = threading.Thread(target=add)
        worker.start()
        assert not done.wait(0.3), "the busy counter was changed while another thread held it"
    assert done.wait(10)
    worker.join()
    assert pn.state.busy
    pn.state._remove_busy_event(event)
    assert not pn.state.busy


def test_switch_interval_is_short():
    before = sys.getswitchinterval()
    try:
        server_threads.configure()
        assert sys.getswitchinterval() == server_threads.SWITCH_INTERVAL <= 0.001
    finally:
        sys.setswitchinterval(before)
