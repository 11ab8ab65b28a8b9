"""The Maps tab: maps A, B and their difference for the scenario, redrawn in place on a change."""

from __future__ import annotations

import asyncio
import time
from functools import partial

import numpy as np
import panel as pn
from bokeh.layouts import row

from app.kit import offloop, timings
from app.kit.alerts import alert
from app.kit.runaway import RUNAWAY_LIMIT
from app.kit.tab import Tab
from app.state.applies import MAPS_TAB, applies
from app.state.scenario import defaults
from app.serve.warmup import WARMUP
from app.state.snapshot import Snapshot
from . import downloads, export, live, data as map_data, figures as map_figures
from .compute import READS, compute

#: Seconds a change may compute before the busy spinner shows (each toggle re-styles the page).
BUSY_AFTER = 0.1

#: Width range (px) of each map on the page: at least MAP_MIN_PX (fewer maps per row if need
#: be), at most MAP_MAX_PX.
MAP_MIN_PX, MAP_MAX_PX = 360, 480

#: Pixels kept for the paper-figure banner above the maps, shown or not.
PAPER_HEIGHT = 52

#: Seconds after the maps are sent that ``after_draw`` runs (the URL update: see app.state.url).
URL_AFTER = 0.1

#: Seconds the whole warm-up of a first start takes on a quiet 2-core machine (every kernel:
#: docs/performance.md, "The first start"), for the estimate said while the maps wait for it.
WARMUP_QUIET_S = 140.0
#: Seconds between updates of that note while the maps wait.
WAITING_POLL_S = 2.0


def compiling_text(warmup):
    """What the maps say while a change waits on a first start's warm-up (issue 46 defect 2: a
    preset's maps came over a minute late, the old ones shown under its button without a word):
    that they are the previous scenario's, which kernels are still compiling, and an estimate.
    "" once every stage is ready (or the warm-up failed: the terminal says so)."""
    pending = [what for (what, _), done in zip(warmup.stages, warmup.done) if not done.is_set()]
    if not pending or warmup.started is None or warmup.error:
        return ""
    elapsed = time.monotonic() - warmup.started
    left = WARMUP_QUIET_S - elapsed
    estimate = (f"about {left:.0f} s more on a quiet 2-core machine, longer on a busy one" if left > 10
                else "longer than on a quiet machine: this one is busy")
    return ("These maps are still the previous scenario's: this is the server's first start, and "
            "it is still compiling numerical kernels; the new maps are drawn as soon as theirs are "
            f"ready. Still compiling: {'; '.join(pending)}. The warm-up started {elapsed:.0f} s "
            f"ago; {estimate}.")


#: Computes the maps of every session, off the event loop (core serialises the kernels anyway).
_COMPUTE = offloop.pool("maps", 4)

READING_GUIDE = """
**Reading the maps.** Each map shows, over target positions, a measure of how well the tracking
state (position, velocity, source strengths) can be recovered from the stations' electric-field
measurements. *log10 |det Γ|* is the paper's measure (larger: more observable); it has units and
only compares like with like. The *observability index* log10 η is scale-free (0 best).
The *D-optimal* measure uses every measurement over N instants with the sensor noise;
the *CRLB position error* is the best achievable 1-σ position error in metres, on a log scale
(as on the Layout design tab). Depth z is measured down from the sea surface. Hover for values;
the save tool of each map writes a PNG named after the scenario, with its parameters below it.
All logarithms are base 10.
"""

_SWATCH = 'display:inline-block;width:22px;height:14px;vertical-align:middle;border:1px solid #888;'
#: The runaway marks' swatch: white dots over a map colour, as drawn (app.kit.runaway.runaway_dots).
RUNAWAY_SWATCH = (_SWATCH + "background:radial-gradient(circle,#ffffff 0 2px,transparent 2.5px) 0 0/6px 6px,"
                  "#46327e")


def legend(p=None):
    """What the marks on the maps ``p`` mean (the veil and the blanks are distinct on purpose);
    the runaway dots only when a map has some (CRLB maps only: ``p.runaway``; with no ``p``,
    every entry). It was shown for every measure."""
    runaway = p is None or any(bool(np.any(r)) for r in p.runaway)
    return (
        '<div class="maps-legend" style="font-size:13px;color:#333;display:flex;flex-wrap:wrap;gap:18px">'
        f'<span><span style="{_SWATCH}background:repeating-linear-gradient(45deg,#6b6b6b 0 4px,#b4b4b4 4px 8px)">'
        '</span> unobservable (rank Γ &lt; 7 states; &lt; 8 for a magnetic sensor): the colours beneath '
        'are round-off</span>'
        f'<span><span style="{_SWATCH}background:#fff"></span> no value: on a station, or Δ ≤ 0 (B no better)'
        '</span>'
        + (f'<span class="maps-legend-runaway"><span style="{RUNAWAY_SWATCH}"></span> CRLB &gt; '
           f'{RUNAWAY_LIMIT:.0%} of the range to the nearest station: the bound does not predict a '
           'tracker\'s error (far-field runaway)</span>' if runaway else '')
        + '<span>△ station</span>'
        f'<span><span style="{_SWATCH.replace("border:1px solid #888;", "")}border:3px solid #b03a2e"></span>'
        ' the paper\'s figure</span></div>'
    )


#: Every entry of the legend (for a page that does not follow the measure).
LEGEND = legend()


def _notes(p):
    """The warnings under the maps: unobservable points, then runaway CRLB points."""
    return "\n".join(t for t in (p.note, p.far_note) if t)


#: Where to start, on the page as it opens (a newcomer took the hatched maps for broken).
START = ("Start here: A is one station, B two stations 15 m apart; one station cannot tell range "
         "from source strength (hatched: unobservable), two can. Hover a map for its value; the "
         "buttons on the left load the paper's other figures, the tabs above go on to layouts, "
         "tracking, calibration and sizing.")


#: The maps' inputs as the page opens.
OPENING = {n: v for n, v in defaults().items() if n in READS}


def _paper_line(p):
    if not p.paper[1]:  # no preset, or one that is not a figure of the paper (seed 001's trial)
        return ""
    return alert(f"Paper {p.preset}: {p.paper[1]} (red frame).", "info")


def _opening(scenario):
    """Whether the page is as it opens: every input of the maps at its default."""
    return scenario.inputs(READS) == OPENING


def _remedies(scenario, p):
    """Which remedy buttons apply to maps ``p``: only where a map is veiled."""
    return dict(known=bool(p.note) and not (scenario.sensor.state_set.startswith("moments known")
                                            and p.measure == "d_optimal"),
                crlb=bool(p.note) and p.measure != "crlb_position")


def _panes(scenario, first):
    """The panes around the maps, showing maps ``first``: {name: pane}."""
    # Written by redraw together with the maps (not bound to the scenario: a binding would compute
    # the maps once more, synchronously, before redraw could start).
    note = pn.pane.HTML(alert(_notes(first), "warning"), visible=bool(_notes(first)),
                        sizing_mode="stretch_width", css_classes=["w-note"])
    # The marks' legend, redrawn with the maps: runaway dots only on CRLB maps (issue 25)
    key = pn.pane.HTML(legend(first), sizing_mode="stretch_width", css_classes=["w-legend"])
    # under the maps (above them it would move them when it goes)
    start = pn.pane.HTML(alert(START, "info"), visible=_opening(scenario), sizing_mode="stretch_width",
                         css_classes=["w-start"])
    # Always laid out, at the height of its one-line banner: the maps no longer jump ~45 px when
    # a paper figure's banner comes and goes
    paper = pn.pane.HTML(_paper_line(first), sizing_mode="stretch_width", min_height=PAPER_HEIGHT,
                         css_classes=["w-paper"])
    waiting = pn.pane.HTML("", visible=False, sizing_mode="stretch_width", css_classes=["w-compiling"])
    known = pn.widgets.Button(name="Moments known (5 states), D-optimal measure", button_type="warning",
                              css_classes=["w-remedy-known"],
                              on_click=lambda e: scenario.update(state_set="moments known (5 states)",
                                                                 measure="D-optimal ½·log10 det F"))
    crlb = pn.widgets.Button(name="Show CRLB position error (m)", button_type="warning",
                             css_classes=["w-remedy-crlb"],
                             on_click=lambda e: setattr(scenario.maps, "measure", "CRLB position error (m)"))
    shown = _remedies(scenario, first)
    known.visible, crlb.visible = shown["known"], shown["crlb"]
    return dict(note=note, key=key, start=start, paper=paper, waiting=waiting, known=known, crlb=crlb)


class _Maps:
    """One session's Maps tab kept current: a change of the maps' inputs computes them on a
    worker thread and draws them in place on the event loop (:meth:`redraw`)."""

    def __init__(self, scenario, cache, busy, after_draw, warmup=WARMUP):
        self.scenario, self.cache, self.busy, self.after_draw = scenario, cache, busy, after_draw
        self.warmup = warmup  # the first start's (compiling_text, said while a change waits on it)
        first = cache.get(Snapshot.of(scenario), compute)
        self.figs = map_figures.build()
        map_figures.fill(self.figs, first)
        self.panes = _panes(scenario, first)
        #: The scenario of the maps drawn or being drawn: a change that ends where it began (a
        #: refused value, restored) sends no maps again (0.5 MB, which held up its message by ~30 ms).
        self.latest = Snapshot.of(scenario)
        self.doc = pn.state.curdoc  # the session document this tab is built for
        timings.watch_arrivals(self.doc)  # where an update's time goes, when APP_TIMINGS asks (app/kit/timings.py)
        # the maps follow a dragged slider: previews until its release (app/tabs/maps/live.py)
        self.follow = live.Live(scenario, self.figs, self.doc, self.exact)
        scenario.watch_inputs(self.redraw, READS)

    def redraw(self, *_):
        # Start computing at once, on a worker thread (the kernels release the GIL): the server's
        # event loop keeps serving other sessions meanwhile, and the compute does not wait for
        # the widget updates already queued on the loop. Then draw, on the loop.
        rec = timings.start(self.doc)
        snapshot = Snapshot.of(self.scenario)
        if rec is not None:
            rec["changed"] = _changed_inputs(self.latest, snapshot)
        if snapshot == self.latest:
            timings.finish(rec, "unchanged")
            return
        self.latest = snapshot
        timings.stamp(rec, "submitted")
        computing = _COMPUTE.submit(self.prepared_maps, snapshot, rec)
        offloop.schedule(self.doc, partial(self.draw, snapshot, computing, rec))  # app.kit.offloop's pattern

    def prepared_maps(self, snapshot, rec):  # on a thread of the maps' pool
        timings.stamp(rec, "started")
        with timings.current(rec):  # the kernel lock's legs (app.tabs.maps.compute.compute)
            prepared = map_data.prepare(self.cache.get(snapshot, compute))
        timings.stamp(rec, "computed")
        return prepared

    async def draw(self, snapshot, computing, rec=None):
        try:
            await self.show_maps(snapshot, computing, rec)
        except BaseException:
            timings.finish(rec, "failed")
            raise
        finally:
            if self.after_draw is not None:
                await asyncio.sleep(URL_AFTER)  # the browser paints the maps first
                await offloop.changes(self.doc, self.after_draw)

    def spinner(self, on):
        self.busy.param.update(value=on, visible=on)

    async def arrived(self, computing):
        """The maps and the arrays to send (map_data.prepare), from the worker; the spinner only
        for a slow change: for a fast one it costs more than it says."""
        maps = asyncio.wrap_future(computing)
        try:
            return await asyncio.wait_for(asyncio.shield(maps), BUSY_AFTER)
        except asyncio.TimeoutError:
            if self.busy is not None:
                await offloop.changes(self.doc, partial(self.spinner, True))
            try:
                return await self.wait_saying(maps)
            finally:
                if self.busy is not None:
                    await offloop.changes(self.doc, partial(self.spinner, False))
                if self.panes["waiting"].visible:
                    await offloop.changes(self.doc, partial(self.say_waiting, ""))

    def say_waiting(self, text):
        self.panes["waiting"].param.update(object=alert(text, "warning") if text else "", visible=bool(text))

    async def wait_saying(self, maps):
        """The maps, saying meanwhile what they wait for while the warm-up is not done."""
        while True:
            text = compiling_text(self.warmup)
            if text or self.panes["waiting"].visible:
                await offloop.changes(self.doc, partial(self.say_waiting, text))
            try:
                return await asyncio.wait_for(asyncio.shield(maps), WAITING_POLL_S)
            except asyncio.TimeoutError:
                continue

    async def show_maps(self, snapshot, computing, rec=None):
        panels = await self.arrived(computing)
        timings.stamp(rec, "resumed")
        # Each session's draw is a callback of its own on the loop (~10 ms of Python): other
        # sessions' events queued meanwhile go between them
        if snapshot != Snapshot.of(self.scenario):  # a newer change draws its own maps
            timings.finish(rec, "superseded")
            return
        # The maps' own Bokeh models in one message, as Panel sends a change made on the
        # loop: they are not changed from Panel's threads, so nothing overtakes them with a
        # model they bring (app/kit/offloop.py). Colour bars and images together: the bars are
        # drawn inside the figures, and sent first, alone, they repainted all three plots
        # with the old images (~20 ms in the browser); through offloop.changes (one message
        # per event) the images were painted up to ~50 ms apart.
        with pn.io.hold():
            map_figures.fill(self.figs, panels)
            timings.stamp(rec, "drawn")
        timings.stamp(rec, "sent")
        timings.finish(rec, "sent")
        self.follow.drawn_exact()
        # the panes under the maps, whose first update brings Panel's stylesheets: in order
        # with the threads' changes
        await offloop.changes(self.doc, partial(self.show, panels))

    def show(self, panels):
        p, panes = panels.panels, self.panes
        panes["note"].param.update(object=alert(_notes(p), "warning"), visible=bool(_notes(p)))
        panes["paper"].object = _paper_line(p)
        panes["start"].visible = _opening(self.scenario)
        panes["key"].object = legend(p)
        now = _remedies(self.scenario, p)
        panes["known"].visible, panes["crlb"].visible = now["known"], now["crlb"]

    def exact(self):  # the exact maps again, of the scenario as it is (previews drawn over them)
        self.latest = None
        self.redraw()


def maps_tab(scenario, cache, *, busy=None, after_draw=None, warmup=WARMUP):
    """The Maps tab of ``scenario``: its layout, kept current by a watcher on the maps' fields.

    ``busy``: a LoadingSpinner shown while a slow change computes; ``after_draw``: called
    ``URL_AFTER`` s after a change's maps are sent (the URL update); ``warmup``: the first
    start's (:func:`compiling_text`, said while a slow change waits on it)."""
    view = _Maps(scenario, cache, busy, after_draw, warmup)
    figs, panes = view.figs, view.panes
    # A row that wraps (public ``styles`` of Bokeh's models, on their elements): three maps
    # across where each gets MAP_MIN_PX (a 1600 px screen), else A and B across and the
    # difference under them (at 1280 × 800 the three in one row had 204 × 189 px frames). At
    # most half the row each: the difference alone on its row is as wide as A and B, so that
    # their shared ranges draw a metre as a metre in all three
    for fig in figs.layout:
        fig.styles = {"flex": f"1 0 {MAP_MIN_PX}px", "min-width": f"{MAP_MIN_PX}px",
                      "max-width": f"min({MAP_MAX_PX}px, 50%)"}
    plots = pn.pane.Bokeh(row(*figs.layout, sizing_mode="stretch_width", styles={"flex-wrap": "wrap"}),
                          sizing_mode="stretch_width")
    tab = pn.Column(panes["paper"], panes["waiting"], plots, panes["start"], panes["key"], panes["note"],
                    pn.Row(panes["known"], panes["crlb"]),
                    pn.pane.Markdown(READING_GUIDE, sizing_mode="stretch_width"),
                    sizing_mode="stretch_width")
    tab.figures = figs  # for tests
    tab.live = view.follow
    return tab


def _changed_inputs(before, after):
    """The inputs whose values differ between two snapshots (name -> the new value), for a timing
    record (app/kit/timings.py); every input when there is no ``before``."""
    old = dict(before.items) if before is not None else {}
    return {n: v for n, v in after.items if n not in old or old[n] != v}


def applied_inputs(scenario):
    """The maps' inputs that apply to them (:func:`app.state.applies.applies` on the Maps tab), as a
    download's header lists them: a header listing the moments of a sensor not used, a seabed
    in the whole space or scenario B's inputs of another comparison misled (the maps' stations
    are written as stations_A_m and stations_B_m)."""
    s = scenario.snapshot()
    return {n: v for n, v in scenario.inputs(READS).items() if applies(n, s, MAPS_TAB)}


def _current(scenario, cache):
    return cache.get(Snapshot.of(scenario), compute), applied_inputs(scenario)


def download_name(scenario, cache, ext):
    """The file name of a download of ``scenario``'s maps (:func:`app.tabs.maps.downloads.download_name`)."""
    return downloads.download_name(cache.get(Snapshot.of(scenario), compute), ext)


def to_csv(scenario, cache):
    """The maps of ``scenario`` as CSV (the download button's file)."""
    return downloads.to_csv(*_current(scenario, cache))


def to_netcdf(scenario, cache):
    """The maps of ``scenario`` as NetCDF (the download button's file)."""
    return downloads.to_netcdf(*_current(scenario, cache))


def to_png(scenario, cache, which=export.ALL):
    """The maps ``which`` (default the three; 0 A, 1 B, 2 the difference) of ``scenario`` as one
    high-resolution PNG (:mod:`app.tabs.maps.export`; the save tool of a map writes its canvas as shown,
    ~200-400 px)."""
    return export.to_png(cache.get(Snapshot.of(scenario), compute), which)


#: The one-map PNG downloads: (label, map index, file name suffix).
MAP_PNGS = (("A", 0, "A"), ("B", 1, "B"), ("B vs A", 2, "difference"))


#: The Maps tab, as the page mounts it (app.kit.tab).
TAB = Tab("maps", "Maps", reads=READS,
          view=lambda m: maps_tab(m.scenario, m.cache, busy=m.busy, after_draw=m.after_draw))
