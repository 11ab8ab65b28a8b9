"""Each input declared once (issue 39 item 1): the sidebar, what it shows where, the hard limits
and the depths are built from the inputs' declarations alone (app.part: a parameter's metadata)."""

from __future__ import annotations

import math

import panel as pn
import param
import pytest

from app import applies, dashboard
from app.part import declared
from app.scenario import (
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
            tabs.active = tab
            w = applies.where(s.snapshot(), tab)
            for title, names, _ in sidebar():
                card = built[title][0]
                rows = list(card.objects)
                assert len(rows) == len(names)
                for name, row in zip(names, rows):
                    assert any(f"w-{name}" in getattr(o, "css_classes", []) for o in row.select()), name
                    assert row.visible == shown(name, w), (values, tab, name)
                assert built[title].visible == any(shown(n, w) for n in names)


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
