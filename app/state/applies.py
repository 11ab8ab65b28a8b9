"""Where each input applies: the declared visibility rules
(:func:`app.state.parts.shown`) read against a scenario's values on a tab. The sidebar (app/page.py)
shows and hides its inputs by these, and the maps' downloads list only the inputs that apply
(app/tabs/maps/maps.py), so both read them here rather than one tab importing the page."""

from __future__ import annotations

from .scenario import COMPARISONS, MEASURE_LABELS, PART_OF, SENSORS, Where, parameter, shown

#: The tabs whose rules differ, by key (a tab's key is the name of its own part of the scenario:
#: app.kit.tab.Tab.key). Their order on the page, and so their indices, is the page's list of
#: tabs (app/page.py's TABS); a tab of another key shows the inputs that apply off the Maps and
#: Track tabs.
MAPS_TAB, DESIGN_TAB, TRACK_TAB, CALIBRATION_TAB, SHAPE_TAB = "maps", "design", "track", "calibration", "shape"


def sensor_kinds(s, tab):
    """The sensor kinds (core kinds E, B, G, BG) the inputs of tab ``tab`` feed: maps A's and B's
    on the Maps tab, the scenario's on the Layout design and Track tabs."""
    kind = SENSORS[s.sensor]
    if tab == MAPS_TAB and COMPARISONS[s.comparison] == "sensor_kinds":
        return {kind, SENSORS[s.sensor_b]}
    return {kind}


def where(s, tab):
    """What the inputs' visibility rules read (:class:`app.state.part.Where`) of scenario values ``s``
    (flat: a :meth:`Scenario.snapshot`) on tab ``tab``."""
    return Where(on_maps=tab == MAPS_TAB, on_track=tab == TRACK_TAB,
                 kinds=frozenset(sensor_kinds(s, tab)), sensor=SENSORS[s.sensor],
                 comparison=COMPARISONS[s.comparison], measure=MEASURE_LABELS[s.measure],
                 plane=s.plane, layout=s.layout, sea_model=s.sea_model)


def _read_by_where():
    """The inputs :func:`where` reads, on every tab and for every comparison (recorded as it
    reads them: no list to keep in step with it)."""
    read = set()

    class Values:
        def __init__(self, **given):
            self.given = given

        def __getattr__(self, name):
            read.add(name)
            return self.given.get(name, parameter(name).default)

    for tab in (MAPS_TAB, DESIGN_TAB, TRACK_TAB, CALIBRATION_TAB, SHAPE_TAB):
        for comparison in COMPARISONS:
            where(Values(comparison=comparison), tab)
    return tuple(n for n in PART_OF if n in read)


#: The inputs whose change can show or hide others: those :func:`where` reads.
DECIDING = _read_by_where()


def applies(name, s, tab):
    """Whether the input of parameter ``name`` applies to scenario values ``s`` (flat: a
    :meth:`Scenario.snapshot`) on tab ``tab``, by its declared rule (others are hidden: Fixed y
    in x–y, target depth in x–z, the maps' controls on the design tab)."""
    if tab in (CALIBRATION_TAB, SHAPE_TAB):  # problems with inputs of their own, in their tabs
        return False
    return shown(name, where(s, tab))


__all__ = ["CALIBRATION_TAB", "DECIDING", "DESIGN_TAB", "MAPS_TAB", "SHAPE_TAB", "TRACK_TAB",
           "applies", "sensor_kinds", "where"]
