"""Wiring: one Scenario, widgets generated from its parameters, live maps, the page template."""

from __future__ import annotations

import html
from functools import partial

import holoviews as hv
import panel as pn

from . import views
from .compute import FIELDS, PanelCache, Snapshot
from .scenario import PRESETS, Scenario

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


def _widgets():
    """Editable sliders (type a value or drag) for every number; a text box for the noise."""
    numeric = {"type": pn.widgets.EditableFloatSlider, "sizing_mode": "stretch_width", "format": "0.[00]"}
    integer = {"type": pn.widgets.EditableIntSlider, "sizing_mode": "stretch_width"}
    spec = {name: dict(numeric) for name in ("Ph", "Pv", "speed", "heading", "h", "z", "y", "d", "k",
                                                "Ph_b", "Pv_b", "d_ref", "T", "sigma", "extent",
                                                "z_min", "z_max")}
    spec.update(steps=dict(integer), resolution=dict(integer))
    spec["noise"] = {"type": pn.widgets.FloatInput, "format": "0.0e+0", "sizing_mode": "stretch_width"}
    for name in Scenario.param:
        if name not in ("name", "message"):  # stable hooks for the browser tests
            spec.setdefault(name, {})["css_classes"] = [f"w-{name}"]
    return spec


def maps(scenario, cache, plane_kind):
    """Three linked maps (A, B, difference) that update in place as the scenario changes."""
    stream = hv.streams.Params(scenario, [f for f in FIELDS if f != "plane"])

    def draw(which, **_):
        return views.map_panel(cache.get(Snapshot.of(scenario)), which)

    panels = [hv.DynamicMap(partial(draw, i), streams=[stream]) for i in range(3)]
    return hv.Layout(panels).cols(3).opts(shared_axes=True)


def create_app():
    scenario = Scenario()
    cache = PanelCache()
    pn.state.on_session_destroyed(lambda ctx: cache.clear())

    if pn.state.location is not None:
        def url_error(bad):
            names = ", ".join(sorted(bad))[:200]
            scenario.message = f"The link's values for {names} could not be used; kept the defaults."
        pn.state.location.sync(scenario, list(FIELDS), on_error=url_error)

    presets = pn.FlexBox(*[
        pn.widgets.Button(name=name, button_type="primary", button_style="outline", width=90,
                          on_click=lambda e, n=name: scenario.apply_preset(n))
        for name in PRESETS
    ], sizing_mode="stretch_width")
    message = pn.pane.Alert(pn.bind(lambda m: html.escape(m), scenario.param.message),
                            alert_type="danger", visible=scenario.param.message.rx.bool())
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

    def note(*_):
        text = cache.get(Snapshot.of(scenario)).note
        return pn.pane.Alert(html.escape(text).replace("\n", "<br>"), alert_type="warning",
                             visible=bool(text), sizing_mode="stretch_width")

    fix_buttons = pn.Row(
        pn.widgets.Button(name="Moments known (5 states), D-optimal measure", button_type="warning",
                          on_click=lambda e: scenario.param.update(state_set="moments known (5 states)",
                                                                   measure="D-optimal ½·log10 det F")),
        pn.widgets.Button(name="Show CRLB position error (m)", button_type="warning",
                          on_click=lambda e: setattr(scenario, "measure", "CRLB position error (m)")),
    )
    plots = pn.pane.HoloViews(pn.bind(partial(maps, scenario, cache), scenario.param.plane),
                              sizing_mode="stretch_width", linked_axes=True)
    template = pn.template.BootstrapTemplate(
        title="Dipole observability explorer",
        sidebar=[pn.pane.Markdown("**Paper figures** (one click loads a figure's scenario)"), presets,
                 message, *sections,
                 pn.pane.Markdown("**Download the maps** (PNG: the save tool on each plot)"), downloads],
        main=[pn.Column(plots, pn.bind(note, *[scenario.param[f] for f in FIELDS]), fix_buttons,
                        pn.pane.Markdown(READING_GUIDE, sizing_mode="stretch_width"),
                        sizing_mode="stretch_width")],
        sidebar_width=360,
        header_background="#1f5f8b",
    )
    template.scenario = scenario  # for tests and the load benchmark
    return template
