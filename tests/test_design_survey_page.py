"""The Layout design tab's survey controls without a browser (issue 49 item 5): the survey
inputs' refusals and their link, the zones drawn, the fixed column, the constraints in the page's
words, the optimiser with them, the N−1 map and the stations-count curve's view."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import core
from app.state import url
from app.state.scenario import CRITERIA, Scenario
from app.state.survey import N1_MAP, SURVEY_CRITERIA
from app.tabs.design import compute as dc, constraints, survey, survey_compute
from app.state.snapshot import Snapshot

SQUARE = [[0.0, -50.0], [80.0, -50.0], [80.0, 50.0], [0.0, 50.0]]


def test_a_self_intersecting_or_short_zone_is_refused_by_name_and_the_last_good_zones_kept():
    s = Scenario()
    s.survey.zones = [SQUARE]
    assert s.message == "" and s.survey.zones == [SQUARE]
    s.survey.zones = [SQUARE, [[0, 0], [10, 10], [10, 0], [0, 10]]]  # a bow tie
    assert s.survey.zones == [SQUARE] and s.refused == ["zones"]
    assert s.message.startswith("Forbidden zone 2 is self-intersecting")
    s.survey.zones = [[[0, 0], [10, 0]]]
    assert s.survey.zones == [SQUARE] and "Forbidden zone 1 has 2 vertices" in s.message
    s.survey.fixed_stations = [0]
    assert s.survey.fixed_stations == [] and "station numbers 1 … 8" in s.message


def test_the_survey_inputs_go_through_a_link_and_back():
    s = Scenario()
    s.update(dict(zones=[SQUARE], fixed_stations=[2], min_spacing=30.0,
                  criterion="N−1 coverage: area under threshold with any one station lost (share)",
                  error_quantity=N1_MAP))
    assert s.message == ""
    query = url.query(s)
    t = Scenario()
    link = url.read_link(t, {k: [v] for k, v in url.parse_qsl(query.lstrip("?"))})
    assert link.problems == {}
    assert {n: t.value(n) for n in ("zones", "fixed_stations", "min_spacing", "criterion", "error_quantity")} == \
        {n: s.value(n) for n in ("zones", "fixed_stations", "min_spacing", "criterion", "error_quantity")}


def test_a_link_with_a_bad_zone_is_refused_naming_it():
    link = url.read_link(Scenario(), {"zones": ["[[[0,0],[1,1],[1,0],[0,1]]]"]})
    assert "Forbidden zone 1 is self-intersecting" in link.problems["zones"]


def test_drawn_zones_drop_the_closing_vertex_and_round_to_the_tables_step():
    data = {"xs": [[0.04, 80.0, 80.0, 0.04]], "ys": [[-50.0, -50.0, 50.0123, -50.0]]}
    assert survey.drawn_zones(data) == [[[0.0, -50.0], [80.0, -50.0], [80.0, 50.0]]]
    assert survey.drawn_zones({"xs": [], "ys": []}) == []


def test_the_fixed_column_reads_back_the_fixed_stations():
    df = survey.frame([[0, 0, 100], [15, 0, 100], [0, 30, 90]], [1, 3], ["x (m)", "y (m)", "z (m)"])
    assert df[survey.FIXED].tolist() == [True, False, True]
    assert survey.fixed_of(df) == [1, 3]
    assert survey.fixed_of(pd.DataFrame({"x (m)": [0.0]})) == []


def values(**kw):
    s = Scenario()
    s.update(kw)
    assert s.message == ""
    return Snapshot.of(s, dc.LAYOUT_READS).scenario()


def test_the_constraints_name_a_fixed_station_in_a_zone_and_a_broken_spacing_from_1():
    s = values(stations=[[-100.0, 0.0, 100.0], [40.0, 0.0, 100.0], [60.0, 0.0, 100.0]],
               fixed_stations=[2, 3], zones=[[[-300, -300], [-250, -300], [-250, -250]], SQUARE],
               min_spacing=30.0)
    assert constraints.problems(s) == [
        "fixed station 2 at (40, 0) m lies inside forbidden zone 2",
        "fixed station 3 at (60, 0) m lies inside forbidden zone 2",
        "fixed stations 2 and 3 are 20 m apart, closer than the minimum spacing 30 m"]
    with pytest.raises(ValueError, match="fixed station 2 at"):  # before any search
        constraints.layout_constraints(s)
    # a fixed station past the table's rows (deleted since) fixes nothing
    assert constraints.fixed_rows(values(fixed_stations=[1, 5])) == [0]


def test_the_optimiser_keeps_the_fixed_station_and_puts_none_in_a_zone():
    s = Scenario()
    s.update(dict(stations=[[-150.0, 0.0, 100.0], [150.0, 0.0, 100.0]], fixed_stations=[1],
                  zones=[[[-60, -250], [250, -250], [250, 250], [-60, 250]]], layout_kind="free",
                  n_stations=2, criterion="Mean CRLB position error, A (m)"))
    r = dc.optimised_layout(Snapshot.of(s, dc.LAYOUT_READS))
    assert r.fixed == 1 and r.stations[0].tolist() == [-150.0, 0.0, 100.0]
    zone = core.LayoutConstraints(zones=s.survey.zones)
    assert len(r.stations) == 3 and (zone.in_zone(r.stations) < 0).all()


def test_the_n1_map_is_the_worst_single_loss_of_the_layout():
    s = Scenario(resolution=21)
    s.update(dict(stations=[[-100.0, 0.0, 100.0], [100.0, 0.0, 100.0], [0.0, 120.0, 100.0]],
                  error_quantity=N1_MAP))
    d = survey_compute.loss_design(Snapshot.of(s, survey_compute.LOSS_READS))
    v = Snapshot.of(s, survey_compute.LOSS_READS).scenario()
    problem = core.LayoutProblem(dc.xy_region(v, 21), velocity=v.velocity(), moments=v.moments(),
                                 threshold=v.threshold, **dc._fisher_options(v))
    want = core.station_loss(np.array(s.stations.stations), problem).worst
    np.testing.assert_array_equal(d.errors.position, want)  # the same computation: exact
    # the rest of the map is the whole layout's (the ellipse's semi-axes etc.)
    whole = dc.design(Snapshot.of(s, dc.ERROR_MAP_READS))
    np.testing.assert_array_equal(d.errors.semi_major, whole.errors.semi_major)
    assert survey_compute.error_map_of(N1_MAP) is survey_compute.loss_design
    text = survey_compute.coverage_text(d.loss)
    assert all(f"{k + 1}: {c:.0%}" in text for k, c in enumerate(d.loss.coverage_left))


@pytest.mark.parametrize("label", list(CRITERIA))
def test_each_criterion_says_its_unit_on_the_page(label):
    assert f"unit: **{core.CRITERIA[CRITERIA[label]][1]}**" in survey.unit_text(label)


def test_the_new_criteria_are_offered():
    assert set(SURVEY_CRITERIA.values()) == {"mean_crlb", "worst_direction", "worst_crlb", "area_crlb_n1"}


def test_the_count_curve_plot_marks_the_knee_with_units():
    problem = core.LayoutProblem(core.Plane("xy", (-300, 300), (-300, 300), 120.0, 7),
                                 criterion="area_crlb", threshold=10.0)
    curve = core.station_count_curve(problem, kind="square", n_max=4, n_curve=4)
    label = "Area with CRLB error under threshold"
    count = survey_compute.Count(curve=curve, criterion="area_crlb", label=label)
    plot = survey.count_plot(count)
    curve_el = plot.Curve.I
    assert curve_el.kdims[0].pprint_label == "Stations N (fixed counted)"
    assert curve_el.vdims[0].unit == "dimensionless"
    np.testing.assert_array_equal(curve_el.dimension_values(0), curve.n[np.isfinite(curve.value)])
    if curve.knee is not None:
        assert plot.VLine.I.data == curve.knee and f"N = {curve.knee}" in survey.count_text(count)
    else:
        assert "no knee" in survey.count_text(count)


def test_the_fixed_rows_of_an_optimised_layout_are_found_by_position():
    assert survey.rows_of([[1.0, 2.0, 3.0], [150.0, 0.0, 100.0], [4, 5, 6]], [[150, 0, 100]]) == [2]
    assert survey.rows_of([[1.0, 2.0, 3.0]], []) == []
