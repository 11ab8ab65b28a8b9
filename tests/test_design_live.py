"""app/tabs/design/live.py without a browser: the Layout design map's previews of a dragged station,
the drop, what is refused."""

import holoviews as hv
import numpy as np
import panel as pn
import pytest
from bokeh.models import HoverTool

from app.kit import drag as loop, views
from app.kit.cache import SHARED
from app.state.scenario import Scenario
from app.tabs.design import live as design_live
from app.tabs.design.compute import ERROR_MAP_READS, design
from app.tabs.maps.compute import Snapshot

pytestmark = [
    pytest.mark.filterwarnings(  # Panel 1.9 deprecates button_type (as test_calibration_tab)
        "ignore:.*deprecated and will be removed in version 2.0:PendingDeprecationWarning"),
    # Panel's Tabulator calls pandas' deprecated reset_index(inplace=True)
    # (as tests/test_track_design_rules.py)
    pytest.mark.filterwarnings("ignore:The inplace keyword:pandas.errors.Pandas4Warning"),
]


@pytest.fixture
def tab():
    from app.page import _widgets
    from app.tabs.design.design import design_tab

    scenario = Scenario()
    t = design_tab(scenario, SHARED, _widgets())
    pane = next(iter(t.select(pn.pane.HoloViews)))
    plot = hv.renderer("bokeh").get_plot(pane.object)  # the figure, the station layer's hook run on it
    yield scenario, t, plot.state
    plot.cleanup()


def offer(follow, value, seq):
    follow.changed("state", [], ["stations", value, seq, False])


def layer(fig, name):
    return next(r for r in fig.renderers if r.name == name)


def test_a_dragged_station_is_previewed_and_the_drop_hides_the_preview(tab):
    scenario, t, fig = tab
    follow = t.follow
    assert {"panstart", "pan", "panend"} <= set(fig.js_event_callbacks)  # the station layer's hook
    error, marks = layer(fig, design_live.PREVIEW_NAME), layer(fig, design_live.PREVIEW_NAME + "-marks")
    names = [r.name for r in fig.renderers]
    # above the HoloViews map's three image layers, under the stations and the ellipse
    assert names.index(design_live.PREVIEW_NAME) == 3 and not error.visible
    mapper = error.glyph.color_mapper
    exact_range = (mapper.low, mapper.high)
    exact = fig.renderers[0]  # the HoloViews map's error layer
    hovers = [h for h in fig.select(type=HoverTool) if exact in h.renderers]
    assert hovers and not any(error in h.renderers for h in hovers)
    old = [list(s) for s in scenario.stations.stations]
    offer(follow, [[0.0, 40.0], [0.0, 25.0]], 1)  # outside a server: drawn at once
    assert follow.drawn == 1 and follow.drag.ready == 1 and follow.previewing
    # the hover reads the preview instead of the exact layer under it
    assert all(error in h.renderers and exact not in h.renderers for h in hovers)
    assert scenario.stations.stations == old  # the scenario keeps its layout until the drop
    n = min(loop.PREVIEW_N, int(scenario.value("resolution")))
    want = design(Snapshot.of_values(scenario, {"stations": [[0.0, 0.0, 100.0], [40.0, 25.0, 100.0]],
                                                "resolution": n}, ERROR_MAP_READS))
    quantity = scenario.design.error_quantity
    shown = error.data_source.data["image"][0]
    assert shown.dtype == np.float32 and shown.shape == (n, n)
    # the same numbers (float32 of the in-process map, rows along y from the bottom)
    np.testing.assert_array_equal(shown, views._errors(want, quantity).astype(np.float32))
    # the veil and the runaway dots, on a grid about the exact map's (its dots the same size)
    k = round(int(scenario.value("resolution")) / n)
    codes = marks.data_source.data["image"][0]
    assert marks.visible and codes.dtype == np.uint8 and codes.shape == (k * n, k * n)
    fine_veil = np.repeat(np.repeat(views.veiled(want), k, axis=0), k, axis=1)
    np.testing.assert_array_equal(codes == 1, fine_veil)
    assert (codes == 2).any() and not (fine_veil & (codes == 2)).any()
    assert (mapper.low, mapper.high) == views.error_clim(want, quantity)  # the colour bar's range
    label = next(m for m in fig.center if getattr(m, "name", None) == design_live.PREVIEW_NAME + "-label")
    assert label.visible and f"grid {n} × {n}" in label.text
    # the drop: preview hidden, colour range back; the layout set redraws the exact map
    follow.dropped()
    assert not follow.previewing and not label.visible and (mapper.low, mapper.high) == exact_range
    assert all(exact in h.renderers and error not in h.renderers for h in hovers)
    offer(follow, [[0.0, 50.0], [0.0, 25.0]], 2)
    assert follow.drawn == 2
    follow.dropped()  # (the layout left as it was): the exact map as it was
    assert (mapper.low, mapper.high) == exact_range and not error.visible


def test_refused_layouts_are_answered_and_not_previewed(tab):
    _, t, fig = tab
    follow = t.follow
    for seq, value in enumerate([[[0.0], [0.0, 1.0]],  # columns of unequal length
                                 [[0.0, "a"], [0.0, 1.0]],
                                 [[float(k) for k in range(9)], [0.0] * 9],  # a 9th station
                                 [[0.0, 1e9], [0.0, 0.0]],  # beyond the accepted range
                                 [[0.0, float("nan")], [0.0, 0.0]],
                                 "nonsense"], start=1):
        offer(follow, value, seq)
        assert follow.drag.ready == seq
    follow.changed("state", [], ["Ph", 150.0, 7, False])  # not a layout
    assert follow.drag.ready == 7 and follow.drawn == 0 and not follow.previewing
