"""The dashboard's state and computations, without a browser."""

import csv
import dataclasses
import math

import numpy as np
import pytest
import xarray as xr

from app.kit import views
from app.kit.cache import PanelCache
from app.state.scenario import (
    ACCEPTED,
    DEPTHS,
    PAPER_MAPS,
    PART_OF,
    PARTS,
    PRESET_INPUTS,
    PRESETS,
    Scenario,
    parameter,
)
from app.tabs.design import compute as dc
from app.tabs.maps import data as map_data, downloads, figures as map_figures
from app.tabs.maps.compute import READS, Snapshot, compute


def test_presets_set_what_the_paper_says():
    s = Scenario()
    for name in (n for n in PRESETS if n.startswith("Fig.")):  # the paper's figures
        s.apply_preset(name)
        # common parameters (spec §5)
        assert (s.target.Ph, s.stations.h, s.sensor.T) == (PRESETS[name]["Ph"], 100.0, 1.0)
        vx, vy = s.snapshot().velocity()
        assert math.isclose(vx, 2.0) and math.isclose(vy, 2.0)
        assert s.message == ""
    s.apply_preset("Fig. 1")
    assert (s.region.plane, s.target.z, s.stations.layout, s.target.Pv, s.region.extent) == ("x–y", 120.0, "single", 20.0, 300.0)
    s.apply_preset("Fig. 2")
    assert (s.region.plane, s.region.y, s.region.z_min, s.region.z_max, s.maps.Ph_b, s.maps.Pv_b) == ("x–z", 50.0, 100.0, 400.0, 100.0, 100.0)
    s.apply_preset("Fig. 3")
    assert s.maps.k == 10.0 and s.maps.comparison.startswith("Moments ×k")
    s.apply_preset("Fig. 4")
    assert (s.target.Ph, s.target.Pv, s.maps.Ph_b, s.maps.Pv_b) == (100.0, 0.0, 70.7, 70.7)
    s.apply_preset("Fig. 5")
    assert s.maps.comparison.startswith("Dual − single") and s.stations.d == 15.0
    s.apply_preset("Fig. 6")
    assert (s.stations.d, s.maps.d_ref) == (50.0, 10.0)


@pytest.mark.parametrize("name", sorted(ACCEPTED))
def test_out_of_range_values_are_refused_with_a_message(name):
    s = Scenario()
    before = s.value(name)
    lo, hi, _ = ACCEPTED[name]
    for bad in (hi * 10 + 10, lo - abs(lo) - 10):
        setattr(s.part_of(name), name, int(bad) if isinstance(before, int) else float(bad))
        assert s.value(name) == before, "the last good value is kept"
        why = "above the sea surface" if name in DEPTHS and bad < 0 else "outside the accepted range"
        assert why in s.message and s.refused == [name]
    if not isinstance(before, int):
        setattr(s.part_of(name), name, float("nan"))
        assert s.value(name) == before and "must be a number" in s.message
    # a good value clears the message
    setattr(s.part_of(name), name, before + 1 if before + 1 <= hi else before * 1.5)
    assert s.message == ""


def test_accepted_ranges_are_what_the_core_accepts():
    # The lowest accepted speed, T, σ and noise must still be accepted by the core.
    s = Scenario(speed=ACCEPTED["speed"][0], T=ACCEPTED["T"][0], sigma=ACCEPTED["sigma"][0],
                 noise=ACCEPTED["noise"][0], resolution=ACCEPTED["resolution"][0])
    p = compute(Snapshot.of(s))
    assert np.isfinite(p.b.value).mean() > 0.99


def test_depth_band_must_be_ordered():
    s = Scenario()
    s.region.z_max = 50.0  # shallower than z_min = 100
    assert s.region.z_max == 400.0 and "deeper" in s.message


def test_fig5_single_is_flagged_dual_is_observable():
    s = Scenario(resolution=41)
    s.apply_preset("Fig. 5")
    p = compute(Snapshot.of(s))
    assert not p.a.observable.any()
    assert p.b.observable.mean() > 0.95
    assert "rank Γ = 6" in p.note and "round-off" in p.note
    # the one-click remedy: moments known and a measure that uses all rows
    s.update(state_set="moments known (5 states)", measure="D-optimal ½·log10 det F")
    p = compute(Snapshot.of(s))
    assert p.a.observable.mean() > 0.95 and p.b.observable.mean() > 0.95 and p.note == ""
    # the paper's square rule with known moments keeps only instant-k rows for two stations
    s.maps.measure = "log10|det Γ| (paper)"
    assert "cannot see the speed" in compute(Snapshot.of(s)).note


def test_moment_scaling_difference_is_five_decades_for_dual():
    s = Scenario(resolution=21, layout="dual", comparison="Moments ×k − original (Fig. 3)", k=10.0,
                 difference="Signed log-ratio")
    p = compute(Snapshot.of(s))
    finite = np.isfinite(p.diff)
    np.testing.assert_allclose(p.diff[finite], 5.0, atol=1e-8)


def test_cache_computes_once_per_scenario():
    calls = []

    def counted(snap):
        calls.append(1)
        return compute(snap)

    cache = PanelCache(size=2)
    s = Scenario(resolution=21)
    for _ in range(3):
        cache.get(Snapshot.of(s), counted)
    assert len(calls) == 1
    s.target.Ph = 50.0
    cache.get(Snapshot.of(s), counted)
    assert len(calls) == 2


def test_the_cache_is_shared_computes_a_key_once_and_stays_within_its_bounds():
    """Issue 29: results are shared by the sessions of a process (two visitors of the default
    view cost one computation, even when they ask at the same time), bounded in entries and
    bytes, and read-only (no session's view can change what another sees)."""
    import threading
    import time as _time

    calls = []

    def slow(snap):
        calls.append(snap)
        _time.sleep(0.3)
        return compute(snap)

    cache = PanelCache(size=3)
    first, second = Scenario(resolution=21), Scenario(resolution=21)  # two sessions, same view
    results = []
    threads = [threading.Thread(target=lambda s=s: results.append(cache.get(Snapshot.of(s), slow)))
               for s in (first, second)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(calls) == 1 and results[0] is results[1]
    with pytest.raises(ValueError, match="read-only"):
        results[0].a.value[0, 0] = 1.0
    for ph in (10.0, 20.0, 30.0, 40.0):  # entries beyond the size push the oldest out
        first.target.Ph = ph
        cache.get(Snapshot.of(first), slow)
    assert len(calls) == 5
    cache.get(Snapshot.of(second), slow)  # the default view was the least recently used
    assert len(calls) == 6
    one = results[0]
    nbytes = sum(a.nbytes for a in (one.a.value, one.b.value, one.diff))
    small = PanelCache(size=10, max_bytes=int(2.5 * nbytes))  # room for about two results
    for ph in (10.0, 20.0, 30.0):
        first.target.Ph = ph
        small.get(Snapshot.of(first), compute)
    assert len(small) <= 2 and small.nbytes <= small.max_bytes


def test_a_failed_computation_is_not_cached_and_does_not_block_the_next_asker():
    cache = PanelCache()
    snap = Snapshot.of(Scenario(resolution=21))

    attempts = []

    def flaky(snap):
        attempts.append(1)
        if len(attempts) == 1:
            raise RuntimeError("no")
        return compute(snap)

    with pytest.raises(RuntimeError):
        cache.get(snap, flaky)
    assert cache.get(snap, flaky) is not None and len(attempts) == 2  # computed again, once
    assert cache.get(snap, flaky) is not None and len(attempts) == 2


def test_downloads_carry_data_and_parameters():
    s = Scenario(resolution=21)
    p = compute(Snapshot.of(s))
    params = dict(Snapshot.of(s).items)
    ds = xr.open_dataset(downloads.to_netcdf(p, params), engine="h5netcdf")
    np.testing.assert_array_equal(ds["B"].values, p.b.value)
    assert ds.attrs["Ph"] == 100.0 and ds["x"].attrs["units"] == "m"
    text = downloads.to_csv(p, params).read()
    assert "# Ph = 100.0" in text
    rows = [line for line in text.splitlines() if not line.startswith("#")]
    assert len(rows) == 1 + 21 * 21 and rows[0].startswith("y (m),x (m),")
    # issue 25: the columns name the measure and unit (they were A, B, difference)
    assert f"A: {p.value_label}" in rows[0] and f"B vs A: {p.diff_label}" in rows[0]
    assert downloads.download_name(p, "csv") == "fig_5_x_y_log10_det.csv"


def test_maps_for_every_measure_and_plane():
    figs = map_figures.build()
    for plane in ("x–y", "x–z"):
        for measure in parameter("measure").objects:
            s = Scenario(resolution=21, plane=plane, measure=measure)
            p = compute(Snapshot.of(s))
            maps, (xname, vname), clim, diff_range, _ = map_data.contents(p)
            assert len(maps) == 3 and vname == ("y" if plane == "x–y" else "z")
            assert clim[0] < clim[1] and diff_range[0] < diff_range[1]
            map_figures.fill(figs, p)
            assert figs.figures[2].yaxis.axis_label.startswith(f"{vname} (m)")  # x–z: ", vertical ×2"
            assert figs.images[1].data["image"][0].dtype == np.float32
            low, high, _ = map_data.ranges(p)[1]
            np.testing.assert_array_equal(figs.images[1].data["image"][0],
                                          map_data.normalised(p.shown(1), low, high))


@pytest.mark.parametrize("bad,why", [
    ([], "1 to 8 stations"),
    ([[0.0, 0.0, 100.0]] * 9, "At most 8 stations"),
    ([[0.0, float("nan"), 100.0]], "m: its y is empty or not a number"),
    ([[0.0, 0.0]], "m: it has 2 coordinates"),
    ([[0.0, 0.0, 1e9]], "m: its z = 1000000000 m is outside that range"),
])
def test_custom_layout_is_checked(bad, why):
    s = Scenario()
    before = s.stations.stations
    s.stations.stations = bad
    assert s.stations.stations == before and why in s.message
    assert "[" not in s.message and "nan" not in s.message  # in words (issue 46 defect 7)


def test_design_maps_and_best_spacing():
    s = Scenario(resolution=31, stations=[[0.0, 0.0, 100.0], [40.0, 20.0, 90.0], [-30.0, 10.0, 100.0]])
    d = dc.design(Snapshot.of(s, dc.ERROR_MAP_READS))
    assert d.errors.position.shape == (31, 31) and np.isfinite(d.errors.position).mean() > 0.95
    e = dc.error_at(Snapshot.of(s, dc.ERROR_MAP_READS), 100.0, 50.0)
    assert float(e.semi_major) >= float(e.semi_minor) > 0
    s.target.z = 100.0  # target depth = station depth: (0, 0) is on station 1
    assert dc.error_at(Snapshot.of(s, dc.ERROR_MAP_READS), 0.0, 0.0) is None
    s.target.z = 120.0
    sp = dc.best_spacing(Snapshot.of(s, dc.SPACING_READS))
    r = sp.result
    assert dc.SPACING_RANGE[0] <= r.d <= dc.SPACING_RANGE[1]
    assert r.value >= np.max(r.curve) - 1e-9  # the refined optimum is at least the scanned best
    assert sp.paper.stations[1, 0] == 15.0 and sp.best.stations[1, 0] == r.d


def test_optimised_layout_and_error_quantities():
    s = Scenario(resolution=21, layout_kind="triangle", n_stations=3)
    r = dc.optimised_layout(Snapshot.of(s, dc.LAYOUT_READS))
    assert r.stations.shape == (3, 3) and 0 < r.d <= 2 * s.region.extent  # up to what fits in the region
    d = dc.design(Snapshot.of(s, dc.ERROR_MAP_READS))
    for quantity in parameter("error_quantity").objects:
        overlay = views.error_map(d, "t", quantity)
        assert overlay.get(0).vdims[0].unit in ("m", "m/s")


@pytest.mark.parametrize("preset", list(PRESETS))
def test_a_snapshots_values_build_the_same_core_inputs_as_the_scenario(preset):
    # The maps are computed from plain values (building a Scenario per map cost ms under the GIL).
    s = Scenario()
    s.apply_preset(preset)
    s.update(plane="x–z", stations=[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    v = Snapshot.of(s, READS).scenario()
    assert (v.core_plane(), v.velocity(), v.core_options()) == (s.snapshot().core_plane(), s.snapshot().velocity(), s.snapshot().core_options())
    assert all(getattr(v, name) == s.value(name) for name in READS)
    v = Snapshot.of(s, dc.ERROR_MAP_READS).scenario()
    assert (v.velocity(), v.core_options(measure=False)) == (s.snapshot().velocity(), s.snapshot().core_options(measure=False))
    assert all(getattr(v, name) == s.value(name) for name in dc.ERROR_MAP_READS)


@pytest.mark.parametrize("name", DEPTHS)
def test_a_depth_above_the_sea_surface_is_refused_in_every_model(name):
    # spec §7: z is depth, positive down, surface z = 0; no sea above it, whatever the model
    for model in parameter("model").objects:
        s = Scenario(model=model)
        before = s.value(name)
        setattr(s.part_of(name), name, -5.0)
        assert s.value(name) == before and "above the sea surface" in s.message
        assert s.refused == [name]
    assert Scenario(h=-5.0).value("h") == Scenario().value("h")  # given at construction: the default, and said so
    assert "above the sea surface" in Scenario(h=-5.0).message


def test_a_station_above_the_sea_surface_is_refused():
    s = Scenario()
    before = s.stations.stations
    s.stations.stations = [[0.0, 0.0, 100.0], [10.0, 0.0, -5.0]]
    assert s.stations.stations == before and "Station 2" in s.message and "above the sea surface" in s.message
    assert s.refused == ["stations"]
    s.stations.stations = [[0.0, 0.0, 0.0]]  # at the surface: accepted
    assert s.stations.stations == [[0.0, 0.0, 0.0]] and s.message == "" and s.refused == []


def _fill(figs, **params):
    p = compute(Snapshot.of(Scenario(resolution=21, **params)))
    map_figures.fill(figs, p)
    return p


@pytest.mark.parametrize("first,then", [
    (dict(plane="x–y"), dict(plane="x–z")),  # defect 1: A's veil kept y 100–300 of x–y ...
    (dict(plane="x–z"), dict(plane="x–y")),  # ... and the other way round
    (dict(), dict(extent=150.0)),
    (dict(plane="x–z"), dict(plane="x–z", z_max=900.0)),
])
def test_every_layer_of_a_map_covers_the_maps_rectangle(first, then):
    figs = map_figures.build()
    _fill(figs, **first)
    p = _fill(figs, **then)
    (u0, u1), (v0, v1) = p.plane.u, p.plane.v
    du, dv = (u1 - u0) / (p.plane.n - 1), (v1 - v0) / (p.plane.n - 1)
    want = dict(x=[u0 - du / 2], y=[v0 - dv / 2], dw=[u1 - u0 + du], dh=[v1 - v0 + dv])  # pixel edges
    for which in range(3):
        for layer in (figs.images[which], figs.veils[which]):
            for key, value in want.items():
                np.testing.assert_allclose(layer.data[key], value, rtol=1e-12, err_msg=f"{which} {key}")
        veil = figs.veils[which].data["image"][0]
        observable = (p.a.observable, p.b.observable, p.a.observable & p.b.observable)[which]
        assert veil.shape == observable.shape
        assert np.array_equal(np.isin(veil, (map_data.VEIL_DARK, map_data.VEIL_LIGHT)), ~observable)


def test_the_xz_plane_has_depth_increasing_downwards_and_shows_every_station():
    # the ranges are fitted in the browser (DataRange1d, match_aspect: app/tabs/maps/figures.py) to the
    # view box's corners; tests/test_browser.py checks the fitted ranges
    figs = map_figures.build()
    _fill(figs, plane="x–z", z_min=100.0, z_max=400.0, h=100.0)
    y = figs.figures[0].y_range
    assert y.flipped  # the top of the plot is the shallow end
    assert all(f.y_range is y for f in figs.figures)  # zoom and pan together
    top, bottom = min(figs.view_source.data["y"]), max(figs.view_source.data["y"])
    marker = 13 / 400 * (400 - 100)  # the triangle's size, in metres of a ~400 px high plot
    assert top <= 100.0 - marker / 2, "the stations at h = z_min are not cut at the top"
    assert bottom >= 400.0 and figs.figures[2].yaxis.axis_label == "z (m), vertical ×2"
    assert figs.figures[0].aspect_scale == 0.5  # 600 m wide, 300 m deep: drawn ×2 in depth
    _fill(figs, plane="x–y")
    y = figs.figures[0].y_range
    assert not y.flipped and figs.figures[0].aspect_scale == 1.0 and figs.figures[0].match_aspect


def test_crlb_maps_are_coloured_by_log10_metres_and_say_why_a_value_is_missing():
    s = Scenario(resolution=21, measure="CRLB position error (m)")
    p = compute(Snapshot.of(s))
    assert p.log_scale
    b = p.b.value
    finite = np.isfinite(b)
    np.testing.assert_allclose(p.shown(1)[finite], np.log10(b[finite]), rtol=1e-12)
    lo, hi = p.clim  # a range of decades, not 0–18 000 m
    assert hi - lo > 1 and hi < np.log10(np.nanmax(b[finite])) + 1e-9
    assert not np.isfinite(p.a.value).any()  # one station: rank 6, CRLB infinite everywhere
    assert p.unobservable[0] == "unobservable (rank 6): colours are round-off"
    figs = map_figures.build()
    map_figures.fill(figs, p)
    for which in range(2):
        fmt = figs.formatters[which].args
        assert fmt["texts"].log and (fmt["bar"].low, fmt["bar"].high) == p.clim
        assert "log scale" in figs.colorbars[which].title
        assert figs.colorbars[which].formatter.args["log"]  # ticks in metres
    assert not figs.colorbars[2].formatter.args["log"]
    assert figs.formatters[0].args["texts"].unobservable.startswith("unobservable (rank 6)")
    assert "unobservable" in figs.formatters[2].args["texts"].unobservable
    # the same kind of scale as the design tab: low error is the good end (reversed viridis)
    assert map_data.ranges(p)[0][2][0] == map_data.Viridis256[-1]
    # the difference map's title is short enough to fit; the explanation is on its colour bar
    assert len(figs.figures[2].title.text) <= 40 and "B locates better" in figs.colorbars[2].title


def test_images_are_sent_normalised_to_their_colour_range():
    s = Scenario(resolution=21, layout="dual", comparison="Moments ×k − original (Fig. 3)")
    p = compute(Snapshot.of(s))
    figs = map_figures.build()
    map_figures.fill(figs, p)
    for which, (low, high, _) in enumerate(map_data.ranges(p)):
        sent = figs.images[which].data["image"][0].astype(float)
        back = low + sent * (high - low)  # what the hover shows, and the colour bar's scale
        np.testing.assert_allclose(back, p.shown(which), rtol=0, atol=1e-6 * (high - low) + 1e-12)
        bar = figs.colorbars[which].color_mapper
        assert (bar.low, bar.high) == (low, high)


def test_the_veil_is_striped_and_distinct_from_a_point_without_value():
    s = Scenario(resolution=41)
    p = compute(Snapshot.of(s))
    codes = map_data.veil_codes(p.a.observable, p.shown(0))
    assert set(np.unique(codes)) == {map_data.VEIL_DARK, map_data.VEIL_LIGHT}  # all unobservable
    codes = map_data.veil_codes(p.b.observable, p.shown(1))
    on_station = ~np.isfinite(p.shown(1)) & p.b.observable
    assert np.array_equal(codes == map_data.NO_VALUE, on_station)
    pal = map_data.VEIL_PALETTE
    assert pal[map_data.NO_VALUE].endswith("00") and not pal[map_data.VEIL_DARK].endswith("00")


def test_the_paper_figure_is_identified_and_the_png_is_named_after_the_scenario():
    s = Scenario(resolution=21)
    for name in PAPER_MAPS:
        s.apply_preset(name)
        p = compute(Snapshot.of(s))
        assert p.preset == name and p.paper[0]
        figs = map_figures.build()
        map_figures.fill(figs, p)
        for which in range(3):
            framed = which in p.paper[0]
            assert ("(paper)" in figs.figures[which].title.text) == framed
            assert (figs.figures[which].outline_line_color == "#b03a2e") == framed
            assert figs.saves[which].filename.startswith(f"fig_{name[-1]}_")
            assert f"h = {s.stations.h:g} m" in figs.captions[which].text
            assert figs.figures[which].border_fill_color == "white"  # an opaque PNG
    s.target.Ph = 123.0  # no longer a paper figure
    assert compute(Snapshot.of(s)).preset == ""


def _design_plot(overlay):
    import holoviews as hv
    from bokeh.models import HoverTool

    fig = hv.render(overlay, backend="bokeh")
    return fig, [t for t in fig.tools if isinstance(t, HoverTool)]


def test_design_maps_have_one_tooltip_and_no_missing_tool(caplog):
    # defect 6: the server logged "Tool of type 'point_draw' could not be found" (the spacing
    # maps' stations asked for an active point-draw tool they do not have), and a station showed
    # two overlapping tooltips

    s = Scenario(resolution=21)
    d = dc.design(Snapshot.of(s, dc.ERROR_MAP_READS))
    with caplog.at_level("WARNING"):
        fig, hovers = _design_plot(views.error_map(d, "t") * views.station_layer(d.stations))
    assert not [r for r in caplog.records if "could not be found" in r.getMessage()]
    assert len(hovers) == 1


def test_best_and_paper_maps_share_one_colour_range():

    s = Scenario(resolution=21)
    sp = dc.best_spacing(Snapshot.of(s, dc.SPACING_READS))
    clim = views.common_clim(sp.best, sp.paper)
    for design in (sp.best, sp.paper):
        lo, hi = views.error_clim(design)
        assert clim[0] <= lo and hi <= clim[1]
    a, b = (_design_plot(views.error_map(x, "t", clim=clim))[0] for x in (sp.best, sp.paper))
    mappers = [next(r.glyph.color_mapper for r in f.renderers if hasattr(r.glyph, "color_mapper"))
               for f in (a, b)]
    assert (mappers[0].low, mappers[0].high) == (mappers[1].low, mappers[1].high) == clim


def test_a_station_added_by_a_click_sits_at_the_station_depth():
    from app.tabs.design.compute import drawn_stations

    old = [[0.0, 0.0, 100.0], [15.0, 0.0, 90.0]]
    data = {"x": [0.0, 20.0, 50.0], "y": [0.0, 0.0, 30.0], "z": [100.0, 90.0, 0.0]}  # z: empty_value
    assert drawn_stations(data, old, 100.0) == [[0.0, 0.0, 100.0], [20.0, 0.0, 90.0], [50.0, 30.0, 100.0]]
    # a deletion keeps the others' depths
    assert drawn_stations({"x": [15.0], "y": [0.0], "z": [90.0]}, old, 100.0) == [[15.0, 0.0, 90.0]]


def test_the_sea_trial_preset_is_recognised_as_active():
    # The maps' snapshot holds only what the maps use (not the design tab's stations).
    s = Scenario(resolution=21)
    s.apply_preset("Seed 001 sea trial")
    assert s.active_preset() == "Seed 001 sea trial"
    assert compute(Snapshot.of(s)).preset == "Seed 001 sea trial"


def test_stations_added_one_by_one_keep_their_depth_whatever_the_browser_sends():
    # issue 25, defect 1: each clicked station was rewritten to z = 0 when the next was added
    # (the point-draw tool's z column holds a placeholder for clicked points)
    from app.tabs.design.compute import drawn_stations

    layout = [[0.0, 0.0, 100.0], [15.0, 0.0, 100.0]]
    for x, y in [(-229.0, 168.0), (-134.0, -165.0), (55.0, 205.0)]:
        data = {"x": [st[0] for st in layout] + [x], "y": [st[1] for st in layout] + [y],
                "z": [st[2] for st in layout[:2]] + [0.0] * (len(layout) - 1)}  # as the browser sent
        layout = drawn_stations(data, layout, 100.0)
    assert [st[2] for st in layout] == [100.0] * 5
    # a drag keeps the dragged station's depth, a deletion the others'
    moved = drawn_stations({"x": [0.0, 15.0, -200.0, -134.0, 55.0], "y": [0.0, 0.0, 100.0, -165.0, 205.0],
                            "z": [0.0] * 5}, [[*st[:2], 50.0 + i] for i, st in enumerate(layout)], 100.0)
    assert [st[2] for st in moved] == [50.0, 51.0, 52.0, 53.0, 54.0]
    gone = drawn_stations({"x": [0.0, -134.0], "y": [0.0, -165.0], "z": [0.0, 0.0]},
                          [[*st[:2], 50.0 + i] for i, st in enumerate(layout)], 100.0)
    assert gone == [[0.0, 0.0, 50.0], [-134.0, -165.0, 53.0]]


def test_a_dragged_station_is_rounded_as_the_table_shows_it_and_the_others_kept_exactly():
    # issue 46 defect 9: the link held 206.999985918 after a drag while the table showed 207.0
    from app.tabs.design.compute import drawn_stations

    layout = [[0.0, 0.0, 100.0], [15.123456, -3.25, 90.0]]  # typed in the table: kept as typed
    moved = drawn_stations({"x": [206.999985918, 15.123456], "y": [-41.00000762, -3.25]}, layout, 100.0)
    assert moved == [[207.0, -41.0, 100.0], [15.123456, -3.25, 90.0]]
    added = drawn_stations({"x": [0.0, 15.123456, 12.3456789], "y": [0.0, -3.25, 1e-9]}, layout, 100.0)
    assert added[2] == [12.3, 0.0, 100.0] and added[:2] == layout


def test_each_map_is_captioned_with_its_own_moments():
    # issue 25, defect 3: map B's caption (and saved PNG) said A's P = (100, 20) in Fig. 2
    s = Scenario(resolution=21)
    s.apply_preset("Fig. 2")
    p = compute(Snapshot.of(s))
    assert "P = (100, 20) A·m" in p.captions[0] and "P = (100, 100) A·m" in p.captions[1]
    assert "P_A = (100, 20) A·m, P_B = (100, 100) A·m" in p.captions[2]
    figs = map_figures.build()
    map_figures.fill(figs, p)
    assert "P = (100, 100)" in figs.captions[1].text.replace("\n", " ")  # the PNG's caption
    s.apply_preset("Fig. 3")
    assert "P = (1000, 200) A·m" in compute(Snapshot.of(s)).captions[1]
    # and the spacing and the grid (issue 25: captions omitted d and the grid)
    s.apply_preset("Fig. 6")
    s.region.resolution = 21
    caps = compute(Snapshot.of(s)).captions
    assert "2 stations d = 10 m apart" in caps[0] and "2 stations d = 50 m apart" in caps[1]
    assert "A: 2 stations d = 10 m apart, B: 2 stations d = 50 m apart" in caps[2]
    assert all("grid 21 × 21 over x ±300 m" in c for c in caps)


@pytest.mark.parametrize("name, moments_b", [("Fig. 3", (1000.0, 200.0)), ("Fig. 4", (70.7, 70.7))])
def test_map_bs_unobservable_direction_is_bs_own(name, moments_b):
    # issue 25, defect 3: B's note gave A's vector. Recomputed here from the probe point the
    # note names, with B's moments, by core directly.
    import re

    import core

    s = Scenario(resolution=21)
    s.apply_preset(name)
    note = compute(Snapshot.of(s)).note
    lines = {line[0]: line for line in note.splitlines()}
    vectors = {}
    for which, moments in (("A", (s.target.Ph, s.target.Pv)), ("B", moments_b)):
        m = re.search(r"at \((-?\d+), (-?\d+), (-?\d+)\) m: .*= \(([^)]*)\)\. Use", lines[which])
        probe = [float(v) for v in m.groups()[:3]]
        shown = np.array([float(v) for v in m.group(4).split(", ")])
        n = core.unobservable_direction([*probe, *s.snapshot().velocity(), *moments], [[0.0, 0.0, s.stations.h]],
                                        T=s.sensor.T, sensor=core.Sensor("E", sigma=s.medium.sigma))
        assert np.allclose(np.abs(shown), np.abs(n), atol=5e-4)  # printed to 3 decimals; sign free
        vectors[which] = shown
    assert not np.allclose(np.abs(vectors["A"]), np.abs(vectors["B"]), atol=5e-3)


def test_the_note_probes_a_point_of_the_x_z_plane():
    # issue 25 (Maps): Fig. 2's note probed (100, 100, 250), off the plane y = 50 m
    s = Scenario(resolution=21)
    s.apply_preset("Fig. 2")
    assert "at (100, 50, 250) m" in compute(Snapshot.of(s)).note


def _state(s):
    return {n: s.value(n) for n in PART_OF}


@pytest.mark.parametrize("first", sorted(PRESETS))
def test_a_preset_after_another_is_the_same_scenario_as_alone(first):
    # issue 25: presets left the custom stations, the x–z range and the sea of the previous one
    for second in PRESETS:
        alone = Scenario(resolution=21)
        alone.apply_preset(second)
        s = Scenario(resolution=21)
        own = dict(track_runs=7, error_quantity="Depth error σz (m)")  # tabs' own, no preset's: kept
        s.update(stations=[[1.0, 2.0, 3.0]], **own)
        s.apply_preset(first)
        s.apply_preset(second)
        alone.update(own)
        assert _state(s) == _state(alone), (first, second)
        assert s.message == "" and s.active_preset() == second


def test_a_figure_button_keeps_the_track_and_design_tabs_own_settings():
    # issue 40 defect 7: Fig. 1 reset the Track tab's runs from 2 to 5 without a word
    from app.state.scenario import TAB_OWN
    own = {n for a in TAB_OWN for n in PARTS[a].names()} - set(PRESET_INPUTS)
    assert {"track_runs", "track_filter", "error_quantity", "n_stations"} <= own
    for name in PRESETS:
        s = Scenario(resolution=21)
        s.update(track_runs=2, track_filter="ekf", n_stations=6, error_quantity="Depth error σz (m)")
        s.apply_preset(name)
        assert (s.track.track_runs, s.track.track_filter, s.design.n_stations,
                s.design.error_quantity) == (2, "ekf", 6, "Depth error σz (m)"), name


def test_the_sea_trial_preset_is_the_command_lines_trial_on_the_track_tab():
    # issue 40 defect 11: the page used 3-axis sensors, a start at (−250, −120), heading 25° and
    # 250 s; the command line's --case seed001-trial is 2-axis sensors at (0, ±5, 8.4), a start
    # at (−57.1, 280) heading −y, 300 measurements. The Maps tab's pair (core.dual_station) has
    # the same spacing and depth.
    import core
    from app.tabs.track import track
    from core.tracking import montecarlo as tr

    s = Scenario()
    s.apply_preset("Seed 001 sea trial")
    trial = tr.CASES["seed001-trial"]
    case = track.case_of(s.snapshot())
    assert dataclasses.replace(case, name=trial.name) == trial
    pair = core.dual_station(s.stations.h, s.stations.d)
    assert np.linalg.norm(pair[1] - pair[0]) == pytest.approx(
        np.linalg.norm(np.subtract(*s.stations.stations)))
    assert {st[2] for st in s.stations.stations} == {float(pair[0][2])}
    # the same numbers as the command line (same seed, same runs)
    s.track.track_runs = 2
    page = track.compute(s)["res"]
    cli = tr.monte_carlo("seed001-trial", filter="bank", runs=2, seed=0, workers=1)
    np.testing.assert_allclose(page.trmse_m, cli.trmse_m, rtol=1e-12)
    np.testing.assert_allclose(page.pcrlb_m, cli.pcrlb_m, rtol=1e-12)


def test_the_sidebar_speed_and_heading_are_hidden_on_the_track_tab():
    # issue 25 (Track): the sidebar's Speed/Heading stayed visible though the track uses its own
    from app.state.applies import DESIGN_TAB, MAPS_TAB, TRACK_TAB, applies

    s = Scenario()
    for name in ("speed", "heading"):
        assert applies(name, s.snapshot(), MAPS_TAB) and applies(name, s.snapshot(), DESIGN_TAB)
        assert not applies(name, s.snapshot(), TRACK_TAB)
    assert "track_speed" in PART_OF and "track_heading" in PART_OF


def test_nine_stations_are_refused_with_at_most_eight():
    s = Scenario()
    s.stations.stations = [[10.0 * i, 0.0, 100.0] for i in range(9)]
    assert "At most 8 stations" in s.message and len(s.stations.stations) == 2


def test_a_map_veiled_everywhere_says_what_it_is_inside_its_frame():
    # issue 25 (first screen): two of three maps fully hatched, with no word inside them
    s = Scenario(resolution=21)
    s.apply_preset("Fig. 1")
    figs = map_figures.build()
    map_figures.fill(figs, compute(Snapshot.of(s)))
    assert figs.labels[0].visible and "rank 6 of 7" in figs.labels[0].text
    assert "range" in figs.labels[0].text and "source strength" in figs.labels[0].text
    assert max(len(line) for lab in figs.labels for line in lab.text.splitlines()) <= 21  # fits 130 px
    assert not figs.labels[1].visible  # dual: observable
    assert figs.labels[2].visible and "A is" in figs.labels[2].text
    assert all(lab in figs.figures[i].center for i, lab in enumerate(figs.labels))  # in the frame
    s.apply_preset("Fig. 6")
    map_figures.fill(figs, compute(Snapshot.of(s)))
    assert not any(lab.visible for lab in figs.labels)


def test_presets_applied_from_two_threads_at_once_leave_one_of_them_whole():
    # Panel runs two clicks' watchers on two of its threads at once: two presets applied so must
    # not leave a mix of both (Scenario.update takes one update at a time, watchers included)
    import threading

    names = ("Seed 001 sea trial", "Seed 003 sensors")
    whole = []
    for name in names:
        s = Scenario()
        s.apply_preset(name)
        whole.append(s.values())
    s = Scenario()
    seen = []
    s.watch(lambda *_: seen.append(s.values()), list(PARTS))  # what each watcher call sees
    start = threading.Barrier(2)

    def apply(name):
        start.wait()
        for _ in range(30):  # without the lock: a mix in 2 of 3 runs of 15 each
            s.apply_preset(name)

    threads = [threading.Thread(target=apply, args=(n,)) for n in names]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert s.values() in whole
    assert all(v in whole for v in seen), "a watcher saw a mix of the two presets"


def test_csv_names_each_unit_once_and_lists_only_the_inputs_that_apply():
    # issue 40 (low): the column "A: CRLB position error (1σ, m) (m)", and a header listing the
    # magnetic moments, the seabed and scenario B's inputs beside electric whole-space maps
    from app.tabs.maps import maps

    s = Scenario(resolution=21, measure="CRLB position error (m)")
    text = maps.to_csv(s, PanelCache()).read()
    lines = text.splitlines()
    columns = next(csv.reader([next(line for line in lines if not line.startswith("#"))]))
    assert "A: CRLB position error (1σ, m)" in columns, columns
    assert not any("(m) (m)" in c for c in columns), columns
    listed = {line[2:].split(" = ")[0] for line in lines if line.startswith("# ")}
    assert {"Ph", "Pv", "z", "d", "noise", "sigma", "measure", "comparison"} <= listed, listed
    assert not listed & {"mx", "my", "mz", "noise_b", "noise_g", "baseline", "sea_depth",
                         "seabed_sigma", "Ph_b", "Pv_b", "k", "d_ref", "y", "z_min", "z_max",
                         "sensor_b", "layout", "stations"}, listed
    # another measure's unit is still said once
    s.maps.measure = "Observability index log10 η"
    columns = next(csv.reader([next(line for line in maps.to_csv(s, PanelCache()).read().splitlines()
                                    if not line.startswith("#"))]))
    assert "A: log10 η (observability index) (dimensionless)" in columns, columns


def test_one_map_exports_alone_at_a_useful_resolution():
    # issue 40 (still present): a map's own PNG was its save tool's canvas, 403 px wide
    from PIL import Image

    from app.tabs.maps import export

    p = compute(Snapshot.of(Scenario(resolution=21)))
    for which in range(3):
        img = Image.open(export.to_png(p, (which,)))
        assert img.size == (export.MAP_WIDTH_PX, round(1.4 * export.MAP_WIDTH_PX)), img.size
    assert Image.open(export.to_png(p)).size[0] == export.WIDTH_PX  # the three, as before


def test_a_restore_on_one_thread_does_not_skip_the_check_of_a_value_set_on_another():
    # Panel runs two inputs' watchers on two of its threads at once. The flag that turns the
    # checks off while values are restored or moved was one for the whole scenario: a value set
    # on another thread during a restore went unchecked and stayed (α = -1 kept on Track).
    import threading

    sc = Scenario()
    inside, go_on = threading.Event(), threading.Event()

    def held(_event):  # thread A, inside a restore: waits there until B has set its value
        inside.set()
        assert go_on.wait(30)

    watcher = sc.target.param.watch(held, ["Pv"])
    a = threading.Thread(target=lambda: sc._quietly(Pv=sc.target.Pv + 1.0))
    a.start()
    assert inside.wait(30)
    try:
        sc.target.Ph = 1e9  # thread B: outside the accepted range
        assert sc.target.Ph == 100.0, "the check of another thread's value was skipped"
        assert "outside the accepted range" in sc.message
    finally:
        go_on.set()
        a.join(30)
        sc.target.param.unwatch(watcher)
