"""Each input declared once (issue 39 item 1): the sidebar, what it shows where, the hard limits
and the depths are built from the inputs' declarations alone (app.state.part: a parameter's metadata)."""

from __future__ import annotations

import math

import panel as pn
import param
import pytest

from app import page as dashboard
from app.state import applies
from app.state.part import declared
from app.state.scenario import (
    ACCEPTED,
    CARDS,
    DEPTHS,
    PART_OF,
    PARTS,
    Scenario,
    parameter,
    shown,
    sidebar,
)

#: Scenarios that change what applies: the sensor kinds, a layered sea, the plane, the comparisons.
VARIANTS = [{}, dict(sensor="magnetometer (B, nT)"), dict(sensor="gradiometer (G, nT/m)"),
            dict(sensor="magnetometer + gradiometer (BG)"), dict(sea_model="layered"),
            dict(plane="x–z"), dict(layout="single", comparison="Moments ×k − original (Fig. 3)"),
            dict(comparison="Moment split B − A (Fig. 4)"),
            dict(comparison="Moment split B − A (Fig. 4)", sensor="magnetometer (B, nT)"),
            dict(comparison="Spacing d − reference d (Fig. 6)"),
            dict(comparison="Sensor kind B − A (seed 003)"), dict(measure="CRLB position error (m)")]
TABS = (applies.MAPS_TAB, applies.DESIGN_TAB, applies.TRACK_TAB)
#: Each tab's index on the page, from its list of tabs (app.page.TABS).
INDEX = {tab.key: i for i, tab in enumerate(dashboard.TABS)}


def on_a_card():
    return [n for n in PART_OF if "card" in declared(parameter(n))]


def test_the_sidebar_is_the_declared_cards_each_input_once_in_its_place():
    cards = sidebar()
    assert [title for title, _, _ in cards] == list(CARDS)
    placed = [n for _, names, _ in cards for n in names]
    assert sorted(placed) == sorted(on_a_card()) and len(placed) == len(set(placed))
    for title, names, collapsed in cards:
        assert collapsed == CARDS[title]
        places = [declared(parameter(n))["card"] for n in names]
        assert all(t == title for t, _ in places) and [p for _, p in places] == sorted(p for _, p in places)
    assert dashboard.SECTIONS == cards


def test_the_sidebar_built_shows_each_input_where_its_declared_rule_says():
    """The page's cards, built, hold the declared inputs in order, each visible exactly where its
    rule holds, on each tab and for each scenario that changes what applies."""
    for values in VARIANTS:
        s = Scenario(**values)
        tabs = pn.Tabs(*[(str(i), pn.Column()) for i in range(5)])
        built = {title: dashboard._section(s, tabs, title, names, collapsed=False)
                 for title, names, _ in sidebar()}
        for tab in TABS:
            tabs.active = INDEX[tab]
            w = applies.where(s.snapshot(), tab)
            for title, names, _ in sidebar():
                card = built[title][0]
                rows = {name: row for row in card.objects for name in names
                        if any(f"w-{name}" in getattr(o, "css_classes", []) for o in row.select())}
                assert len(rows) == len(card.objects)  # one input per row
                # in their declared places; an input is built when it first applies
                assert list(rows) == [n for n in names if n in rows]
                for name in names:
                    if name in rows:
                        assert rows[name].visible == shown(name, w), (values, tab, name)
                    else:
                        assert not shown(name, w), (values, tab, name)
                assert built[title].visible == any(shown(n, w) for n in names)


def test_a_new_page_builds_only_the_inputs_that_apply():
    """A card holds the inputs that applied at some time in the session, nothing more: a new page
    the ones that apply to it (a magnetic sensor's moment, a layered sea's depth are built when
    they first apply), a collapsed card none until it is opened."""
    for values in VARIANTS:
        s = Scenario(**values)
        tabs = pn.Tabs(*[(str(i), pn.Column()) for i in range(5)])
        w = applies.where(s.snapshot(), applies.MAPS_TAB)
        for title, names, collapsed in sidebar():
            card = dashboard._section(s, tabs, title, names, collapsed)[0]
            wanted = [] if collapsed else [n for n in names if shown(n, w)]
            assert len(card.objects) == len(wanted), (values, title)
            for name, row in zip(wanted, card.objects):
                assert any(f"w-{name}" in getattr(o, "css_classes", []) for o in row.select()), name
            if collapsed:
                card.collapsed = False
                assert len(card.objects) == len([n for n in names if shown(n, w)])
    s = Scenario()
    tabs = pn.Tabs(*[(str(i), pn.Column()) for i in range(5)])
    built = {title: dashboard._section(s, tabs, title, names, collapsed)[0] for title, names, collapsed in sidebar()}
    before = sum(len(c.objects) for c in built.values())
    s.update(sensor="magnetometer (B, nT)")  # the moment's three inputs now apply
    mx = [row for row in built["Target"].objects
          if any("w-mx" in getattr(o, "css_classes", []) for o in row.select())]
    assert len(mx) == 1 and mx[0].visible
    assert sum(len(c.objects) for c in built.values()) > before


def test_what_decides_visibility_is_what_the_rules_read():
    """DECIDING (recorded from applies.where) holds every input a rule's answer depends on: the
    answer of every rule for every variant changes only through those inputs."""
    assert {"plane", "comparison", "measure", "sensor", "sensor_b", "sea_model", "layout"} <= set(applies.DECIDING)
    base = Scenario().snapshot()
    for tab in TABS:
        before = {n: shown(n, applies.where(base, tab)) for n in on_a_card()}
        for name in set(PART_OF) - set(applies.DECIDING):
            p = parameter(name)
            if isinstance(p, param.Number) and not isinstance(p, param.Integer):
                other = Scenario().snapshot()
                setattr(other, name, p.default + 1.0)
                assert {n: shown(n, applies.where(other, tab)) for n in on_a_card()} == before


def test_the_limits_are_the_declared_ones_and_refuse_what_is_outside():
    declared_limits = {n: declared(parameter(n))["hard"] for n in PART_OF if "hard" in declared(parameter(n))}
    assert ACCEPTED == declared_limits
    assert all(cls.accepted == {n: declared_limits[n] for n in cls.names() if n in declared_limits}
               for cls in PARTS.values())
    # every number shown in the sidebar has limits: nothing typed there reaches the core unchecked
    numbers = [n for n in on_a_card() if isinstance(parameter(n), param.Number)]
    assert numbers and set(numbers) <= set(ACCEPTED)
    for name, (lo, hi, _unit) in ACCEPTED.items():
        integer = isinstance(parameter(name), param.Integer)
        step = 1 if integer else max(abs(hi), abs(lo), 1.0) * 1e-6
        for bad in (lo - step, hi + step):
            assert Scenario.problem(name, int(bad) if integer else bad), (name, bad)
        good = lo if not integer else int(lo)
        assert Scenario.problem(name, good) is None or name in DEPTHS and good < 0, (name, good)


def test_the_depths_are_the_declared_ones():
    assert set(DEPTHS) == {"h", "z", "z_min", "z_max"}
    assert all(parameter(n).label for n in DEPTHS)
    for name in DEPTHS:
        assert "above the sea surface" in Scenario.problem(name, -1.0)
    s = Scenario(sea_model="layered", sea_depth=50.0)
    s.update(z=60.0)  # outside the water column: refused with the declared depths' rule
    assert s.target.z != 60.0 and "water column" in s.message


@pytest.mark.parametrize("name", ["noise"])
def test_a_number_declared_without_a_slider_has_a_box_only(name):
    assert name not in dashboard.NUMBERS and not math.isnan(parameter(name).default)
    assert declared(parameter(name))["slider"] is False


# -- no hand-kept list of input names in app/ ------------------------------------------------

def _watch_lists(tree):
    """ids of the literals given as what a watcher or a computation reads: ``.watch(fn, [..])``,
    ``.watch_inputs(fn, [..])`` and ``inputs(..., but=(..))`` (tests/test_tab_keys.py checks the
    computations' reads)."""
    import ast

    ids = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, (ast.Attribute, ast.Name)):
            fname = node.func.attr if isinstance(node.func, ast.Attribute) else node.func.id
            if fname in ("watch", "watch_inputs") and len(node.args) >= 2:
                ids.add(id(node.args[1]))
            ids.update(id(k.value) for k in node.keywords if fname == "inputs" and k.arg == "but")
    return ids


def test_no_module_of_app_keeps_a_list_of_input_names():
    """A tuple, list, set or dict's keys written in app/ whose strings are all input names (two
    or more) is a hand-kept list: what it says belongs in the inputs' declarations (app.state.part). A
    watcher's list of what it reads is not one (the tab-key test checks the computations')."""
    import ast
    import pathlib

    app_dir = pathlib.Path(applies.__file__).parent
    found = []
    for path in sorted(app_dir.rglob("*.py")):
        tree = ast.parse(path.read_text())
        exempt = _watch_lists(tree)
        for node in ast.walk(tree):
            if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
                elts = node.elts
            elif isinstance(node, ast.Dict):
                elts = [k for k in node.keys if k is not None]
            else:
                continue
            strings = [e.value for e in elts if isinstance(e, ast.Constant) and isinstance(e.value, str)]
            if (len(strings) >= 2 and len(strings) == len(elts) and set(strings) <= set(PART_OF)
                    and id(node) not in exempt):
                found.append(f"{path.name}:{node.lineno} {strings}")
    assert found == []


def test_the_check_finds_a_hand_kept_list(tmp_path, monkeypatch):
    """The check above fails on the lists it replaced (e.g. url.SEABED_INPUTS as it was)."""
    import ast

    tree = ast.parse('SEABED_INPUTS = ("h", "z", "z_min", "z_max", "model", "stations")\n'
                     'scenario.watch_inputs(fn, ["h", "z"])\n')
    exempt = _watch_lists(tree)
    lists = [n for n in ast.walk(tree) if isinstance(n, ast.Tuple | ast.List)]
    assert [id(n) in exempt for n in lists] == [False, True]


# -- what the page derives from the declarations -----------------------------------------------

def test_what_a_layered_sea_moves_is_what_the_inputs_declare():
    """Switching to a layered sea moves exactly the inputs declared with ``seabed`` or
    ``layered``; the link writes those (url.SEABED_INPUTS); the ones declared on the seabed
    follow the sea depth."""
    from app.state import url
    from app.state.derive import LAYERED, SEABED

    assert set(url.SEABED_INPUTS) == set(SEABED) | set(LAYERED)
    assert SEABED == {"z": "within", "h": "bottom", "stations": "bottom", "z_min": "surface",
                      "z_max": "bottom"} and LAYERED == {"model": "exact dipole"}
    s = Scenario(z=250.0, h=300.0, z_min=20.0, z_max=600.0, model="paper eqs. (10)–(12) as printed",
                 stations=[[0.0, 0.0, 300.0], [10.0, 0.0, 40.0]], sea_depth=200.0)
    before = s.values()
    s.medium.sea_model = "layered"
    moved = {n for n, v in s.values().items() if v != before[n]} - {"sea_model"}
    assert moved == set(SEABED) | set(LAYERED)
    assert (s.stations.h, s.target.z, s.region.z_min, s.region.z_max) == (200.0, 200.0, 0.0, 200.0)
    assert s.stations.stations == [[0.0, 0.0, 200.0], [10.0, 0.0, 200.0]]
    assert s.medium.model == "exact dipole"
    s.stations.stations = [[0.0, 0.0, 200.0], [10.0, 0.0, 50.0]]
    s.target.z = 120.0
    s.medium.sea_depth = 150.0  # on the seabed ("bottom"): they follow it; the others stay
    assert (s.stations.h, s.region.z_max, s.target.z, s.region.z_min) == (150.0, 150.0, 120.0, 0.0)
    assert s.stations.stations == [[0.0, 0.0, 150.0], [10.0, 0.0, 50.0]]
    # a layered sea's link carries them even at their defaults
    q = url.query(Scenario(sea_model="layered"))
    assert all(f"{n}=" in q for n in url.SEABED_INPUTS)


#: Panel 1.9 deprecates a widget's ``name`` (its label) for ``label``, which Panel 1.5 (the lowest
#: version supported) does not have: the Shape tab's case selector still passes ``name``.
WIDGET_NAME = pytest.mark.filterwarnings("ignore:Widget.name is deprecated:PendingDeprecationWarning")


@WIDGET_NAME
def test_the_numbers_formats_are_the_declared_ones():
    """Every number box's slider, in the sidebar and in the tabs' own inputs, has its declared
    format (``fmt``), else the default."""
    from app.tabs.shape import shape
    from app.tabs.track import track

    s = Scenario()
    built = {}
    # an input is built when it first applies: every scenario that changes what applies, on
    # every tab, builds them all
    for k, values in enumerate(VARIANTS):
        tabs = pn.Tabs(*[(str(i), pn.Column()) for i in range(5)])
        for title, names, _ in sidebar():
            built[title, k] = dashboard._section(Scenario(**values), tabs, title, names, collapsed=False)
        for tab in TABS:
            tabs.active = INDEX[tab]
    built["shape"] = shape._inputs(s)
    built["track"] = track.track_tab(s)
    sliders = {}
    for layout in built.values():
        for col in layout.select(pn.Column):
            names = [c[2:] for c in col.css_classes if c.startswith("w-") and c[2:] in PART_OF]
            found = col.select(pn.widgets.FloatSlider)
            if names and len(found) == 1:
                sliders[names[0]] = found[0]
    numbers = [n for n in PART_OF if type(parameter(n)) is param.Number]
    shown_with_slider = set(dashboard.NUMBERS) | set(shape.PARAMS) | set(s.track.names())
    expected = {n for n in numbers if n in shown_with_slider}
    assert expected <= set(sliders), sorted(expected - set(sliders))
    for name in expected:
        assert sliders[name].format == declared(parameter(name)).get("fmt", "0.[00]"), name
    assert {n for n in PART_OF if "fmt" in declared(parameter(n))} >= {"noise_b", "shape_noise", "track_alpha"}


@WIDGET_NAME
def test_the_shape_tabs_cards_are_the_declared_groups():
    from app.state.derive import groups
    from app.tabs.shape import shape

    cards = shape._inputs(Scenario()).select(pn.Card)
    declared_groups = groups(shape.PARAMS)
    assert [c.title for c in cards] == [title for title, _ in declared_groups]
    assert sum(len(names) for _, names in declared_groups) == len(shape.PARAMS)
    for card, (_, names) in zip(cards, declared_groups):
        shown_names = [c[2:] for row in card.objects for o in row.select()
                       for c in getattr(o, "css_classes", []) if c[2:] in names]
        assert list(dict.fromkeys(shown_names)) == names
        for name in names:  # a number: a box and a slider; a choice: a select; text: a text box
            row = next(r for r in card.objects if any(f"w-{name}" in getattr(o, "css_classes", [])
                                                      for o in r.select()))
            widget_types = {type(o) for o in row.select(pn.widgets.Widget)}
            p = parameter(name)
            if isinstance(p, param.Number):
                assert widget_types & {pn.widgets.FloatSlider, pn.widgets.IntSlider}, name
            else:
                assert (pn.widgets.TextInput if isinstance(p, param.String) else pn.widgets.Select) in widget_types


def test_the_calibration_inputs_show_for_their_declared_sources():
    from app.tabs.calibration import calibration

    s = Scenario()
    widgets = {n: calibration._input(s, n) for n in calibration.FIELDS}
    sources = parameter("cal_source").objects
    only = {n: declared(parameter(n))["sources"] for n in calibration.FIELDS
            if "sources" in declared(parameter(n))}
    assert set(only) == {"cal_headings", "cal_roll_deg", "cal_pitch_deg", "cal_n_attitudes", "cal_seed"}
    for source in sources:
        s.calibration.cal_source = source
        for name, w in widgets.items():
            assert w.visible == (source in only.get(name, sources)), (source, name)
    assert calibration.BE == ("cal_be_n", "cal_be_e", "cal_be_d")


def test_the_moments_known_are_the_declared_moments_and_cores_moment_states():
    """The "moments known" state set drops the target's moment inputs of the sensor kind, which
    are core's moment states of that kind's Sensor."""
    from app.state.derive import moments
    from app.state.scenario import SENSORS, STATE_SETS

    for label, kind in SENSORS.items():
        for state_set, known in STATE_SETS.items():
            v = Scenario(sensor=label, state_set=state_set,
                         measure="CRLB position error (m)").snapshot()
            opts = v.core_options()
            assert opts["known"] == (opts["sensor"].state_names[5:] if known else ())
            assert moments(kind) == tuple(opts["sensor"].state_names[5:])
            assert v.moments() == tuple(getattr(v, n) for n in moments(kind))


def test_the_sensor_banner_follows_every_input_the_magnetic_kinds_read():
    from app.state.derive import MAGNETIC_READS

    assert set(MAGNETIC_READS) == {"mx", "my", "mz", "noise_b", "noise_g", "baseline"}
    s = Scenario(sensor="magnetometer + gradiometer (BG)")
    banner = dashboard.sensor_banner(s, applies.TRACK_TAB)
    assert banner.visible
    for name in MAGNETIC_READS:
        before = banner.object
        s.update({name: s.value(name) + 0.5})
        assert banner.object != before, name
