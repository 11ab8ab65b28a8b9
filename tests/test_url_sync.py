"""The page URL follows the scenario (app.dashboard._sync_url), after the maps for map values."""

from app.dashboard import _sync_url
from app.scenario import Scenario


class FakeLocation:
    def __init__(self):
        self.updates = []

    def update_query(self, **query):
        self.updates.append(query)


def test_a_map_value_reaches_the_url_when_flushed_after_the_maps():
    scenario, location = Scenario(), FakeLocation()
    flush = _sync_url(scenario, location, {})
    scenario.Ph = 250.0
    scenario.Pv = 40.0
    assert location.updates == []  # waits for the maps: redraw flushes after sending them
    flush()
    assert location.updates == [{"Ph": "250.0", "Pv": "40.0"}]
    flush()
    assert len(location.updates) == 1  # nothing new, nothing sent


def test_a_design_only_value_reaches_the_url_at_once():
    scenario, location = Scenario(), FakeLocation()
    _sync_url(scenario, location, {})
    scenario.threshold = 7.0
    assert location.updates == [{"threshold": "7.0"}]


def test_a_link_value_that_would_be_refused_is_not_set_and_is_reported():
    scenario, location = Scenario(), FakeLocation()
    _sync_url(scenario, location, {"Ph": [b"250"], "h": [b"1e9"], "d": [b"abc"]})
    assert scenario.Ph == 250
    assert scenario.h == Scenario().h and scenario.d == Scenario().d
    assert "h:" in scenario.message and "d:" in scenario.message
    assert location.updates == []


def test_a_refused_value_never_reaches_the_url():
    # Scenario restores the last good value from inside the change's own event; the URL must hold
    # what the scenario holds (it took the refused -0.5, so a copied link reopened with an error).
    scenario, location = Scenario(), FakeLocation()
    flush = _sync_url(scenario, location, {})
    scenario.Ph = -0.5
    assert scenario.Ph == Scenario().Ph and "P_h" in scenario.message
    scenario.z = 150.0
    flush()
    assert location.updates == [{"Ph": f"{Scenario().Ph!r}", "z": "150.0"}]
