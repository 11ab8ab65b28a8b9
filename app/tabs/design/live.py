"""The Layout design map follows a dragged station (issue 38): previews while the hand moves,
the exact map on the drop.

Bokeh's point-draw tool moves a dragged station in the page's data source in place and sends
the source to the server only on the drop. While the hand moves, the path here, through public
Bokeh and HoloViews only:

* in the browser, a ``CustomJS`` on the design figure's ``pan`` events (``js_on_event``,
  attached by a HoloViews ``hooks`` function of the station layer, :meth:`StationDrag.hook`)
  reads the stations' x and y from that source: BokehJS hands each pan to the active tool (the
  point-draw tool, which moves the point) before it triggers the figure's ``Pan`` event. A
  layout that differs from the last one goes into the page's closed loop to this tab's own
  :class:`app.kit.drag.Drag` (:data:`app.kit.drag.LOOP_JS`: sent once the server has answered the
  previous one, at most one every THROTTLE_MS; the latest waiting layout replaces older ones);
  ``panend`` drops what waits (the drop reaches the server through the point-draw tool);
* on the server, Bokeh's ``on_change`` of that model runs :meth:`StationDrag.changed` on the
  event loop as the message arrives. The layout is read as a drop would read it
  (:func:`app.tabs.design.compute.drawn_stations`: a moved station keeps its depth) and checked as the
  scenario checks it; its map is computed off the loop (:func:`app.tabs.design.compute.design`) at
  PREVIEW_N² points (fewer when one takes longer than PREVIEW_BUDGET_S: :func:`app.kit.drag.next_n`),
  one at a time per session, the latest layout next. It is drawn into layers of the figure's
  own, added by the hook above the HoloViews map's layers and under the stations: the error
  (float32, coloured in the browser by the map's own colour mapper, whose range, and so the
  colour bar, become the preview's), its marks (uint8: veil, runaway dots) and a label
  "Preview while dragging (grid n × n)". Each layout is answered (``Drag.ready``, in the same
  message as its preview): drawn, replaced or refused;
* on the drop (:meth:`StationDrag.dropped`, in one ``pn.io.hold()`` with the layout's setting
  by app/tabs/design/design.py) previews still computing are dropped, the preview layers hidden and the
  colour mapper's range set back to the exact map's; then the layout is set on the scenario,
  which redraws the exact map through HoloViews as any change does (images and colour range).
  A drop that leaves the layout as it was (the hand came back, or it is refused) shows the
  exact map as it was.

The previews never go through the HoloViews plot: its data sources hold the exact map only, so
the drop's redraw is the tab's usual one.
"""

from __future__ import annotations

import asyncio
import math
import time
import weakref
from functools import partial

import panel as pn
from bokeh.models import (ColumnDataSource, CustomJS, GlyphRenderer, HoverTool, Image, Label,
                          LinearColorMapper)

from app.kit import offloop, views
from app.kit.drag import LOOP_JS, PATIENCE_MS, PREVIEW_N, PREVIEWS, THROTTLE_MS, answer, drag_model, next_n
from app.state.parts import MAX_STATIONS, Stations
from app.state.snapshot import Snapshot
from . import compute as design_compute
from .compute import ERROR_MAP_READS, drawn_stations

#: Previews of every session's design map, off the event loop.
_PREVIEWS = offloop.pool("design-previews", 2)

#: The name of the preview layers' renderers and data sources (tests and the benchmark find
#: them by it).
PREVIEW_NAME = "design-preview"
#: The start of the label over a preview.
PREVIEW_LABEL = "Preview while dragging"

#: On the design figure's ``panstart`` (``source``: the stations' data source): the layout as
#: the pan starts.
START_JS = LOOP_JS + """
loop.stations = [Array.from(source.data.x), Array.from(source.data.y)];
"""
#: On its ``pan``: the layout, if a station moved, into the loop.
PAN_JS = LOOP_JS + """
const now = [Array.from(source.data.x), Array.from(source.data.y)];
const last = loop.stations;
const same = last !== undefined && last[0].length === now[0].length &&
  now[0].every((v, i) => v === last[0][i] && now[1][i] === last[1][i]);
if (!same) { loop.stations = now; loop.offer("stations", now); }
"""
#: On its ``panend``: nothing more to send (the drop goes through the point-draw tool).
END_JS = LOOP_JS + """
if (loop.pending !== null && loop.pending[0] === "stations") loop.drop();
loop.stations = undefined;
"""


def _empty():
    return dict(image=[], x=[], y=[], dw=[], dh=[])


class Layers:
    """The preview layers of one design figure (``exact``: the HoloViews map's error layer): the
    error (coloured by the map's own colour mapper, read by the map's hover), its marks and a
    label saying it is a preview.

    Only the colour mapper is shared with the HoloViews plot (the colour bar must show the
    preview's range): HoloViews compares the mapper's range with its own before it sets it, so
    the exact map's redraw sets it back. The plot's title is not touched: HoloViews sets a title
    only when its own idea of it changed, so a title the preview had changed stayed."""

    def __init__(self, fig, exact):
        self.fig, self.exact = fig, exact  # the HoloViews map's error layer
        self.mapper = mapper = exact.glyph.color_mapper
        self.error = GlyphRenderer(
            name=PREVIEW_NAME, visible=False,
            data_source=ColumnDataSource(data=_empty(), name=PREVIEW_NAME),
            glyph=Image(image="image", x="x", y="y", dw="dw", dh="dh", color_mapper=mapper))
        self.marks = GlyphRenderer(
            name=PREVIEW_NAME + "-marks", visible=False,
            data_source=ColumnDataSource(data=_empty(), name=PREVIEW_NAME + "-marks"),
            glyph=Image(image="image", x="x", y="y", dw="dw", dh="dh",
                        color_mapper=LinearColorMapper(palette=list(views.MARK_COLOURS), low=0, high=2)))
        self.label = Label(x=0, y=0, text="", visible=False, name=PREVIEW_NAME + "-label",
                           text_font_size="12px", text_color="#b03a2e", text_baseline="top",
                           background_fill_color="white", background_fill_alpha=0.85)
        fig.add_layout(self.label)
        self.exact_range = None  # the colour mapper's range before the preview (the exact map's)
        # the map's hover reads the preview while one is shown: the exact layer is swapped for
        # it in the hover's renderers (a change of which removes the tooltip of a renderer no
        # longer listed; hidden, the exact layer left its last tooltip on the page)
        self.hovers = [(hover, list(hover.renderers)) for hover in fig.select(type=HoverTool)
                       if isinstance(hover.renderers, list) and exact in hover.renderers]

    def show(self, arrays, n):
        error, marks, (low, high) = arrays
        if self.exact_range is None:
            self.exact_range = (self.mapper.low, self.mapper.high)
        self.error.data_source.data = error
        self.marks.data_source.data = marks
        self.mapper.update(low=low, high=high)
        x0, y0, w, h = error["x"][0], error["y"][0], error["dw"][0], error["dh"][0]
        self.label.update(x=x0 + 0.02 * w, y=y0 + 0.98 * h, visible=True,
                          text=f"{PREVIEW_LABEL} (grid {n} × {n}): the exact map on release")
        self.error.visible = self.marks.visible = True
        for hover, renderers in self.hovers:
            hover.renderers = [self.error if r is self.exact else r for r in renderers]

    @property
    def shown(self):
        return self.error.visible

    def hide(self):
        """No preview: the exact map's colour range back (the layout set next redraws the map
        with its own, if it changed)."""
        if self.exact_range is not None:
            self.mapper.update(low=self.exact_range[0], high=self.exact_range[1])
            self.exact_range = None
        self.error.visible = self.marks.visible = self.label.visible = False
        for hover, renderers in self.hovers:
            hover.renderers = renderers


class StationDrag:
    """Previews of one session's Layout design map while a station is dragged (module
    docstring). ``scenario``: the session's; ``quantity()``: the map's error quantity;
    ``doc``: the session's document (None outside a server)."""

    def __init__(self, scenario, quantity, doc):
        self.scenario, self.quantity, self.doc = scenario, quantity, doc
        self.drag = drag_model()
        self.drag.on_change("state", self.changed)
        self.pending = None  # the latest (stations, seq) not yet computed
        self.computing = False
        self.generation = 0  # a drop starts a new one: previews of an older one are not drawn
        self.drawn = 0  # previews drawn (for tests and the benchmark)
        self.preview_n = PREVIEW_N
        self.layers = weakref.WeakKeyDictionary()  # figure -> its Layers
        if doc is not None and doc.session_context is not None:
            doc.on_session_destroyed(lambda _ctx: self.close())

    # -- the figure ---------------------------------------------------------------------------
    def hook(self, plot, element):
        """A HoloViews ``hooks`` function of the station layer (``plot.state``: the design
        figure; ``plot.handles['source']``: the stations' data source): once per figure, the
        pan callbacks and the preview layers, placed right above the map's image layers."""
        fig, source = plot.state, plot.handles.get("source")
        if not PREVIEWS or source is None or fig in self.layers or self.scenario is None:
            return
        images = [r for r in fig.renderers if isinstance(r, GlyphRenderer) and isinstance(r.glyph, Image)]
        if not images:
            return
        layers = self.layers[fig] = Layers(fig, images[0])
        at = list(fig.renderers).index(images[-1]) + 1
        fig.renderers = [*fig.renderers[:at], layers.error, layers.marks, *fig.renderers[at:]]
        args = dict(drag=self.drag, source=source, throttle=THROTTLE_MS, patience=PATIENCE_MS)
        fig.js_on_event("panstart", CustomJS(args=args, code=START_JS))
        fig.js_on_event("pan", CustomJS(args=args, code=PAN_JS))
        fig.js_on_event("panend", CustomJS(args=args, code=END_JS))

    # -- the layouts the page sends -----------------------------------------------------------
    def changed(self, _attr, _old, new):
        if self.scenario is None or not isinstance(new, list) or len(new) != 4 or not isinstance(new[2], int):
            return
        name, value, seq, _released = new
        stations = self.layout(value) if name == "stations" else None
        if stations is None:
            answer(self.drag, seq)
            return
        if self.pending is not None:  # replaced by a newer layout: answered with it
            answer(self.drag, self.pending[1])
        self.pending = (stations, seq)
        if not self.computing:
            self._start()

    def layout(self, value):
        """The layout (S, 3) the page's x and y columns say, read as a drop would read it; None
        when the scenario would refuse it."""
        try:
            xs, ys = value
            ok = len(xs) == len(ys) and 1 <= len(xs) <= MAX_STATIONS and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                for v in (*xs, *ys))
        except (TypeError, ValueError):
            return None
        if not ok:
            return None
        st = self.scenario.stations
        stations = drawn_stations({"x": xs, "y": ys}, st.stations, st.h)
        return None if Stations.problem("stations", stations) else stations

    def _start(self):
        stations, seq = self.pending
        self.pending, self.computing = None, True
        fine = int(self.scenario.value("resolution"))  # the exact map's grid: the marks' dots its size
        n = min(self.preview_n, fine)
        # the dragged layout and the preview's grid in place of the scenario's values
        snapshot = Snapshot.of_values(self.scenario, dict(stations=stations, resolution=n), ERROR_MAP_READS)
        future = _PREVIEWS.submit(_preview, snapshot, self.quantity(), fine)
        offloop.schedule(self.doc, partial(self._finish, self.generation, future, n, seq))

    async def _finish(self, generation, future, n, seq):
        try:
            arrays, seconds = await asyncio.wrap_future(future)
        except Exception:  # noqa: BLE001 (a layout the core refuses: no preview)
            arrays = None
        else:
            self.preview_n = next_n(n, seconds)
        self.computing = False
        if self.scenario is None:  # the session ended meanwhile
            return
        # the layers and the answer in one message; on the loop, outside a callback of the
        # document, Bokeh models are changed in pn.io.hold() (app/tabs/maps/live.py does the same)
        with pn.io.hold():
            if arrays is not None and generation == self.generation:
                for layers in list(self.layers.values()):
                    layers.show(arrays, n)
                self.drawn += 1
            answer(self.drag, seq)
            if self.pending is not None:
                self._start()

    # -- the drop -----------------------------------------------------------------------------
    def dropped(self):
        """The drop (or a click adding a station) reached the server, before its layout is set
        (app/tabs/design/design.py, in ``pn.io.hold()`` with the setting, so one message carries both):
        previews still computing or waiting are not drawn, the shown one is hidden and the exact map's colour
        range is back (the layout's exact map, redrawn when it is set, brings its own)."""
        self.generation += 1
        if self.pending is not None:  # not to be computed: answered
            answer(self.drag, self.pending[1])
        self.pending = None
        for layers in list(self.layers.values()):
            layers.hide()

    @property
    def previewing(self):
        """Whether a preview is shown."""
        return any(layers.shown for layers in self.layers.values())

    def close(self):
        """The session ended: cut what the page's callbacks keep (as app.tabs.maps.live.Live.close)."""
        if self.drag is not None:
            self.drag.remove_on_change("state", self.changed)
        self.scenario = self.doc = self.quantity = None


def _preview(snapshot, quantity, fine):
    """(the preview layers' arrays, seconds its compute took): on a worker thread."""
    t0 = time.perf_counter()
    design = design_compute.design(snapshot)
    seconds = time.perf_counter() - t0
    return views.preview_arrays(design, quantity, fine), seconds


__all__ = ["END_JS", "PAN_JS", "PREVIEW_NAME", "START_JS", "Layers", "StationDrag"]
