"""A hidden tab computes nothing (issue 40, defect 3; app/kit/shown.py): the Layout design tab built,
then hidden, does not recompute on a preset; shown again, it computes once, for the scenario as
it then is. In-process (outside a server a deferred computation runs at once when shown); the
same in the browser, timed against the maps: tests/test_browser_state.py."""

import panel as pn
import pytest

from app.kit.cache import PanelCache
from app.kit.shown import WhenShown
from app.page import _widgets
from app.state.scenario import Scenario
from app.tabs.design import compute as design_compute
from app.tabs.design.compute import ERROR_MAP_READS
from app.tabs.design.design import design_tab
from app.tabs.maps.compute import Snapshot


class Counting(PanelCache):
    """A cache that counts the Layout design maps it is asked to compute."""

    def __init__(self):
        super().__init__()
        self.designs = []

    def get(self, snapshot, fn):
        if fn is design_compute.design and (fn.__qualname__, snapshot) not in self.designs:
            self.designs.append((fn.__qualname__, snapshot))
        return super().get(snapshot, fn)


def test_when_shown_defers_each_call_once_until_the_tab_is_shown():
    tabs = pn.Tabs(("A", pn.Column()), ("B", pn.Column()))
    gate = WhenShown(tabs, 1)
    calls = []
    now = gate(lambda *events: calls.append(("now", len(events))), later=lambda: calls.append("later"))
    now("event")
    assert calls == []  # tab B hidden
    now("event"), now("event")
    tabs.active = 1
    assert calls == ["later"]  # once, however many changes while hidden
    now("event")
    assert calls == ["later", ("now", 1)]  # shown: at once
    tabs.active = 0
    now("event")
    assert calls == ["later", ("now", 1)]


# building the tab: Panel's Tabulator calls pandas' deprecated reset_index(inplace=True), and
# Panel 1.9 deprecates the buttons' button_type (as tests/test_track_design_rules.py)
@pytest.mark.filterwarnings("ignore:The inplace keyword:pandas.errors.Pandas4Warning")
@pytest.mark.filterwarnings("ignore:.*deprecated and will be removed in version 2.0:PendingDeprecationWarning")
def test_a_hidden_layout_design_tab_recomputes_nothing_until_shown():
    s = Scenario(resolution=21)
    tabs = pn.Tabs(("Maps", pn.Column()), ("Layout design", pn.Column()))
    tabs.active = 1  # built on its first visit, as the page does
    cache = Counting()
    tab = design_tab(s, cache, _widgets(), WhenShown(tabs, 1))
    tab.get_root()  # rendered: its map drawn
    first = len(cache.designs)
    assert first >= 1
    tabs.active = 0  # back to Maps
    s.apply_preset("Seed 001 sea trial")
    s.apply_preset("Fig. 1")
    assert len(cache.designs) == first  # hidden: neither preset's map computed
    tabs.active = 1
    # shown: the map of the scenario as it is now, computed once (not the trial's)
    assert [snap for _, snap in cache.designs[first:]] == [Snapshot.of(s, ERROR_MAP_READS)]
