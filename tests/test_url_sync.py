"""The page URL follows the scenario (app.url.sync_url), after the maps for map values; refused
link values are reported and taken out of the address bar. Against Panel's own Location."""

from urllib.parse import parse_qs

from panel.io.location import Location

from app.scenario import Scenario
from app.url import sync_url, without


def _location(search=""):
    loc = Location(search=search)
    loc.updates = []
    loc.param.watch(lambda e: loc.updates.append(parse_qs(e.new.lstrip("?"))), "search")
    return loc


def _args(search):
    return {k: [v.encode() for v in vs] for k, vs in parse_qs(search.lstrip("?")).items()}


def test_a_map_value_reaches_the_url_when_flushed_after_the_maps():
    scenario, location = Scenario(), _location()
    flush = sync_url(scenario, location, {})
    scenario.Ph = 250.0
    scenario.Pv = 40.0
    assert location.updates == []  # waits for the maps: redraw flushes after sending them
    flush()
    assert location.updates == [{"Ph": ["250.0"], "Pv": ["40.0"]}]
    flush()
    assert len(location.updates) == 1  # nothing new, nothing sent


def test_a_design_only_value_reaches_the_url_at_once():
    scenario, location = Scenario(), _location()
    sync_url(scenario, location, {})
    scenario.threshold = 7.0
    assert location.updates == [{"threshold": ["7.0"]}]


def test_a_link_value_that_would_be_refused_is_not_set_reported_and_removed_from_the_url():
    search = "?Ph=250&h=1e9&d=abc&resolution=100000&z=-5"
    scenario, location = Scenario(), _location(search)
    sync_url(scenario, location, _args(search))
    assert scenario.Ph == 250
    default = Scenario()
    assert (scenario.h, scenario.d, scenario.resolution, scenario.z) == (default.h, default.d,
                                                                        default.resolution, default.z)
    for name in ("h:", "d:", "resolution:", "z:"):
        assert name in scenario.message
    assert "above the sea surface" in scenario.message  # z = -5 m: a depth above the surface
    assert scenario.refused == []  # about the link, not an input: shown at the top of the page
    assert parse_qs(location.search.lstrip("?")) == {"Ph": ["250"]}  # only the accepted value stays


def test_without_keeps_the_other_parameters_in_order():
    assert without("?a=1&b=x%E2%80%93z&c=3", {"a", "c"}) == "?b=x%E2%80%93z"
    assert without("?a=1", {"a"}) == "" and without("", {"a"}) == ""


def test_a_refused_value_never_reaches_the_url():
    # Scenario restores the last good value from inside the change's own event; the URL must hold
    # what the scenario holds (it took the refused -0.5, so a copied link reopened with an error).
    scenario, location = Scenario(), _location()
    flush = sync_url(scenario, location, {})
    scenario.Ph = -0.5
    assert scenario.Ph == Scenario().Ph and "P_h" in scenario.message
    scenario.z = 150.0
    flush()
    assert location.updates == [{"Ph": [f"{Scenario().Ph!r}"], "z": ["150.0"]}]
