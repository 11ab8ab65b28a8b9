"""Process-wide settings for serving many sessions from threads, and patches of Bokeh's and Panel's
internals that each removed a measured cost (``configure`` is called by app/main.py). Each patch
keeps the library's own function and tests/test_server_threads.py checks it against it."""

from __future__ import annotations

import asyncio
import concurrent.futures
import sys
import threading

import bokeh.io.doc
import panel as pn
import param
import tornado.escape
from bokeh.core.serialization import Serializer
from bokeh.model import Model
from bokeh.protocol.messages.patch_doc import patch_doc
from bokeh.server.session import ServerSession, _needs_document_lock
from bokeh.server.views.ws import WSHandler
from panel.io.application import Application
from panel.io.state import set_curdoc
from panel.reactive import Reactive
from param.parameterized import Parameters, Undefined
from tornado.iostream import StreamClosedError
from tornado.websocket import WebSocketClosedError

#: A map is computed on a worker thread while Panel's Python runs on others; the worker gives up
#: the GIL in every numpy/numba call and, with Python's default 5 ms switch interval, may wait
#: that long to get it back each time (the compute took 3–5× its in-process time inside the
#: server). 0.5 ms lets it resume promptly.
SWITCH_INTERVAL = 0.0005


def _not_counted(self, *args, **kwargs):
    """Stands in for Panel's busy counting (see :func:`drop_process_wide_busy_flag`)."""


def drop_process_wide_busy_flag():
    """Panel counts every event of every session into ``pn.state.busy``, one flag for the whole
    process that only a template's busy indicator reads (``pn.state.sync_busy``); this app has
    none (``busy_indicator=None``: each session has its own spinner). Counting cost ~5 ms of
    Python per browser event (each add or remove lifts and restores the read-only flag of every
    parameter of ``pn.state``; a P_h release with its last drag step took 22 ms of Panel's Python
    with it, 10-15 ms without), and it was not thread-safe: two worker threads
    (``--num-threads``) interleaving there restored "read-only" under each other and the event
    being processed failed with "Read-only parameter 'busy' cannot be modified" (seen in the
    load test: an update never answered). So the events are not counted."""
    cls = type(pn.state)
    for name in ("_add_busy_event", "_remove_busy_event", "_cleanup_busy_counter"):
        setattr(cls, name, _not_counted)


#: Bokeh's own ``WSHandler.open`` (see :func:`send_without_delay`).
_BOKEH_OPEN = WSHandler.open


def _open_without_delay(self):
    self.set_nodelay(True)
    return _BOKEH_OPEN(self)


def send_without_delay():
    """Bokeh writes every message as several websocket frames (header, metadata, content, one per
    binary buffer) and leaves Nagle's algorithm on, so a frame after the first may wait for the
    peer's delayed ACK (40 ms). Seen from the other end: the frames of each message from a Bokeh
    client reached the server 41.7 ms apart (the load test's clients now set TCP_NODELAY, as a
    browser does). The server's own messages to the browser have the same shape, so each
    session's socket sends at once too."""
    WSHandler.open = _open_without_delay


class _SyncedSerializer(Serializer):
    """Bokeh's serializer as ``PATCH-DOC`` messages use it, keeping the set of models the browser
    already has (``references``) as it is: a model's reference is made when it is met, not one for
    each of them up front. (``has_ref`` is Bokeh's: it is only asked about models not synced yet.)"""

    def __init__(self, *, references=frozenset(), **kwargs):
        super().__init__(**kwargs)
        self._synced = references

    def get_ref(self, obj):
        ref = super().get_ref(obj)
        return obj.ref if ref is None and isinstance(obj, Model) and obj in self._synced else ref


#: The module of ``patch_doc`` (``bokeh.protocol.messages.patch_doc`` names the class there).
_PATCH_DOC_MODULE = sys.modules[patch_doc.__module__]


def serialize_only_what_changed():
    """Every message to a browser (``PATCH-DOC``) began with a reference object built for each of
    the document's ~360 models, to recognise the ones the browser already has: 15 % of the time
    the server held the GIL under the load test (``py-spy record --gil``), ~6 messages per map
    update. Bokeh's ``patch_doc.create`` now encodes with :class:`_SyncedSerializer`; the message
    is the same (tests/test_server_threads.py compares them)."""
    _PATCH_DOC_MODULE.Serializer = _SyncedSerializer


#: Panel's own ``Reactive._update_properties`` (see :func:`design_only_for_stylesheets`).
_PANEL_UPDATE_PROPERTIES = Reactive._update_properties


def _update_properties(self, *events, doc):
    if any(event.name == "stylesheets" for event in events):
        return _PANEL_UPDATE_PROPERTIES(self, *events, doc=doc)
    return self._process_param_change({event.name: event.new for event in events})


def design_only_for_stylesheets():
    """Panel works out a widget's design (its theme's style sheets, resolving file paths on
    disk) for every property update and uses it only when the update sets ``stylesheets``: 5 % of
    the GIL time under the load test. It is now worked out only then."""
    Reactive._update_properties = _update_properties


class _PerThreadStack(threading.local):
    """Bokeh's stack of patched ``curdoc()`` documents, one per thread (see :func:`build_pages_off_loop`)."""

    def __init__(self):
        self.items = []

    def append(self, item):
        self.items.append(item)

    def pop(self):
        return self.items.pop()

    def __len__(self):
        return len(self.items)

    def __getitem__(self, index):
        return self.items[index]


#: Builds new sessions' pages, one at a time, off the event loop.
_BUILDER = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="page-build")
#: Panel's own ``Application`` methods (see :func:`build_pages_off_loop`).
_PANEL_SESSION_CREATED = Application.on_session_created
_PANEL_INITIALIZE = Application.initialize_document


async def _on_session_created(self, session_context):
    await _PANEL_SESSION_CREATED(self, session_context)
    doc, loop_thread = session_context._document, threading.get_ident()

    def build():
        with set_curdoc(doc):
            _PANEL_INITIALIZE(self, doc)
        pn.state._thread_id_[doc] = loop_thread  # served from the event loop from now on, as usual

    try:
        await asyncio.wrap_future(_BUILDER.submit(build))
    except Exception:
        doc.clear()  # Bokeh logs the error and builds the page on the loop, as it always did
        raise
    doc._built_off_loop = True


def _initialize_document(self, doc):
    if not getattr(doc, "_built_off_loop", False):
        _PANEL_INITIALIZE(self, doc)


def build_pages_off_loop():
    """Bokeh builds a new session's page (this app's ~360 models: ~2 s of Panel's Python) on the
    event loop, between awaiting the application's ``on_session_created`` and serving the page:
    every open session froze for that long whenever someone opened the dashboard. The page is now
    built on a thread of its own, during ``on_session_created``, which the loop awaits while it
    goes on serving the other sessions (sharing the GIL with the build). Two things that assumed
    the loop's thread are made to hold on another: ``curdoc()``'s stack of patched documents,
    which Bokeh keeps in one list for the process (now one per thread, so a build and the loop's
    callbacks never see each other's document), and the thread Panel records as the document's,
    set back to the loop's once the page is built."""
    if not isinstance(bokeh.io.doc._PATCHED_CURDOCS, _PerThreadStack):
        stack = _PerThreadStack()
        stack.items.extend(bokeh.io.doc._PATCHED_CURDOCS)  # this thread's: called while the app builds
        bokeh.io.doc._PATCHED_CURDOCS = stack
    Application.on_session_created = _on_session_created
    Application.initialize_document = _initialize_document


#: Encodes the documents browsers ask for, off the event loop; a thread of its own, so that a
#: built page is sent without waiting for the pages queued for building after it.
_ENCODER = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="page-send")


def _document_reply(connection, request_id, document):
    """Bokeh's ``PULL-DOC-REPLY``, encoded to JSON here (the loop then only writes it)."""
    msg = connection.protocol.create("PULL-DOC-REPLY", request_id, document)
    msg.header_json, msg.metadata_json, msg.content_json  # noqa: B018 - cached by the message
    return msg


@_needs_document_lock
async def _handle_pull(self, message, connection):
    return await asyncio.wrap_future(_ENCODER.submit(_document_reply, connection, message.header["msgid"],
                                                     self.document))


def send_pages_off_loop():
    """A browser's first websocket message asks for its whole document, which Bokeh encoded on
    the event loop (~360 models; 0.7-0.8 s each in an asyncio debug trace of 12 sessions opening
    at once, every other session waiting). It is encoded on a thread of its own instead, with the
    session's document lock held as in Bokeh's own handler."""
    ServerSession._handle_pull = _handle_pull


#: Bokeh's own ``WSHandler.write_message`` (see :func:`write_frames_at_once`).
_BOKEH_WRITE_MESSAGE = WSHandler.write_message


async def _write_message_at_once(self, message, binary=False, locked=True):
    """Bokeh's ``WSHandler.write_message`` with Tornado's ``WebSocketProtocol13.write_message``
    inlined, less the task it wraps each frame's write in (the frame itself is written at once)."""
    if locked:
        with await self.write_lock.acquire():
            return await _write_message_at_once(self, message, binary, locked=False)
    ws = self.ws_connection
    if ws is None or ws.is_closing():
        raise WebSocketClosedError()
    if isinstance(message, dict):
        message = tornado.escape.json_encode(message)
    message = tornado.escape.utf8(message)
    ws._message_bytes_out += len(message)
    flags = 0
    if ws._compressor:
        message = ws._compressor.compress(message)
        flags |= ws.RSV1
    try:
        await ws._write_frame(True, 0x2 if binary else 0x1, message, flags=flags)
    except StreamClosedError:
        raise WebSocketClosedError() from None


def write_frames_at_once():
    """Bokeh sends a message as 3 or more websocket frames and awaits each write, and Tornado
    wraps each write in a task of its own: each frame costs two turns of the event loop's queue
    (the task's start, then waking the writer), behind everything else queued there, although
    the bytes went to the socket at once. Bokeh holds the session's document lock until its
    writes are done, so under the load test a session's next change waited for them: writes
    p95 290 ms, max 0.7 s, while the lock was held. Now a frame written to the socket at once is
    done at once (awaiting its write still waits when the socket is full, as before)."""
    WSHandler.write_message = _write_message_at_once


#: param's own ``Parameters._update`` (see :func:`update_reads_only_what_it_sets`).
_PARAM_UPDATE = Parameters._update


def _update(self_, arg=Undefined, /, **kwargs):
    """param 2.4's ``Parameters._update``, reading the old values (returned for ``with
    obj.param.update(...)`` to restore) of the parameters it sets rather than of all of them."""
    BATCH_WATCH = self_._BATCH_WATCH
    self_._BATCH_WATCH = True
    self_or_cls = self_.self_or_cls

    base = {}
    if arg is not Undefined:
        base.update(arg)
    base.update(kwargs)

    trigger_params = [k for k in base if k in self_ and hasattr(self_[k], '_autotrigger_value')]
    for tp in trigger_params:
        self_[tp]._mode = 'set'

    existing = self_.objects('existing')
    restore = {k: self_.get_value_generator(k, existing) for k in base if k in existing}

    for (k, v) in base.items():
        if k not in self_:
            self_._BATCH_WATCH = False
            raise ValueError(f"{k!r} is not a parameter of {self_.cls.__name__}")
        try:
            setattr(self_or_cls, k, v)
        except Exception:
            self_._BATCH_WATCH = False
            raise

    self_._BATCH_WATCH = BATCH_WATCH
    if not BATCH_WATCH:
        self_._batch_call_watchers()

    for tp in trigger_params:
        p = self_[tp]
        p._mode = 'reset'
        setattr(self_or_cls, tp, p._autotrigger_reset_value)
        p._mode = 'set-reset'
    return restore


def update_reads_only_what_it_sets():
    """Every ``obj.param.update(...)`` began by reading the value of each of the object's
    parameters (``param.values()``: a widget has ~40, each read through param's descriptors) to
    keep the old values of the few it sets. A slider change goes through ~12 of them (Panel's
    widget, its editable twin, the link to the Scenario and back). Only the parameters set are
    read now: the Python of a P_h release the Scenario refuses went from 11.2 to 7.3 ms
    (``python -m bench.bench_events``). The update is otherwise param's own
    (tests/test_server_threads.py runs both on the same objects)."""
    if param.__version__.startswith("2.4."):  # the version this copy was taken from
        Parameters._update = _update


def configure():
    sys.setswitchinterval(SWITCH_INTERVAL)
    drop_process_wide_busy_flag()
    send_without_delay()
    serialize_only_what_changed()
    design_only_for_stylesheets()
    build_pages_off_loop()
    send_pages_off_loop()
    write_frames_at_once()
    update_reads_only_what_it_sets()
