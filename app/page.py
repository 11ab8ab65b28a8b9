"""The page: the sidebar of scenario parameters and the tabs, assembled.

Each tab is a module of its own, a function of the one shared :class:`app.state.scenario.Scenario`
returning its layout (:mod:`app.tabs.maps.maps`, :mod:`app.tabs.design.design`); the URL sync is :mod:`app.state.url`.
"""

from __future__ import annotations

import ctypes
import gc
import threading
from functools import partial

import panel as pn
import param
from panel.io.state import set_curdoc

from app.kit import offloop
from app.kit.alerts import alert, refusal, with_refusal
from app.kit.cache import SHARED
from app.kit.inputs import number_input
from app.kit.number_box import number_box
from app.kit.shown import ALWAYS, WhenShown
from app.kit.tab import Mount
from app.report.buttons import study_buttons
from app.state import url
from app.state.applies import (
    CALIBRATION_TAB,
    DECIDING,
    MAPS_TAB,
    SHAPE_TAB,
    TRACK_TAB,
    applies,
)
from app.state.derive import MAGNETIC_READS
from app.state.part import declared
from app.state.scenario import (
    ACCEPTED,
    PART_OF,
    PRESET_INPUTS,
    PRESETS,
    SENSORS,
    Scenario,
    parameter,
    sidebar,
)
from app.state.sensors import BY_KIND
from app.tabs.calibration.calibration import TAB as CALIBRATION, uploaded_bytes
from app.tabs.calibration.source import bring_own_values
from app.tabs.design.design import TAB as DESIGN
from app.tabs.maps import export, live, maps
from app.tabs.maps.compute import KIND_NAMES, MAP_INPUTS
from app.tabs.shape.shape import TAB as SHAPE
from app.tabs.track.track import TAB as TRACK

#: The page's tabs, in order (each an :class:`app.kit.tab.Tab`): the Tabs' titles, each tab's
#: index, which are built on their first visit, which wait while hidden, which say the sensor
#: kind over them and which put their inputs in the sidebar are derived from this list.
TABS = (maps.TAB, DESIGN, TRACK, CALIBRATION, SHAPE)

#: Sidebar sections: (title, parameters, collapsed?), as the inputs declare them (app.state.parts.sidebar).
SECTIONS = sidebar()


#: Seconds after the last session closed that the memory freed by closed sessions is handed back
#: to the OS: after Panel's own collection of their cyclic graphs (``gc.collect``, which Panel
#: runs 5 s after the last session it destroyed).
TRIM_AFTER_S = 15.0
_trim = {"timer": None}
_trim_lock = threading.Lock()


def _release_freed_memory():
    """Hand memory freed by closed sessions back to the OS (glibc keeps it in its arenas)."""
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):  # not glibc: nothing to do
        pass


def _schedule_trim():
    """Release the closed sessions' memory TRIM_AFTER_S after the last close (each close moves
    it on, as Panel's collection). No collection of our own: a full collection walks every live
    object of every open session, ~0.15-0.4 s of the GIL, and a second one per close doubled
    what a close cost everyone else (docs/performance.md)."""
    with _trim_lock:
        if _trim["timer"] is not None:
            _trim["timer"].cancel()
        timer = _trim["timer"] = threading.Timer(TRIM_AFTER_S, _release_freed_memory)
    timer.daemon = True  # a server that stops does not wait for it
    timer.start()


def freeze_startup_objects():
    """Move every object alive now (modules, classes, the kernels' dispatchers: ~350 000 after
    the app is imported) to the collector's permanent generation, so that no full collection
    walks them again: each one then costs ~40 % less (measured with 6 open sessions). Call once,
    before the first session."""
    gc.collect()
    gc.freeze()


_alert = alert


#: Numbers typed or dragged (:func:`app.kit.inputs.number_input`): every number of the sidebar but
#: those declared with a box only (the noise: a slider cannot span 1e-12 … 1e-2 V/m).
NUMBERS = tuple(n for _, names, _ in SECTIONS for n in names
                if isinstance(parameter(n), param.Number) and declared(parameter(n)).get("slider", True))


def _widgets():
    """pn.Param widget specs of the inputs that are not :data:`NUMBERS` (a select; the noise has a
    number box, app.kit.number_box): each with its stable css class."""
    spec = {}
    for name in PART_OF:  # stable hooks for the browser tests
        spec.setdefault(name, {})["css_classes"] = [f"w-{name}"]
    return spec


#: Selectors whose change moves other values by a rule (a layered sea puts the stations on the
#: seabed), as declared: the note on what moved shows under them.
MOVES = tuple(n for n in PART_OF if declared(parameter(n)).get("moves"))


def _section(scenario, tabs, title, names, collapsed):
    """A sidebar card of ``names``' inputs; an input that does not apply is hidden, and so is the
    card when none does. A refused value's message shows under its input."""
    watched = [*map(scenario.ref, DECIDING), tabs.param.active]
    rows = {}  # name -> its row in the card, once built

    def widget(name):
        if name == "noise":  # a box that says why it refuses (emptied, it raised in the server)
            return number_box(scenario.part_of(name), name, css_classes=[f"w-{name}"])
        if name in NUMBERS:
            return number_input(scenario.part_of(name), name, css_classes=[f"w-{name}"], on_slider=live.follow)
        spec = dict(_widgets()[name])
        cls = spec.pop("type", pn.widgets.Select)
        return cls.from_param(scenario.ref(name), **spec)

    def row(name):
        if name not in ACCEPTED and name not in MOVES:  # a selector: nothing it offers is refused
            rows[name] = widget(name)
        else:
            # A refused value is said right under its input, where the user typed it (at the top
            # of the sidebar it was out of sight when typing in Stations or Advanced).
            w = widget(name)
            column = w if name in NUMBERS else pn.Column(w, sizing_mode="stretch_width", margin=0)
            rows[name] = with_refusal(scenario, column, [name], f"w-message-{name}")
        return rows[name]

    # An input is built when it first applies, and a collapsed card's inputs when it is first
    # opened: a new page carries only what it shows (the two collapsed cards held ~40 % of the
    # sidebar's models, the inputs of the open cards that do not apply, e.g. a magnetic sensor's
    # moment or a layered sea's depth, another third).
    card = pn.Card(title=title, collapsed=collapsed, sizing_mode="stretch_width")
    # Hidden as a whole in a plain column: a hidden Card still showed its header in the browser.
    outer = pn.Column(card, sizing_mode="stretch_width", margin=0)
    opened_once = [not collapsed]
    lock = threading.Lock()  # watchers run on Panel's threads: one build of an input
    doc = pn.state.curdoc  # the session's (None outside a server)

    def apply():
        """Each input shown where it applies, the card where one does: one watcher per card (one
        binding per input re-read the scenario once per input, and carried its own watchers)."""
        s = scenario.snapshot()
        shown = {name: applies(name, s, TABS[tabs.active].key) for name in names}
        with lock:
            new = [name for name in names if opened_once[0] and shown[name] and name not in rows]
            for name in new:
                row(name)
            for name, r in rows.items():
                r.visible = shown[name]
            if new:  # in their declared places among those built
                card.objects = [rows[name] for name in names if name in rows]
        outer.visible = any(shown.values())

    def show_applicable(*_):
        """:func:`apply` as a change of the page's document on its loop, events held
        (``offloop.soon``): an input built here brings new models to the page, and made on
        Panel's threads their message could be overtaken by a later one that refers to them
        (docs/dashboard.md, "Changes in the order they were made")."""
        offloop.soon(doc, apply)

    def opened(event):
        if not event.new and not opened_once[0]:
            opened_once[0] = True
            show_applicable()

    card.param.watch(opened, ["collapsed"])
    by_owner = {}
    for ref in watched:
        by_owner.setdefault(ref.owner, []).append(ref.name)
    for owner, params in by_owner.items():  # one call per change of an owner's values
        owner.param.watch(show_applicable, params)
    apply()  # while the page is built
    return outer


#: What the Layout design and Track tabs say over their content for a magnetic sensor kind.
DESIGN_SENSOR = ("Sensor: {name}. The Cramér–Rao maps, spacing and layouts below are for this "
                 "kind: moment m = ({mx:g}, {my:g}, {mz:g}) A·m², noise {noise}, {tensor}.")
TRACK_SENSOR = ("The track below is seen by the sidebar's sensor, {name}: a magnetic target of "
                "moment m = ({mx:g}, {my:g}, {mz:g}) A·m² (8 states: position, horizontal velocity, "
                "moment), noise {noise}, {tensor}. The EKF, PU-EKF and seed 001's filter bank run on it through "
                "the same measurement model as the maps (the bank's hypotheses: vertical moments "
                "of ½, 1 and 2 × |m|).")


def tensor_text(kind, baseline):
    """What the gradiometer reads, its baseline's effect and limits (issue 36 item 4)."""
    if "G" not in kind:
        return "no gradiometer"
    if baseline <= 0:
        return ("point gradient tensor (no baseline: one gradiometer alone cannot tell range from "
                "moment, spec §11)")
    return (f"gradiometer of baseline L = {baseline:g} m (magnetometer differences: it sets the "
            "scale, so one gradiometer alone is observable, its bound growing steeply with "
            "range / L; targets within L of a station masked)")


def sensor_banner(scenario, tab):
    """An HTML pane over tab ``tab`` (DESIGN_TAB or TRACK_TAB) saying which sensor kind its
    numbers are for when the scenario's is magnetic; hidden for the electric kind."""
    def text(sensor, *_):
        kind = SENSORS[sensor]
        if kind == "E":
            return ""
        name = f"{KIND_NAMES[kind][0]} ({KIND_NAMES[kind][1]})"
        noise = BY_KIND[kind].noise_text(scenario.sensor)  # the kind's sensor part says it
        text = TRACK_SENSOR if tab == TRACK_TAB else DESIGN_SENSOR
        return _alert(text.format(name=name, mx=scenario.target.mx, my=scenario.target.my, mz=scenario.target.mz,
                                  noise=noise, tensor=tensor_text(kind, scenario.sensor.baseline)),
                      "info")

    deps = [scenario.ref(n) for n in ("sensor", *MAGNETIC_READS)]
    return pn.pane.HTML(pn.bind(text, *deps), visible=pn.bind(lambda k, *_: SENSORS[k] != "E", *deps),
                        sizing_mode="stretch_width",
                        css_classes=["w-track-sensor" if tab == TRACK_TAB else "w-design-sensor"])


def panel_extension():
    """Panel's settings the page is built for: the Tabulator and the chunked upload (FileDropper)
    of the calibration tab, sliders that
    report on release only (:mod:`app.kit.inputs` keeps a box and its slider in step on that value),
    the busy spinner over a recomputing map, and no notification area (messages are shown in
    the page)."""
    pn.extension("tabulator", "filedropper", throttled=True, loading_indicator=True,
                 notifications=False)


def in_parts(doc, parts):
    """Run the functions ``parts`` (each builds a part of the page) one per turn of the event
    loop of ``doc``'s session, in order, after the step that runs now: between two parts the
    server's loop serves other sessions (Bokeh runs a new session's script in one step, which
    held the loop for the whole page). Each in Panel's document context; a part should change the
    page once (Panel applies each change of a page not yet connected in a turn of its own, and
    Bokeh walks the whole document's model graph for it). Outside a served session (``doc``
    None or without a session: tests) they run at once."""
    if doc is None or doc.session_context is None:
        for part in parts:
            part()
        return
    queue = list(parts)

    def next_part():
        part = queue.pop(0)
        try:
            # built as the first step's objects are, before the template set the session's
            # design: the template's hooks style them (with the session's design set, the cards
            # were drawn in another style: plain titles, narrower padding)
            with set_curdoc(doc), pn.config.set(design=None):
                part()
        finally:  # a part that failed (Bokeh logs it) leaves the others to be built
            if queue:  # queued from inside this step: it runs in the loop's next turn
                doc.add_next_tick_callback(next_part)

    if queue:
        doc.add_next_tick_callback(next_part)


def first_visit(tabs, titles, holders, makers):
    """Build tab ``title``'s content with ``makers[title]()`` into its holder ``holders[title]``
    (a Column, with a placeholder until then) the first time it is the active tab of ``tabs``: a new page
    carries the Python objects and models of the tab it shows only (the hidden tabs were ~half
    of a new page's server CPU, docs/performance.md)."""
    built, lock = set(), threading.Lock()
    doc = pn.state.curdoc  # the session's (None outside a server)

    def fill(active, now=False):
        title = titles[active]
        with lock:  # one build per tab, whichever thread sees the click
            if title not in holders or title in built:
                return
            built.add(title)
        content = makers[title]()  # Panel's objects, on the watcher's thread
        # their models join the page as a change of the document on its loop, events held: made
        # on Panel's threads, the message bringing them could be overtaken (offloop.soon)
        put = partial(setattr, holders[title], "objects", [content])
        put() if now else offloop.soon(doc, put)

    tabs.param.watch(lambda event: fill(event.new), ["active"])
    fill(tabs.active, now=True)


def _maker(tab, mount, sides):
    """A maker of ``tab``'s content (``mount``: its :class:`app.kit.tab.Mount`, made when it is
    built): with the sensor banner over it where it says so; a tab whose inputs go to the
    sidebar puts them in its column of ``sides`` (on its first visit)."""
    def make():
        m = mount(tab)
        if tab.sidebar:
            inputs, main = tab.view(m)
            inputs.param.update(width=None, sizing_mode="stretch_width")
            offloop.soon(pn.state.curdoc, partial(setattr, sides[tab.title], "objects", [inputs]))
            return main
        view = tab.view(m)
        if not tab.banner:
            return view
        return pn.Column(sensor_banner(m.scenario, tab.key), view, sizing_mode="stretch_width", margin=0)
    return make


def _preset_buttons(scenario, tabs, keys):
    """The paper figures' preset buttons, the one the scenario holds solid."""
    buttons = {name: pn.widgets.Button(name=name, button_type="primary", button_style="outline",
                                       width=90 if len(name) <= 6 else 150,  # a seed's name is longer
                                       css_classes=[f"w-preset-{name[-1]}"],
                                       on_click=lambda e, n=name: scenario.apply_preset(n))
               for name in PRESETS}

    def restyle(*_):  # the preset the scenario holds is solid: worked out once per change
        active = scenario.active_preset()
        for name, button in buttons.items():
            button.button_style = "solid" if name == active else "outline"

    for part in {scenario.part_of(n) for n in PRESET_INPUTS}:  # one call per part a change sets
        part.param.watch(restyle, [n for n in PRESET_INPUTS if scenario.part_of(n) is part])
    restyle()
    # The paper's figures set the maps' scenario: not offered on the tabs with inputs of their
    # own (Calibration, Shape), where a click changed the hidden Maps state.
    return pn.Column(pn.pane.Markdown("**Paper figures** (one click loads a figure's scenario; "
                                      "the figure's map gets a red frame; the Layout design "
                                      "and Track tabs' own settings stay)"),
                     pn.FlexBox(*buttons.values(), sizing_mode="stretch_width"),
                     visible=pn.bind(lambda tab: keys[tab] not in (CALIBRATION_TAB, SHAPE_TAB), tabs.param.active),
                     sizing_mode="stretch_width", margin=0)


def _download(scenario, cache, ext, fn, label=None, suffix=""):
    """A download button of the maps, named after the scenario (was always observability_maps.*),
    set as the file is made."""
    def make():
        name = maps.download_name(scenario, cache, ext)
        button.filename = name.removesuffix(f".{ext}") + f"_{suffix}.{ext}" if suffix else name
        return fn(scenario, cache)

    button = pn.widgets.FileDownload(callback=make, filename=f"observability_maps.{ext}",
                                     label=label or {"csv": "CSV", "nc": "NetCDF", "png": "PNG"}[ext],
                                     button_type="light",
                                     css_classes=[f"w-download-{ext}" + (f"-{suffix}" if suffix else "")])
    return button


def _download_buttons(scenario, cache, tabs, keys):
    """The maps' downloads, shown on the Maps tab."""
    def download(*args, **kw):
        return _download(scenario, cache, *args, **kw)

    return pn.Column(
        pn.pane.Markdown("**Download the maps** (PNG: the three maps, "
                         f"{export.WIDTH_PX} px wide; PNG A, B, B vs A: one map, "
                         f"{export.MAP_WIDTH_PX} px wide)"),
        pn.Row(download("csv", maps.to_csv), download("nc", maps.to_netcdf), download("png", maps.to_png)),
        # one map at a useful resolution (its save tool writes the canvas as shown, ~200-400 px)
        pn.Row(*[download("png", lambda s, c, which=which: maps.to_png(s, c, (which,)), f"PNG {label}", suffix)
                 for label, which, suffix in maps.MAP_PNGS]),
        visible=tabs.param.active.rx() == keys.index(MAPS_TAB), margin=0)


def _calibration_log(sides):
    """(uploaded_log, put_log) of the Calibration tab's upload, for the study buttons: the log it
    holds, as (name, bytes) ("", None when none, or the tab not built yet), and handing it a
    file's log (False when the tab is not built yet). ``sides``: the sidebar columns by title."""
    def log_input():  # the Calibration tab's upload, once the tab is built
        found = sides[CALIBRATION.title].select(pn.widgets.FileDropper)
        return found[0] if found else None

    def uploaded_log():
        upload = log_input()
        data = None if upload is None else uploaded_bytes(upload)
        return (next(reversed(upload.value)) if data is not None else "", data)

    def put_log(name, data):
        upload = log_input()
        if upload is not None:
            upload.value = {name: data}
        return upload is not None

    return uploaded_log, put_log


def _fill_sidebar(scenario, cache, tabs, keys, log):
    """The sidebar, filled after the page's first step, in two parts, each in a turn of the
    session's event loop of its own (in_parts): Bokeh runs the whole :func:`create_app` in one
    step of the server's loop, which every other session waits for. The parts fill the Column
    returned, in the page from the start: built before the browser pulls the document (it has
    the page's HTML and scripts to load first), they reach it with the document, else as a
    change. Panel applies a change to a page not yet connected in a turn of its own, in which
    Bokeh walks the whole document's model graph again: so one change of the sidebar per part
    (a change per card cost 8 more walks, ~15 % of a page's server CPU). ``log``: the Calibration
    tab's (uploaded_log, put_log), for the study buttons (:func:`_calibration_log`)."""
    sidebar = pn.Column(sizing_mode="stretch_width", margin=0)

    def cards(sections):
        return [_section(scenario, tabs, *section) for section in sections]

    def first_part():
        sidebar.objects = [_preset_buttons(scenario, tabs, keys), refusal(scenario, None, "w-message"),
                           *cards(SECTIONS[:2])]

    def second_part():
        sidebar.objects = [*sidebar.objects, *cards(SECTIONS[2:]), _download_buttons(scenario, cache, tabs, keys),
                           study_buttons(scenario, *log)]

    in_parts(pn.state.curdoc, [first_part, second_part])
    return sidebar


def _template(sidebar, sides, tabs, titles, busy):
    """The page's Bootstrap template: the sidebar, the tabs, the busy spinner in the header."""
    return pn.template.BootstrapTemplate(
        title="Dipole observability explorer",
        # the Calibration and Shape tabs' inputs, shown on their tabs (where nothing else is)
        sidebar=[sidebar, *[pn.Column(side, visible=tabs.param.active.rx() == titles.index(t), margin=0,
                                      sizing_mode="stretch_width") for t, side in sides.items()]],
        main=[tabs],
        sidebar_width=360,
        header_background="#1f5f8b",
        header=[busy],
        # Panel's own busy indicator follows a process-wide flag: every event of any session
        # would restyle the spinner of every open session (Python work on the server for each).
        busy_indicator=None,
    )


def create_app():
    scenario = Scenario()
    bring_own_values(scenario)  # before the link is read: a link naming only the source too
    cache = SHARED  # results are shared by every session of the process (app.kit.cache)
    pn.state.on_session_destroyed(lambda ctx: _schedule_trim())

    served = pn.state.location is not None  # no page URL outside a served page
    args = (pn.state.session_args or {}) if served else {}
    keys, titles = tuple(t.key for t in TABS), tuple(t.title for t in TABS)
    # the link's values first: the first maps are the link's (read once, here)
    link = url.read_link(scenario, args, titles) if served else None
    flush_url = []  # set below, once the tabs exist

    #: Spins while a change slower than BUSY_AFTER computes, hidden otherwise (an idle ring
    #: looked stalled). In the header, a Bokeh root of its own: its changes re-lay out only
    #: itself, not the maps. throttle=0: it stops when the maps are ready, not later.
    busy = pn.indicators.LoadingSpinner(value=False, visible=False, width=24, height=24,
                                        css_classes=["w-busy"], margin=(0, 10), align="center",
                                        color="light", bgcolor="dark", throttle=0)
    # the URL update after the maps are drawn (none outside a served page: nothing to wait for)
    after_draw = (lambda: flush_url[0]() if flush_url else None) if served else None
    # The other tabs are built on their first visit (first_visit), and stay: Panel's dynamic
    # Tabs detach a hidden tab's models from the document, and a change made to them there (a
    # preset) patched Panel's shared stylesheets to cdn.holoviz.org, for every model of the
    # page (issue 25, Offline).
    # The Calibration and Shape tabs' inputs sit in the sidebar, which has nothing else for them
    # (at 1280 × 800 a blank sidebar beside inputs in the main area cut off the coefficient table
    # and shrank the Shape views to ~190 × 100 px): filled on the tab's first visit.
    sides = {t.title: pn.Column(sizing_mode="stretch_width", margin=0, css_classes=[f"w-side-{t.title.lower()}"])
             for t in TABS if t.sidebar}

    # A hidden tab computes nothing: the Layout design and Track tabs follow the scenario when
    # shown (a preset on the Maps tab waited 6-20 s for them, and its text and link 20-30 s:
    # app/kit/shown.py). Given the Tabs below, before any tab is built.
    when_shown = {}

    def mount(tab):
        return Mount(scenario, cache, _widgets(),
                     when_shown.get(tab.key, ALWAYS), busy, after_draw)

    makers = {t.title: _maker(t, mount, sides) for t in TABS}
    later = {title: makers[title] for title in titles[1:]}
    # What a hidden tab says until its first visit has built it (~0.1-0.5 s)
    holders = {t: pn.Column(pn.pane.HTML(f"Opening the {t} tab…", css_classes=["w-tab-opening"],
                                         styles={"color": "#555", "font-size": "15px"}),
                            sizing_mode="stretch_width", margin=0)
               for t in later}
    tabs = pn.Tabs((titles[0], makers[titles[0]]()), *holders.items(), sizing_mode="stretch_width")
    when_shown.update({t.key: WhenShown(tabs, i) for i, t in enumerate(TABS) if t.waits})
    first_visit(tabs, titles, holders, later)
    if MAPS_TAB in keys:
        live.shown_with(tabs, keys.index(MAPS_TAB))  # no previews of the maps while another tab is shown
    if served:
        flush_url.append(url.sync_url(scenario, pn.state.location, args, onload=pn.state.onload,
                                      tabs=tabs, titles=titles,
                                      waits=lambda names: bool(set(names) & MAP_INPUTS),
                                      link=link))
    sidebar = _fill_sidebar(scenario, cache, tabs, keys, _calibration_log(sides))
    template = _template(sidebar, sides, tabs, titles, busy)
    template.scenario = scenario  # for tests and the load benchmark
    template.built_later = sidebar  # for tests
    return template
