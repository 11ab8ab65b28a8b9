"""The page URL follows the scenario (app.state.url.sync_url), after the maps for map values; refused
link values are reported and taken out of the address bar. Against Panel's own Location."""

from urllib.parse import parse_qs

import panel as pn
import pytest
from panel.io.location import Location

from app.state.scenario import PART_OF, PRESETS, Scenario
from app.state.url import query, sync_url, without
from app.tabs.maps.compute import MAP_INPUTS

TITLES = ("Maps", "Layout design", "Track", "Calibration")


def _maps_wait(names):
    return bool(set(names) & MAP_INPUTS)


def _location(search=""):
    loc = Location(search=search)
    loc.updates = []
    loc.param.watch(lambda e: loc.updates.append(parse_qs(e.new.lstrip("?"))), "search")
    return loc


def _args(search):
    return {k: [v.encode() for v in vs] for k, vs in parse_qs(search.lstrip("?")).items()}


def test_a_map_value_reaches_the_url_when_flushed_after_the_maps():
    scenario, location = Scenario(), _location()
    flush = sync_url(scenario, location, {}, waits=_maps_wait)
    scenario.target.Ph = 250.0
    scenario.target.Pv = 40.0
    assert location.updates == []  # waits for the maps: redraw flushes after sending them
    flush()
    assert location.updates == [{"Ph": ["250"], "Pv": ["40"]}]
    flush()
    assert len(location.updates) == 1  # nothing new, nothing sent


def test_a_design_only_value_reaches_the_url_at_once():
    scenario, location = Scenario(), _location()
    sync_url(scenario, location, {})
    scenario.design.threshold = 7.0
    assert location.updates == [{"threshold": ["7"]}]


def test_a_link_value_that_would_be_refused_is_not_set_reported_and_removed_from_the_url():
    # a link is taken whole or not at all (issue 40 defect 1): Ph = 250, accepted on its own,
    # is not set either (tests/test_link_refusal.py)
    search = "?Ph=250&h=1e9&d=abc&resolution=100000&z=-5"
    scenario, location = Scenario(), _location(search)
    sync_url(scenario, location, _args(search))
    assert {n: scenario.value(n) for n in PART_OF} == {n: Scenario().value(n) for n in PART_OF}
    for name in ("h:", "d:", "resolution:", "z:"):
        assert name in scenario.message
    assert "above the sea surface" in scenario.message  # z = -5 m: a depth above the surface
    assert scenario.refused == []  # about the link, not an input: shown at the top of the page
    assert location.search == ""  # the address bar shows the view: the defaults


def test_without_keeps_the_other_parameters_in_order():
    assert without("?a=1&b=x%E2%80%93z&c=3", {"a", "c"}) == "?b=x%E2%80%93z"
    assert without("?a=1", {"a"}) == "" and without("", {"a"}) == ""


def test_a_refused_value_never_reaches_the_url():
    # Scenario restores the last good value from inside the change's own event; the URL must hold
    # what the scenario holds (it took the refused -0.5, so a copied link reopened with an error).
    scenario, location = Scenario(), _location()
    flush = sync_url(scenario, location, {}, waits=_maps_wait)
    scenario.target.Ph = -0.5
    assert scenario.target.Ph == Scenario().value("Ph") and "P_h" in scenario.message
    scenario.target.z = 150.0
    flush()
    assert location.updates == [{"z": ["150"]}]  # P_h is back at its default: not in the link


def _served_like(search):
    """A Scenario and Tabs opened from link ``search``, as the page does (app.page)."""
    scenario, location = Scenario(), _location(search)
    tabs = pn.Tabs(*[(t, pn.pane.Markdown(t)) for t in TITLES])
    sync_url(scenario, location, _args(search), tabs=tabs, titles=TITLES)
    return scenario, tabs, location


def _inputs(s):
    return {n: s.value(n) for n in PART_OF}


@pytest.mark.parametrize("tab", TITLES)
def test_a_link_of_every_tab_reopens_every_input_and_the_tab(tab):
    # issue 25: links carried neither the Track nor the Calibration state (?track_heading=33 was
    # ignored), nor the tab shown
    s, tabs, location = _served_like("")
    s.apply_preset("Seed 001 sea trial")
    s.update(track_heading=33.0, track_runs=7, cal_source="Designed manoeuvre",
                   cal_headings="0, 45, 90", error_quantity="Depth error σz (m)", d=65.9, Ph=101.3)
    tabs.active = TITLES.index(tab)
    link = location.search
    assert ("tab=" in link) == (tab != "Maps")
    again, tabs2, _ = _served_like(link)
    assert _inputs(again) == _inputs(s) and tabs2.active == TITLES.index(tab)
    assert again.message == ""


def test_a_link_holds_only_values_that_differ_from_the_defaults_without_float_noise():
    s = Scenario()
    assert query(s) == ""
    s.stations.d = 65.89999999999999  # what a slider step gives
    s.stations.stations = [[0.1 + 0.2, 0.0, 100.0]]
    assert parse_qs(query(s).lstrip("?")) == {"d": ["65.9"], "stations": ["[[0.3,0.0,100.0]]"]}
    s.stations.d = Scenario().value("d")
    assert "d=" not in query(s)


def test_a_value_moved_by_the_layered_sea_is_in_the_link_as_moved_and_said():
    s, _, location = _served_like("")
    s.medium.sea_model = "layered"
    assert "moved" in s.message and "100 → 200 m" in s.message and s.refused == ["sea_model"]
    got = parse_qs(location.search.lstrip("?"))
    assert got["h"] == ["200"] and got["sea_model"] == ["layered"]
    again, _, _ = _served_like(location.search)
    assert _inputs(again) == _inputs(s)


def test_every_preset_round_trips_through_its_link():
    for name in PRESETS:
        s, _, location = _served_like("")
        s.apply_preset(name)
        again, _, _ = _served_like(location.search)
        assert _inputs(again) == _inputs(s), name
