"""app/tabs/maps/live.py without a browser: previews of a dragged value, the release, what is ignored."""

import numpy as np
import pytest

from app.kit import drag as loop
from app.kit.cache import SHARED
from app.state.scenario import Scenario
from app.tabs.maps import live, figures as map_figures, maps
from app.tabs.maps.compute import Snapshot

pytestmark = pytest.mark.filterwarnings(  # Panel 1.9 deprecates button_type (as test_calibration_tab)
    "ignore:.*deprecated and will be removed in version 2.0:PendingDeprecationWarning")


@pytest.fixture
def tab():
    scenario = Scenario()
    return scenario, maps.maps_tab(scenario, SHARED)  # outside a server: each preview drawn at once


def drag(lv, name, value, seq, released=False):
    lv.changed("state", [], [name, value, seq, released])


def test_a_dragged_value_is_previewed_and_its_release_draws_the_exact_maps(tab):
    scenario, t = tab
    figs, lv = t.figures, t.live
    assert figs.preview_layers == ()  # made by the first preview (app/tabs/maps/figures.add_previews)
    drag(lv, "Ph", 150.0, 1)
    assert lv.drawn == 1 and scenario.target.Ph == 100.0  # the scenario keeps its value until release
    # each map's preview layer over its map and under its veil
    assert [f.renderers[1] for f in figs.figures] == list(figs.preview_layers)
    assert [f.renderers[2].data_source for f in figs.figures] == list(figs.veils)
    assert all(layer.visible for layer in figs.preview_layers)
    pv = figs.previews[1].data["pv"][0]
    assert pv.dtype == np.uint8 and pv.shape == (lv.preview_n,) * 2
    assert "P = (150, 20)" in figs.captions[0].text and figs.figures[0].title.text.endswith("— preview")
    assert figs.veils[0].data["image"][0].dtype == np.uint8
    drag(lv, "Ph", 150.0, 2, released=True)
    assert scenario.target.Ph == 150.0
    assert not any(layer.visible for layer in figs.preview_layers)
    assert "preview" not in figs.figures[0].title.text and "grid 200 × 200" in figs.captions[0].text.replace("\n", " ")


def test_a_release_where_nothing_changes_still_replaces_the_previews(tab):
    scenario, t = tab
    drag(t.live, "Ph", 333.0, 1)
    drag(t.live, "Ph", 100.0, 2, released=True)  # the hand came back: the scenario does not change
    assert scenario.target.Ph == 100.0
    # made by the first preview (app/tabs/maps/figures.add_previews), hidden by the release
    assert len(t.figures.preview_layers) == 3
    assert not any(layer.visible for layer in t.figures.preview_layers)


def test_a_value_the_server_set_is_not_previewed_and_hidden_tabs_are_skipped(tab):
    scenario, t = tab
    drag(t.live, "Ph", 100.0, 1)  # the handle moved to the scenario's value (a preset, a typed value)
    assert t.live.drawn == 0
    t.live.shown = False
    drag(t.live, "Ph", 150.0, 2)
    assert t.live.drawn == 0
    drag(t.live, "noise", 1e-6, 3)  # not a slider the maps follow: ignored
    drag(t.live, "track_speed", 3.0, 4)
    assert t.live.drawn == 0


def test_previews_come_from_explicit_values_not_the_scenario():
    sc = Scenario()
    snap = Snapshot.of_values(sc, {"Ph": 321.0, "resolution": 50})
    values = dict(snap.items)
    assert values["Ph"] == 321.0 and values["resolution"] == 50 and sc.target.Ph == 100.0
    assert Snapshot.of_values(sc, {}) == Snapshot.of(sc)
    with pytest.raises(KeyError):
        Snapshot.of_values(sc, {"track_speed": 1.0})


def test_the_preview_grid_follows_the_compute_time():
    n, budget = loop.PREVIEW_N, loop.PREVIEW_BUDGET_S
    assert loop.next_n(n, budget) == n  # within budget: kept
    assert loop.next_n(n, budget / 10) == n  # never above PREVIEW_N
    assert loop.next_n(n, 0.6) == 30  # a magnetic preview at 100² (~0.6 s): ~√(0.06 / 0.6) × 100
    assert loop.next_n(30, 0.6 * 0.09 * 2) == loop.PREVIEW_MIN_N  # never below the minimum
    assert loop.next_n(30, 0.005) == 100  # fast again: back to PREVIEW_N


def test_magnetic_maps_follow_the_drag_on_a_grid_their_compute_allows():
    scenario = Scenario()
    scenario.update(sensor="magnetometer (B, nT)")
    t = maps.maps_tab(scenario, SHARED)
    lv = t.live
    drag(lv, "mx", 60.0, 1)
    assert lv.drawn == 1 and "magnetometer" in t.figures.figures[0].title.text
    first = t.figures.previews[0].data["pv"][0].shape[0]
    assert first == loop.PREVIEW_N
    drag(lv, "mx", 70.0, 2)  # the next preview's grid follows the first one's compute time
    n = t.figures.previews[0].data["pv"][0].shape[0]
    assert lv.drawn == 2 and loop.PREVIEW_MIN_N <= n <= loop.PREVIEW_N
    assert f"grid {n} × {n}" in t.figures.captions[0].text.replace("\n", " ")
    drag(lv, "mx", 70.0, 3, released=True)
    assert scenario.target.mx == 70.0 and len(t.figures.preview_layers) == 3
    assert not any(layer.visible for layer in t.figures.preview_layers)


def test_the_page_is_answered_for_every_value_it_sends(tab):
    # the page's closed loop sends its next value once Drag.ready reaches the last it sent
    scenario, t = tab
    lv = t.live
    drag(lv, "Ph", 150.0, 1)
    assert lv.drag.ready == 1  # drawn (outside a server, at once)
    drag(lv, "Ph", 100.0, 2)  # the scenario's value while dragging Ph: still previewed
    assert lv.drag.ready == 2 and lv.drawn == 2
    drag(lv, "track_speed", 3.0, 3)  # not an input of the maps: answered, not drawn
    assert lv.drag.ready == 3 and lv.drawn == 2
    lv.shown = False
    drag(lv, "Ph", 170.0, 4)
    assert lv.drag.ready == 4 and lv.drawn == 2
    drag(lv, "Ph", 170.0, 5, released=True)
    assert lv.drag.ready == 5 and scenario.target.Ph == 170.0
    lv.changed("state", [], ["Ph", 180.0, 4, False])  # an older answer never goes back
    assert lv.drag.ready == 5
    # the answer reaches the page's loop through a browser-side callback of Drag.ready
    assert [cb.code for cb in lv.drag.js_property_callbacks["change:ready"]] == [loop.READY_JS]


def test_a_number_input_holding_a_whole_number_keeps_a_dragged_values_decimals(tab):
    # A link's ?Ph=150 and a drag released on 151 arrive as JSON integers, so a Number input can
    # hold an int: the next drag's value 263.2 was rounded to 263 (previews and release), then
    # Panel's own release set 263.2, and the page ended with the maps at 263.2, the handle at 263
    scenario, t = tab
    scenario.target.Ph = 151
    drag(t.live, "Ph", 263.2, 1)
    assert "P = (263.2, 20)" in t.figures.captions[0].text  # the preview is of the hand's value
    drag(t.live, "Ph", 263.2, 2, released=True)
    assert scenario.target.Ph == 263.2
    assert "P = (263.2, 20)" in t.figures.captions[0].text and "preview" not in t.figures.figures[0].title.text
    drag(t.live, "resolution", 150.4, 3, released=True)  # an Integer input: a whole number
    assert scenario.value("resolution") == 150 and isinstance(scenario.value("resolution"), int)


def test_a_uniform_veil_is_not_resent_by_a_preview_or_its_release(tab):
    """A veil that is clear or striped everywhere shows the same at any grid: neither the drag's
    coarser veil nor the exact one after its release is sent again (each release re-sent three
    200² veils)."""
    scenario, t = tab
    figs, lv = t.figures, t.live
    before = [v.data["image"][0] for v in figs.veils]
    # the default scenario: A and the difference unobservable everywhere, B observable everywhere
    assert [map_figures.uniform_veil(v) for v in before] == ["striped", "clear", "striped"]
    sent = []
    for i, v in enumerate(figs.veils):
        v.on_change("data", lambda _a, _o, _n, i=i: sent.append(i))
    drag(lv, "Ph", 150.0, 1)
    drag(lv, "Ph", 150.0, 2, released=True)
    assert lv.drawn == 1 and scenario.target.Ph == 150.0
    assert "P = (150, 20)" in figs.captions[0].text  # the exact maps were drawn
    assert sent == []


def test_a_veil_that_differs_by_place_is_not_uniform():
    mixed = np.zeros((4, 4), np.uint8)
    mixed[:2] = 1
    assert map_figures.uniform_veil(mixed) is None  # a preview sends such a veil when it changes
    assert map_figures.uniform_veil(np.full((3, 3), 3, np.uint8)) == "clear"
    assert map_figures.uniform_veil(np.array([[1, 2], [2, 1]], np.uint8)) == "striped"
