"""Process-wide serving settings (app/server_threads.py)."""

import asyncio
import json
import sys
import threading
import types
import uuid

import numpy as np
import panel as pn
import param
import pytest
from bokeh.core.serialization import Serializer
from bokeh.document import Document
from bokeh.server.views.ws import WSHandler
from param.parameterized import Parameters
from tornado.locks import Lock
from tornado.web import Application as TornadoApp
from tornado.websocket import WebSocketClosedError, websocket_connect

from app import server_threads
from tests.server import close_websocket, free_port


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
    calls = []

    class Handler:
        def set_nodelay(self, value):
            calls.append(("nodelay", value))

    monkeypatch.setattr(server_threads, "_BOKEH_OPEN", lambda self: calls.append(("bokeh open", self)))
    server_threads.configure()
    handler = Handler()
    WSHandler.open(handler)
    assert calls == [("nodelay", True), ("bokeh open", handler)]


def _patch_events(doc, change):
    """The document events of ``change()`` on a document whose models the browser already has."""
    doc.models.flush_synced()
    events = []
    doc.on_change(events.append)
    change()
    doc.remove_on_change(events.append)
    return events


def _patch(serializer, events):
    """Bokeh's PATCH-DOC message of ``events``, encoded with ``serializer`` (a class)."""
    module = server_threads._PATCH_DOC_MODULE
    bokeh_serializer, module.Serializer = module.Serializer, serializer
    try:
        return module.patch_doc.create(events)
    finally:
        module.Serializer = bokeh_serializer


def _message(serializer, doc, events):
    """A PATCH-DOC message as comparable data (:func:`_comparable`) and the models it leaves as not
    yet synced; the document's state is put back afterwards."""
    new = set(doc.models._new_models)
    msg = _patch(serializer, events)
    left_new = set(doc.models._new_models)
    doc.models._new_models = new
    return (*_comparable(msg), left_new)


def _comparable(msg):
    """A message's content with its buffers' ids (drawn from a global counter) replaced by their
    position, and the buffers' bytes."""
    text = json.dumps(json.loads(msg.content_json), sort_keys=True)
    for i, buffer in enumerate(msg.buffers):
        text = text.replace(buffer.id, f"buffer-{i}")
    return text, [bytes(b.to_bytes()) for b in msg.buffers]


def _document():
    from bokeh.models import Column, ColumnDataSource, Div, Slider

    sliders = [Slider(start=0, end=10, value=1, title=f"s{i}") for i in range(300)]
    source = ColumnDataSource(dict(image=[np.zeros((3, 3), np.float32)]))
    column = Column(children=[*sliders, Div(text="a")], tags=[source])
    doc = Document()
    doc.add_root(column)
    return doc, sliders, source, column


def test_patch_messages_are_bokehs_own_with_references_looked_up():
    # Bokeh builds a reference for every model of the document before each message; the
    # replacement looks them up when met. The messages must be the same: a plain value, an
    # array (binary buffer), a model the browser already has, and a new model (sent in full,
    # then counted as synced).
    from bokeh.models import Div

    doc, sliders, source, column = _document()

    def change():
        sliders[0].value = 5
        source.data = dict(image=[np.arange(9, dtype=np.float32).reshape(3, 3)])
        column.children = [*column.children[:-1], Div(text="new"), sliders[1]]

    events = _patch_events(doc, change)
    assert doc.models._new_models  # the new Div
    ours, bokehs = _message(server_threads._SyncedSerializer, doc, events), _message(Serializer, doc, events)
    assert ours == bokehs
    assert ours[2] == set()  # the new Div was sent in full: synced from now on
    assert '"text": "new"' in ours[0] and len(ours[1]) == 1


def test_patch_messages_are_encoded_with_the_synced_serializer_once_configured():
    server_threads.configure()
    assert server_threads._PATCH_DOC_MODULE.Serializer is server_threads._SyncedSerializer


def test_a_patch_message_does_not_build_a_reference_for_every_model(monkeypatch):
    from bokeh.model import Model

    doc, sliders, _, _ = _document()
    events = _patch_events(doc, lambda: setattr(sliders[7], "value", 3))
    built = []
    bokeh_ref = Model.ref
    monkeypatch.setattr(Model, "ref", property(lambda self: built.append(self) or bokeh_ref.fget(self)))
    _patch(server_threads._SyncedSerializer, events)
    assert len(built) <= 2  # the changed slider's, in the event (Bokeh's own: all ~300)
    built.clear()
    _patch(Serializer, events)
    assert len(built) > 300  # what the test guards against


def test_a_widget_update_works_out_the_design_only_for_stylesheets(monkeypatch):
    from panel.theme import Bootstrap

    widget = pn.widgets.FloatSlider(design=Bootstrap)
    events = []
    widget.param.watch(lambda *e: events.extend(e), ["value", "stylesheets"])
    widget.value = 0.5
    widget.stylesheets = [":host {color: red}"]
    doc = Document()
    sheets = lambda update: [getattr(s, "url", s) for s in update(widget, events[1], doc=doc)["stylesheets"]]
    assert sheets(server_threads._update_properties) == sheets(server_threads._PANEL_UPDATE_PROPERTIES)
    assert len(sheets(server_threads._update_properties)) > 2  # the theme's sheets, and the widget's
    worked_out = []
    monkeypatch.setattr(Bootstrap, "params", lambda *a, **k: worked_out.append(a) or ({}, None))
    assert server_threads._update_properties(widget, events[0], doc=doc) == {"value": 0.5}
    assert worked_out == []
    server_threads._PANEL_UPDATE_PROPERTIES(widget, events[0], doc=doc)
    assert worked_out  # Panel's own: for a value alone


def test_curdoc_patches_of_two_threads_do_not_see_each_other():
    # A page is built on a thread of its own while the loop runs other sessions' callbacks, each
    # under Bokeh's patch_curdoc: with one stack for the process, either could get the other's
    # document. After build_pages_off_loop() each thread has its own.
    from bokeh.io.doc import curdoc, patch_curdoc

    server_threads.build_pages_off_loop()
    docs, seen = [Document(), Document()], {}
    inside = threading.Barrier(2)

    def use(i):
        with patch_curdoc(docs[i]):
            inside.wait(10)  # both patched at once
            seen[i] = curdoc()
            inside.wait(10)

    workers = [threading.Thread(target=use, args=(i,)) for i in range(2)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    assert seen[0] is docs[0] and seen[1] is docs[1]


def test_a_pulled_document_is_bokehs_own_reply_encoded_off_the_event_loop(monkeypatch):
    # A browser's first request (PULL-DOC) is answered with the whole document, encoded on a
    # thread of its own (send_pages_off_loop) rather than on the event loop.
    from bokeh.protocol import Protocol

    doc, _, _, _ = _document()
    threads = []
    protocol = Protocol()
    create = protocol.create
    monkeypatch.setattr(protocol, "create", lambda *a: threads.append(threading.current_thread().name) or create(*a))
    connection = types.SimpleNamespace(protocol=protocol)
    session = types.SimpleNamespace(document=doc, destroyed=False, _pending_writes=None,
                                    _lock=Lock(),
                                    block_expiration=lambda: None, unblock_expiration=lambda: None)
    request = types.SimpleNamespace(header={"msgid": "42"})
    reply = asyncio.run(server_threads._handle_pull(session, request, connection))
    assert threads and threads[0].startswith("page-send")
    assert _comparable(reply) == _comparable(create("PULL-DOC-REPLY", "42", doc))
    assert reply.header["reqid"] == "42"


class _Frames(WSHandler):
    """Bokeh's websocket handler without its session set-up. When it opens it sends one
    Bokeh-shaped message (two text frames, a dict, a binary frame) through ``write`` (Bokeh's
    method or the patched one), and notes whether the event loop got a turn during the writes."""

    compress = False
    write = None
    report = None

    def prepare(self):
        pass

    def check_origin(self, origin):
        return True

    def select_subprotocol(self, subprotocols):
        return None

    def get_compression_options(self):
        return {} if self.compress else None

    async def open(self):
        turned = []
        asyncio.get_running_loop().call_soon(turned.append, True)
        async with self.write_lock:
            for part, binary in (('{"msgtype":"PATCH-DOC"}', False), ("{}", False), ({"a": [1, 2]}, False),
                                 (b"\x00\x01binary" * 100, True)):
                await type(self).write(self, part, binary, locked=False)
        await type(self).write(self, "after, locked", False)
        type(self).report.append(bool(turned))
        self.close()

    def on_close(self):
        type(self).closed.set()


async def _frames_received(write, compress):
    report = []
    handler = type("H", (_Frames,), dict(write=write, compress=compress, report=report, closed=asyncio.Event()))
    port = free_port()
    server = TornadoApp([("/ws", handler, dict(application_context=None, bokeh_websocket_path="/ws"))]).listen(port, address="127.0.0.1")
    try:
        conn = await websocket_connect(f"ws://127.0.0.1:{port}/ws",
                                       compression_options={} if compress else None)
        frames = []
        while (msg := await conn.read_message()) is not None:
            frames.append(msg)
        await close_websocket(conn)
        await asyncio.wait_for(handler.closed.wait(), 10)  # the server's end is closed too
        return frames, report
    finally:
        server.stop()


@pytest.mark.parametrize("compress", [False, True])
def test_frames_written_at_once_are_the_same_frames_without_turns_of_the_event_loop(compress):
    # Bokeh's write (through Tornado's, which wraps each frame in a task) gave the loop a turn per
    # frame, with the session's document lock held; the patched write sends the same frames and
    # completes without one when the socket takes the bytes at once.
    bokeh_frames, bokeh_turned = asyncio.run(_frames_received(server_threads._BOKEH_WRITE_MESSAGE, compress))
    ours, ours_turned = asyncio.run(_frames_received(server_threads._write_message_at_once, compress))
    assert ours == bokeh_frames
    assert ours[:3] == ['{"msgtype":"PATCH-DOC"}', "{}", '{"a": [1, 2]}']
    assert ours[3] == b"\x00\x01binary" * 100 and ours[4] == "after, locked"
    assert bokeh_turned == [True] and ours_turned == [False]
    server_threads.configure()
    assert WSHandler.write_message is server_threads._write_message_at_once


def test_a_frame_for_a_closed_websocket_raises_what_bokeh_catches():
    handler = types.SimpleNamespace(ws_connection=None, write_lock=Lock())
    with pytest.raises(WebSocketClosedError):
        asyncio.run(server_threads._write_message_at_once(handler, "x"))


def _watched():
    """A Parameterized with ~40 parameters, an event parameter and a watcher that records."""

    class Many(param.Parameterized):
        a = param.Number(1.0)
        b = param.Number(2.0, bounds=(0, 10))
        go = param.Event()
        locals().update({f"p{i}": param.Integer(i) for i in range(36)})

    obj, seen = Many(), []
    obj.param.watch(lambda *events: seen.append([(e.name, e.old, e.new, e.type) for e in events]),
                    ["a", "b", "go", "p3"])
    return obj, seen


@pytest.mark.parametrize("update", [dict(a=5.0, b=3.0), dict(go=True, a=7.0), dict(p3=9, a=1.0)])
def test_a_param_update_is_params_own_reading_only_what_it_sets(update, monkeypatch):
    ours, params_own = _watched(), _watched()
    restore = server_threads._update(ours[0].param, update)
    assert restore == server_threads._PARAM_UPDATE(params_own[0].param, update)
    assert restore == {k: getattr(_watched()[0], k) for k in update}  # the old values
    assert ours[1] == params_own[1] and ours[1]  # the same events, batched the same way
    assert ours[0].param.values() == {**params_own[0].param.values(), "name": ours[0].name}
    read = []
    own_read = Parameters.get_value_generator
    monkeypatch.setattr(Parameters, "get_value_generator",
                        lambda self_, name, *a: read.append(name) or own_read(self_, name, *a))
    server_threads._update(ours[0].param, update)
    assert sorted(read) == sorted(update)
    read.clear()
    server_threads._PARAM_UPDATE(ours[0].param, update)
    assert len(read) == 40  # param's own reads them all: what the patch removes


def test_a_param_update_refuses_what_params_own_refuses():
    outcomes = []
    for update in (server_threads._update, server_threads._PARAM_UPDATE):
        obj, seen = _watched()
        with pytest.raises(ValueError, match="'nope' is not a parameter"):
            update(obj.param, dict(a=4.0, nope=1))
        with pytest.raises(ValueError, match="must be at most 10"):
            update(obj.param, dict(b=99.0))
        obj.param.update(a=6.0)  # batching was switched off again: the watcher runs
        assert obj.a == 6.0 and seen and seen[-1][-1] == ("a", 4.0, 6.0, "changed")
        outcomes.append((obj.a, obj.b, seen))
    assert outcomes[0] == outcomes[1]


def test_param_updates_read_only_what_they_set_once_configured():
    server_threads.configure()
    # A param other than 2.4 keeps its own (the copy is of 2.4's): this fails to say so.
    assert param.__version__.startswith("2.4.") and Parameters._update is server_threads._update
    obj, seen = _watched()
    with obj.param.update(a=3.0):  # the context form restores what the patched update returns
        assert obj.a == 3.0
    assert obj.a == 1.0 and [e[0][:3] for e in seen] == [("a", 1.0, 3.0), ("a", 3.0, 1.0)]
