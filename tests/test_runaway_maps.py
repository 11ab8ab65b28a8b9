"""Issue 18: where the linearised bound stops predicting a tracker's error (CRLB > 30 % of the
range to the nearest station), the Maps and Layout design tabs say so instead of quoting
kilometres as errors. Without a browser; the served page is tested in test_browser.py."""

import numpy as np
import pytest

import core
from app.kit import views
from app.state.scenario import Scenario
from app.tabs.design import design
from app.tabs.design import compute as dc
from app.tabs.maps import compute as c
from app.tabs.maps import data as map_data, figures as map_figures
from app.tabs.maps.compute import Snapshot

CRLB = "CRLB position error (m)"


def _by_hand(plane, stations, crlb, observable):
    """The flag, point by point from its definition (no shared code with app.kit.runaway.runaway)."""
    u, v = plane.axes
    out = np.zeros(crlb.shape, dtype=bool)
    for i, vi in enumerate(v):
        for j, uj in enumerate(u):
            point = (uj, vi, plane.fixed) if plane.kind == "xy" else (uj, plane.fixed, vi)
            rng = min(np.linalg.norm(np.subtract(point, st)) for st in stations)
            out[i, j] = bool(observable[i, j] and np.isfinite(crlb[i, j]) and crlb[i, j] > 0.3 * rng)
    return out


@pytest.mark.parametrize("plane", ["x–y", "x–z"])
def test_crlb_maps_hatch_exactly_the_points_whose_bound_exceeds_30_percent_of_the_range(plane):
    s = Scenario(resolution=31, measure=CRLB, plane=plane)
    p = c.compute(Snapshot.of(s))
    ra, rb, rd = p.runaway
    expected = _by_hand(p.plane, p.stations[1], p.b.value, p.b.observable)
    np.testing.assert_array_equal(rb, expected)
    assert 0 < rb.sum() < rb.size  # both cases occur: near the stations the bound is trusted
    assert not ra.any()  # one station with the moments unknown: unobservable, veiled instead
    np.testing.assert_array_equal(rd, (ra | rb) & p.a.observable & p.b.observable & np.isfinite(p.diff))
    veils = map_data.prepare(p).veils
    hatched = np.isin(veils[1], (map_data.RUNAWAY, map_data.RUNAWAY_GAP))
    np.testing.assert_array_equal(hatched, rb)
    assert {map_data.RUNAWAY, map_data.RUNAWAY_GAP} <= set(np.unique(veils[1]))  # dotted
    assert f"{rb.sum() / p.b.observable.sum():.0%} of the observable points" in p.far_note
    assert "not as an error to quote" in p.far_note


def test_the_hover_of_a_hatched_point_says_the_bound_does_not_predict_there():
    p = c.compute(Snapshot.of(Scenario(resolution=21, measure=CRLB)))
    figs = map_figures.build()
    map_figures.fill(figs, p)
    assert "far-field runaway" in figs.formatters[1].args["texts"].runaway
    assert "runaway" in figs.formatters[2].args["texts"].runaway
    assert "value >= 4" in figs.formatters[1].code  # the text is added only on hatched codes


@pytest.mark.parametrize("measure", ["log10|det Γ| (paper)", "D-optimal ½·log10 det F"])
def test_maps_of_other_measures_carry_no_runaway_marks(measure):
    # the flag compares a bound in metres with a range: it has no meaning for the other measures
    p = c.compute(Snapshot.of(Scenario(resolution=21, measure=measure)))
    assert p.runaway == () and p.far_note == ""
    assert all(v.max() <= map_data.NO_VALUE for v in map_data.prepare(p).veils)


def test_the_layout_design_map_hatches_the_same_points():
    s = Scenario(resolution=31)
    d = dc.design(Snapshot.of(s, dc.ERROR_MAP_READS))
    far = _by_hand(d.plane, d.stations, d.errors.position, d.errors.observable)
    assert 0 < far.sum() < far.size
    layer = views.error_map(d, "t").get(2)  # image, veil, runaway hatching
    hatch = np.flipud(layer.data)  # hv.Image rows run from the top
    assert hatch.shape == far.shape
    assert not (hatch.astype(bool) & ~far).any()  # hatched only where flagged …
    # … in dots over all of it (DOT × DOT squares on a 2 DOT grid: a quarter of the points)
    assert hatch[far].mean() == pytest.approx(0.25, abs=0.1)


def test_a_clicked_far_point_says_its_bound_does_not_predict_an_error():
    s = Scenario()
    snap = Snapshot.of(s, dc.ERROR_MAP_READS)
    stations = np.array(s.stations.stations, dtype=float)
    near, far = (10.0, 10.0), (290.0, 290.0)
    texts = {}
    for x, y in (near, far):
        err = dc.error_at(snap, x, y)
        rng = float(np.min(np.linalg.norm(stations - [x, y, s.target.z], axis=1)))
        texts[(x, y)] = (float(err.position) / rng, views.error_ellipse(err, x, y, s.region.extent, rng)[1])
    assert texts[near][0] < 0.3 and "runaway" not in texts[near][1]
    assert texts[far][0] > 0.3 and "does not predict a tracker's error" in texts[far][1]


def test_the_optimiser_is_not_capped_below_the_region_and_reports_a_bound_it_hits():
    # issue 16 defect 7: the app passed a 200 m cap; a square of 4 came back at 200 m, at_bound
    s = Scenario(layout_kind="square", n_stations=4)
    r = dc.optimised_layout(Snapshot.of(s, dc.LAYOUT_READS))
    assert 250.0 < r.d < 2 * s.region.extent and r.at_bound == ()  # free optimum: side ~298 m (issue 16)
    np.testing.assert_allclose(r.stations[:, :2].mean(axis=0), 0.0, atol=1e-9)  # centred
    assert "spacing d = " in design.optimise_text(r, s.design.criterion)
    capped = type(r)(**{**r.__dict__, "at_bound": ("d_max",)})
    assert "largest spacing that fits in the region" in design.optimise_text(capped, s.design.criterion)


def test_the_track_is_drawn_over_the_snapshot_crlb_map_of_its_stations():
    # issue 18: "set or draw a straight track over the current map and stations"
    from app.tabs.track import track

    s = Scenario(track_runs=2, track_filter="ekf", track_duration=60.0)
    out = track.compute(s)
    d = out["map"]
    (x0, x1), (y0, y1) = out["window"]
    assert d.plane.u == (x0, x1) and d.plane.v == (y0, y1) and d.plane.fixed == s.target.z
    assert x0 <= out["truth"][:, 0].min() and out["truth"][:, 0].max() <= x1  # the track is on it
    # the map is the core's CRLB at the track's velocity, N instants (checked at one point)
    u, v = d.plane.axes
    i, j = 7, 11
    state = [u[j], v[i], s.target.z, *out["truth"][0, 3:5], s.target.Ph, s.target.Pv]
    one = core.crlb_maps(core.Plane("xy", (u[j], u[j] + 1), (v[i], v[i] + 1), s.target.z, 2),
                           d.stations, velocity=tuple(state[3:5]), moments=(s.target.Ph, s.target.Pv), T=s.sensor.T,
                           sensor=core.Sensor("E", s.sensor.noise, s.medium.sigma), steps=s.sensor.steps)
    assert d.errors.position[i, j] == pytest.approx(one.position[0, 0], rel=1e-9)
    layers = track.plan_view(out)
    image, hatch = layers.get(0), layers.get(1)
    assert image.vdims[0].unit == "log10 m"
    np.testing.assert_array_equal(np.flipud(hatch.data) > 0,
                                  c.runaway(d.plane, d.stations, d.errors.position, d.errors.observable)
                                  & map_data.runaway_dots((len(v), len(u))))
