"""One tab contract (issue 47, item 2): the page mounts its tabs from one list, ``app.page.TABS``,
and derives their titles, indices and visit hooks from it."""

import panel as pn
import pytest

from app import page
from app.kit.tab import Mount, Tab

pytestmark = pytest.mark.filterwarnings(  # Panel 1.9 deprecates button_type (as test_calibration_tab)
    "ignore:.*deprecated and will be removed in version 2.0:PendingDeprecationWarning")


def _titles(tabs):
    """The titles the page's Tabs show (its Bokeh model's panels: public Bokeh API)."""
    return [panel.title for panel in tabs.get_root().tabs]


def test_every_tab_module_exposes_the_contract():
    """Each tab's key is a part of the scenario (its own), its reads are inputs of the scenario,
    and its title is the one the page shows."""
    from app.state.scenario import PART_OF, PARTS

    assert [t.key for t in page.TABS] == ["maps", "design", "track", "calibration", "shape"]
    for tab in page.TABS:
        assert isinstance(tab, Tab) and tab.key in PARTS, tab
        assert tab.reads and set(tab.reads) <= set(PART_OF), tab
    tabs = page.create_app().main[0]
    assert _titles(tabs) == [t.title for t in page.TABS]


def test_a_tab_added_to_the_list_alone_is_mounted(monkeypatch):
    """A fake tab appended to ``TABS`` (no other edit) is on the page, built on its first visit
    with the session's scenario, and says the sensor kind over it when it asks to."""
    built = []

    def view(mount):
        built.append(mount)
        return pn.pane.Markdown("the fake tab's view", css_classes=["w-fake"])

    fake = Tab("fake", "Fake", view=view, reads=("Ph",), banner=True)
    monkeypatch.setattr(page, "TABS", (*page.TABS, fake))
    template = page.create_app()
    tabs = template.main[0]
    assert _titles(tabs)[-1] == "Fake" and len(tabs) == len(page.TABS)
    assert built == []  # hidden: built on its first visit, not before
    tabs.active = len(page.TABS) - 1
    assert len(built) == 1 and isinstance(built[0], Mount)
    assert built[0].scenario is template.scenario and built[0].cache is page.SHARED
    holder = tabs[len(page.TABS) - 1]
    shown = holder.select(pn.pane.Markdown)
    assert any(p.object == "the fake tab's view" for p in shown)
    # the banner over it, as over the Layout design and Track tabs (page.sensor_banner)
    assert any("w-design-sensor" in p.css_classes for p in holder.select(pn.pane.HTML))
    tabs.active = 0
    tabs.active = len(page.TABS) - 1
    assert len(built) == 1  # built once, kept
