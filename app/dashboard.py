"""Wiring: one Scenario, widgets generated from its parameters, live maps, the page template."""

from __future__ import annotations

import asyncio
import concurrent.futures
import ctypes
import gc
import html
import json
import threading
from functools import partial

import holoviews as hv
import pandas as pd
import panel as pn
from bokeh.models.widgets.tables import NumberFormatter
from panel.io.state import set_curdoc

from . import compute, map_figures, views
from .compute import DESIGN_FIELDS, FIELDS, PanelCache, Snapshot
from .scenario import MAX_STATIONS, PRESETS, Scenario

#: Sidebar sections: (title, parameters, collapsed?).
SECTIONS = (
    ("View", ["measure", "comparison", "difference", "plane"], False),
    ("Target", ["Ph", "Pv", "speed", "heading", "z", "y"], False),
    ("Stations", ["h", "d", "layout"], False),
    ("Scenario B of Figs. 3, 4, 6", ["k", "Ph_b", "Pv_b", "d_ref"], True),
    ("Advanced", ["model", "state_set", "T", "sigma", "noise", "steps", "extent", "z_min", "z_max",
                  "resolution"], True),
)

READING_GUIDE = """
**Reading the maps.** Each map shows, over target positions, a measure of how well the tracking
state (position, velocity, source strengths) can be recovered from the stations' electric-field
measurements. *log10 |det Γ|* is the paper's measure (larger: more observable); it has units and
only compares like with like. The *observability index* log10 η is scale-free (0 best).
The *D-optimal* measure uses every measurement over N instants with the sensor noise;
the *CRLB position error* is the best achievable 1-σ position error in metres.
Grey veil: rank Γ < 7 — structurally unobservable, the colours there are round-off.
Triangles: stations. Hover for values. All logarithms are base 10.
"""


#: Seconds a change may compute before the busy spinner shows (each toggle re-styles the page).
BUSY_AFTER = 0.1

#: Seconds after the maps are sent that the URL takes the new values (see _sync_url).
URL_AFTER = 0.1

#: Computes the maps of every session, off the event loop (core serialises the kernels anyway).
_COMPUTE = concurrent.futures.ThreadPoolExecutor(max_workers=4, thread_name_prefix="maps")


#: Maps are drawn on the event loop one session at a time, in two steps with a turn of the loop
#: between them. Maps computed at about the same time used to be drawn in one go (~10-20 ms of
#: Python each), and every other session's events waited behind all of them.
_DRAWING = asyncio.Lock()


def _release_freed_memory():
    """Hand memory freed by closed sessions back to the OS (glibc keeps it in its arenas)."""
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):  # not glibc: nothing to do
        pass


def _alert(text, kind):
    """Plain text in a Bootstrap alert box: escaped, never interpreted as HTML or Markdown."""
    fg, bg = {"danger": ("#842029", "#f8d7da"), "warning": ("#664d03", "#fff3cd")}[kind]
    style = f"color:{fg};background:{bg};border:1px solid {fg}33;border-radius:6px;padding:10px 14px"
    return (f'<div class="alert alert-{kind}" role="alert" style="{style}">'
            f'{html.escape(text).replace(chr(10), "<br>")}</div>')


def _widgets():
    """Editable sliders (type a value or drag) for every number; a text box for the noise."""
    numeric = {"type": pn.widgets.EditableFloatSlider, "sizing_mode": "stretch_width", "format": "0.[00]"}
    integer = {"type": pn.widgets.EditableIntSlider, "sizing_mode": "stretch_width"}
    spec = {name: dict(numeric) for name in ("Ph", "Pv", "speed", "heading", "h", "z", "y", "d", "k",
                                                "Ph_b", "Pv_b", "d_ref", "T", "sigma", "extent",
                                                "z_min", "z_max", "threshold")}
    spec.update(steps=dict(integer), resolution=dict(integer))
    spec["noise"] = {"type": pn.widgets.FloatInput, "format": "0.0e+0", "sizing_mode": "stretch_width"}
    for name in Scenario.param:
        if name not in ("name", "message"):  # stable hooks for the browser tests
            spec.setdefault(name, {})["css_classes"] = [f"w-{name}"]
    return spec


DESIGN_HELP = """
**Layout design.** Click on the map to add a station (up to 8), drag one to move it, select it
and press Backspace to delete it; or edit the table. The map is the Cramér–Rao bound (1σ) on
the 3-D position, horizontal, depth or speed error of a target at depth z, with the sensor noise
and N instants of the Advanced section — the numbers an analyst reports. Click a point for its
horizontal error ellipse. *Find best spacing* scans the dual layout's spacing d over this region
and refines the optimum with scipy; *Optimise N-station layout* does the same for a line,
triangle or square of N stations (or free positions, ~10 s) and makes it the custom layout.
"""


def design_tab(scenario, cache):
    """Custom layouts in metres of error, and the best dual-station spacing."""
    snap = lambda: Snapshot.of(scenario, DESIGN_FIELDS)
    watch = [f for f in DESIGN_FIELDS if f != "stations"]
    points = hv.DynamicMap(lambda **_: views.station_layer(scenario.stations),
                           streams=[hv.streams.Params(scenario, ["stations"])])
    draw = hv.streams.PointDraw(source=points, num_objects=MAX_STATIONS, empty_value=scenario.h)

    def drawn(data):
        if data is None or not len(data.get("x", [])):
            return
        scenario.stations = [[float(x), float(y), float(z)]
                             for x, y, z in zip(data["x"], data["y"], data["z"])]

    draw.add_subscriber(drawn)
    errors = hv.DynamicMap(lambda **_: views.error_map(cache.get(snap(), compute.design),
                                                       "Custom layout: Cramér–Rao error", scenario.error_quantity),
                           streams=[hv.streams.Params(scenario, watch + ["stations", "error_quantity"])])
    tap = hv.streams.Tap(source=errors, x=scenario.extent / 3, y=scenario.extent / 3)

    def ellipse(x, y, **_):
        return views.error_ellipse(compute.error_at(snap(), x, y), x, y, scenario.extent)[0]

    def ellipse_text(x, y, *_):
        return views.error_ellipse(compute.error_at(snap(), x, y), x, y, scenario.extent)[1]

    ell = hv.DynamicMap(ellipse, streams=[tap, hv.streams.Params(scenario, watch + ["stations"])])
    table = pn.widgets.Tabulator(
        pn.bind(lambda st: pd.DataFrame(st, columns=["x (m)", "y (m)", "z (m)"]), scenario.param.stations),
        show_index=False, sizing_mode="stretch_width", height=260, css_classes=["w-station-table"],
        formatters={c: NumberFormatter(format="0.0") for c in ("x (m)", "y (m)", "z (m)")})

    def edited(event):
        scenario.stations = table.value.astype(float).values.tolist()

    table.on_edit(edited)
    run = pn.widgets.Button(name="Find best spacing", button_type="primary")

    def spacing(clicks):
        if not clicks:
            return pn.pane.Markdown("Press *Find best spacing* (about a second).")
        sp = cache.get(snap(), compute.best_spacing)
        best = views.error_map(sp.best, f"Best: d = {sp.result.d:.1f} m") * views.station_layer(sp.best.stations)
        paper = views.error_map(sp.paper, "Paper: d = 15 m") * views.station_layer(sp.paper.stations)
        return pn.Column(pn.pane.HoloViews(views.spacing_plot(sp)),
                         pn.Row(pn.pane.HoloViews(best), pn.pane.HoloViews(paper)))

    criteria = pn.Param(scenario, parameters=["criterion", "threshold", "layout_kind", "n_stations"],
                        show_name=False, widgets=_widgets(), sizing_mode="stretch_width")
    optimise = pn.widgets.Button(name="Optimise N-station layout → custom layout", button_type="primary")

    def optimise_clicked(event):
        optimise.loading = True
        try:
            result = cache.get(snap(), compute.optimised_layout)
            scenario.stations = [[float(v) for v in st] for st in result.stations]
        finally:
            optimise.loading = False

    optimise.on_click(optimise_clicked)
    return pn.Column(
        pn.pane.Markdown(DESIGN_HELP, sizing_mode="stretch_width"),
        pn.Row(pn.pane.HoloViews(errors * points * ell),
               pn.Column(pn.Param(scenario, parameters=["error_quantity"], show_name=False, widgets=_widgets()),
                         table, pn.bind(ellipse_text, tap.param.x, tap.param.y, scenario.param.stations),
                         width=380)),
        pn.Row(pn.Column(criteria, run, optimise, width=360), pn.panel(pn.bind(spacing, run.param.clicks))),
        sizing_mode="stretch_width",
    )


def _link_value(raw):
    """A query value as Panel writes them: JSON where it parses, else the plain string."""
    try:
        return json.loads(raw)
    except ValueError:
        return raw


def _link_problem(name, value):
    """None if a link's ``value`` for ``name`` is accepted, else why (tried on a throw-away Scenario)."""
    trial = Scenario()
    try:
        setattr(trial, name, value)
    except Exception:  # param's own type and selector checks
        return f"{name}: {trial.param[name].label} does not accept {str(value)[:40]!r}"
    return f"{name}: {trial.message.removesuffix(' Kept the last good value.').rstrip('.')}" if trial.message else None


def _sync_url(scenario, location, args):
    """The scenario lives in the page URL. A pasted link's values are read here, once, from the
    request (``args``, as pn.state.session_args); any that would be refused is never set (so no
    widget shows it) and the page says which and why. Later changes are written back.

    Returns ``flush``: a change of the maps' values waits in the URL until the maps are drawn
    (redraw calls ``flush``). Each URL update costs the browser ~10 ms and the server an echo of
    the new address to process: ~18 ms of every slider change when it went first."""
    names = sorted(set(FIELDS) | set(DESIGN_FIELDS))
    good, problems = {}, {}
    for name in names:
        if name in args:
            value = _link_value(args[name][0].decode("utf-8", "replace"))
            problem = _link_problem(name, value)
            problems.update({name: problem} if problem else {})
            good.update({} if problem else {name: value})
    scenario.param.update(good)
    pending, lock = {}, threading.Lock()

    def flush():
        with lock:
            query = dict(pending)
            pending.clear()
        if query:
            location.update_query(**query)

    def to_url(*events):
        # The value the scenario holds, not the event's: a refused value's event arrives after the
        # restore of the last good one.
        now = {e.name: getattr(scenario, e.name) for e in events}
        with lock:
            pending.update({name: v if isinstance(v, str) else json.dumps(v) for name, v in now.items()})
        if not any(e.name in FIELDS for e in events):  # no maps to wait for
            flush()

    scenario.param.watch(to_url, names)
    if problems:
        scenario.message = ("Link values refused, defaults kept: " + "; ".join(problems.values()))[:600]
    return flush


def create_app():
    scenario = Scenario()
    cache = PanelCache()

    def session_closed(ctx):
        cache.clear()
        gc.collect()  # the maps of a closed session are large, cyclic Bokeh/param graphs
        _release_freed_memory()

    pn.state.on_session_destroyed(session_closed)

    flush_url = None  # no page URL outside a served page
    if pn.state.location is not None:
        flush_url = _sync_url(scenario, pn.state.location, pn.state.session_args or {})

    presets = pn.FlexBox(*[
        pn.widgets.Button(name=name, button_type="primary", button_style="outline", width=90,
                          on_click=lambda e, n=name: scenario.apply_preset(n))
        for name in PRESETS
    ], sizing_mode="stretch_width")
    message = pn.pane.HTML(pn.bind(_alert, scenario.param.message, "danger"), sizing_mode="stretch_width",
                           visible=scenario.param.message.rx.bool(), css_classes=["w-message"])
    sections = [
        pn.Card(pn.Param(scenario, parameters=names, widgets=_widgets(), show_name=False,
                         sizing_mode="stretch_width"),
                title=title, collapsed=collapsed, sizing_mode="stretch_width")
        for title, names, collapsed in SECTIONS
    ]

    def params():
        return {f: getattr(scenario, f) for f in FIELDS}

    downloads = pn.Row(
        pn.widgets.FileDownload(callback=lambda: views.to_csv(cache.get(Snapshot.of(scenario)), params()),
                                filename="observability_maps.csv", label="CSV", button_type="light"),
        pn.widgets.FileDownload(callback=lambda: views.to_netcdf(cache.get(Snapshot.of(scenario)), params()),
                                filename="observability_maps.nc", label="NetCDF", button_type="light"),
    )

    first = cache.get(Snapshot.of(scenario))
    # Written by redraw together with the maps (not bound to the scenario: a binding would compute
    # the maps once more, synchronously, before redraw could start).
    note = pn.pane.HTML(_alert(first.note, "warning"), visible=bool(first.note), sizing_mode="stretch_width")

    fix_buttons = pn.Row(
        pn.widgets.Button(name="Moments known (5 states), D-optimal measure", button_type="warning",
                          on_click=lambda e: scenario.param.update(state_set="moments known (5 states)",
                                                                   measure="D-optimal ½·log10 det F")),
        pn.widgets.Button(name="Show CRLB position error (m)", button_type="warning",
                          on_click=lambda e: setattr(scenario, "measure", "CRLB position error (m)")),
    )
    doc = pn.state.curdoc  # the session document this app is built for
    figs = map_figures.build()
    map_figures.fill(figs, first)
    #: Spins while a change slower than BUSY_AFTER computes. In the header, a Bokeh root of its own:
    #: its CSS class changes re-lay out only itself, not the maps (which would then all be
    #: repainted). throttle=0: it stops when the maps are ready, not half a second later.
    busy = pn.indicators.LoadingSpinner(value=False, width=24, height=24, css_classes=["w-busy"],
                                        margin=(0, 10), align="center", throttle=0)

    #: The scenario of the maps drawn or being drawn: a change that ends where it began (a refused
    #: value, restored) sends no maps again (0.5 MB, which held up its message by ~30 ms).
    latest = [Snapshot.of(scenario)]

    def redraw(*_):
        # Start computing at once, on a worker thread (the kernels release the GIL): the server's
        # event loop keeps serving other sessions meanwhile, and the compute does not wait for
        # the widget updates already queued on the loop. Then draw, on the loop.
        snapshot = Snapshot.of(scenario)
        if snapshot == latest[0]:
            return
        latest[0] = snapshot
        computing = _COMPUTE.submit(cache.get, snapshot)
        with set_curdoc(doc):  # this session's: on a Panel worker thread curdoc may be another's
            pn.state.execute(partial(draw, snapshot, computing))

    async def draw(snapshot, computing):
        try:
            await show_maps(snapshot, computing)
        finally:
            if flush_url is not None:
                await asyncio.sleep(URL_AFTER)  # the browser paints the maps first
                flush_url()

    async def show_maps(snapshot, computing):
        maps = asyncio.wrap_future(computing)
        try:  # the spinner only for a slow change: for a fast one it costs more than it says
            panels = await asyncio.wait_for(asyncio.shield(maps), BUSY_AFTER)
        except asyncio.TimeoutError:
            busy.value = True
            try:
                panels = await maps
            finally:
                busy.value = False
        async with _DRAWING:
            if snapshot != Snapshot.of(scenario):  # a newer change draws its own maps
                return
            with pn.io.hold():  # first, alone: the browser has the new colour ranges before the images
                map_figures.set_ranges(figs, panels)
            await asyncio.sleep(0)  # events queued meanwhile go first
            with pn.io.hold():
                map_figures.set_maps(figs, panels)
                note.param.update(object=_alert(panels.note, "warning"), visible=bool(panels.note))

    scenario.param.watch(redraw, list(FIELDS))
    plots = pn.pane.Bokeh(figs.layout, sizing_mode="stretch_width")
    template = pn.template.BootstrapTemplate(
        title="Dipole observability explorer",
        sidebar=[pn.pane.Markdown("**Paper figures** (one click loads a figure's scenario)"), presets,
                 message, *sections,
                 pn.pane.Markdown("**Download the maps** (PNG: the save tool on each plot)"), downloads],
        main=[pn.Tabs(
            ("Maps", pn.Column(plots, note, fix_buttons,
                               pn.pane.Markdown(READING_GUIDE, sizing_mode="stretch_width"),
                               sizing_mode="stretch_width")),
            ("Layout design", design_tab(scenario, cache)),
            dynamic=True, sizing_mode="stretch_width")],
        sidebar_width=360,
        header_background="#1f5f8b",
        header=[busy],
        # Panel's own busy indicator follows a process-wide flag: every event of any session
        # would restyle the spinner of every open session (Python work on the server for each).
        busy_indicator=None,
    )
    template.scenario = scenario  # for tests and the load benchmark
    return template
