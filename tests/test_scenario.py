"""The dashboard's state and computations, without a browser."""

import math

import numpy as np
import pytest
import xarray as xr

from app import map_figures, views
from app.compute import DESIGN_FIELDS, FIELDS, PanelCache, Snapshot, compute
from app.scenario import ACCEPTED, PRESETS, Scenario


def test_presets_set_what_the_paper_says():
    s = Scenario()
    for name in (n for n in PRESETS if n.startswith("Fig.")):  # the paper's figures
        s.apply_preset(name)
        # common parameters (spec §5)
        assert (s.Ph, s.h, s.T) == (PRESETS[name]["Ph"], 100.0, 1.0)
        vx, vy = s.velocity()
        assert math.isclose(vx, 2.0) and math.isclose(vy, 2.0)
        assert s.message == ""
    s.apply_preset("Fig. 1")
    assert (s.plane, s.z, s.layout, s.Pv, s.extent) == ("x–y", 120.0, "single", 20.0, 300.0)
    s.apply_preset("Fig. 2")
    assert (s.plane, s.y, s.z_min, s.z_max, s.Ph_b, s.Pv_b) == ("x–z", 50.0, 100.0, 400.0, 100.0, 100.0)
    s.apply_preset("Fig. 3")
    assert s.k == 10.0 and s.comparison.startswith("Moments ×k")
    s.apply_preset("Fig. 4")
    assert (s.Ph, s.Pv, s.Ph_b, s.Pv_b) == (100.0, 0.0, 70.7, 70.7)
    s.apply_preset("Fig. 5")
    assert s.comparison.startswith("Dual − single") and s.d == 15.0
    s.apply_preset("Fig. 6")
    assert (s.d, s.d_ref) == (50.0, 10.0)


@pytest.mark.parametrize("name", sorted(ACCEPTED))
def test_out_of_range_values_are_refused_with_a_message(name):
    s = Scenario()
    before = getattr(s, name)
    lo, hi, _ = ACCEPTED[name]
    for bad in (hi * 10 + 10, lo - abs(lo) - 10):
        setattr(s, name, int(bad) if isinstance(before, int) else float(bad))
        assert getattr(s, name) == before, "the last good value is kept"
        assert "outside the accepted range" in s.message
    if not isinstance(before, int):
        setattr(s, name, float("nan"))
        assert getattr(s, name) == before and "must be a number" in s.message
    # a good value clears the message
    setattr(s, name, before + 1 if before + 1 <= hi else before * 1.5)
    assert s.message == ""


def test_accepted_ranges_are_what_the_core_accepts():
    # The lowest accepted speed, T, σ and noise must still be accepted by the core.
    s = Scenario(speed=ACCEPTED["speed"][0], T=ACCEPTED["T"][0], sigma=ACCEPTED["sigma"][0],
                 noise=ACCEPTED["noise"][0], resolution=ACCEPTED["resolution"][0])
    p = compute(Snapshot.of(s))
    assert np.isfinite(p.b.value).mean() > 0.99


def test_depth_band_must_be_ordered():
    s = Scenario()
    s.z_max = 50.0  # shallower than z_min = 100
    assert s.z_max == 400.0 and "deeper" in s.message


def test_fig5_single_is_flagged_dual_is_observable():
    s = Scenario(resolution=41)
    s.apply_preset("Fig. 5")
    p = compute(Snapshot.of(s))
    assert not p.a.observable.any()
    assert p.b.observable.mean() > 0.95
    assert "rank Γ = 6" in p.note and "round-off" in p.note
    # the one-click remedy: moments known and a measure that uses all rows
    s.param.update(state_set="moments known (5 states)", measure="D-optimal ½·log10 det F")
    p = compute(Snapshot.of(s))
    assert p.a.observable.mean() > 0.95 and p.b.observable.mean() > 0.95 and p.note == ""
    # the paper's square rule with known moments keeps only instant-k rows for two stations
    s.measure = "log10|det Γ| (paper)"
    assert "cannot see the speed" in compute(Snapshot.of(s)).note


def test_moment_scaling_difference_is_five_decades_for_dual():
    s = Scenario(resolution=21, layout="dual", comparison="Moments ×k − original (Fig. 3)", k=10.0,
                 difference="Signed log-ratio")
    p = compute(Snapshot.of(s))
    finite = np.isfinite(p.diff)
    np.testing.assert_allclose(p.diff[finite], 5.0, atol=1e-8)


def test_cache_computes_once_per_scenario(monkeypatch):
    calls = []
    import app.compute as compute_module
    real = compute_module.compute
    monkeypatch.setattr(compute_module, "compute", lambda snap: calls.append(1) or real(snap))
    cache = PanelCache(size=2)
    s = Scenario(resolution=21)
    for _ in range(3):
        cache.get(Snapshot.of(s))
    assert len(calls) == 1
    s.Ph = 50.0
    cache.get(Snapshot.of(s))
    assert len(calls) == 2


def test_downloads_carry_data_and_parameters():
    s = Scenario(resolution=21)
    p = compute(Snapshot.of(s))
    params = dict(Snapshot.of(s).items)
    ds = xr.open_dataset(views.to_netcdf(p, params), engine="h5netcdf")
    np.testing.assert_array_equal(ds["B"].values, p.b.value)
    assert ds.attrs["Ph"] == 100.0 and ds["x"].attrs["units"] == "m"
    text = views.to_csv(p, params).read()
    assert "# Ph = 100.0" in text
    rows = [line for line in text.splitlines() if not line.startswith("#")]
    assert len(rows) == 1 + 21 * 21 and rows[0].startswith("y,x,")


def test_maps_for_every_measure_and_plane():
    figs = map_figures.build()
    for plane in ("x–y", "x–z"):
        for measure in Scenario.param.measure.objects:
            s = Scenario(resolution=21, plane=plane, measure=measure)
            p = compute(Snapshot.of(s))
            maps, (xname, vname), clim, diff_range, _ = map_figures.contents(p)
            assert len(maps) == 3 and vname == ("y" if plane == "x–y" else "z")
            assert clim[0] < clim[1] and diff_range[0] < diff_range[1]
            map_figures.fill(figs, p)
            assert figs.figures[2].yaxis.axis_label == f"{vname} (m)"
            assert figs.images[1].data["image"][0].dtype == np.float32
            np.testing.assert_array_equal(figs.images[1].data["image"][0], p.b.value.astype(np.float32))


@pytest.mark.parametrize("bad,why", [
    ([], "1 to 8 stations"),
    ([[0.0, 0.0, 100.0]] * 9, "1 to 8 stations"),
    ([[0.0, float("nan"), 100.0]], "three numbers"),
    ([[0.0, 0.0]], "three numbers"),
    ([[0.0, 0.0, 1e9]], "three numbers"),
])
def test_custom_layout_is_checked(bad, why):
    s = Scenario()
    before = s.stations
    s.stations = bad
    assert s.stations == before and why in s.message


def test_design_maps_and_best_spacing():
    from app import compute as c
    s = Scenario(resolution=31, stations=[[0.0, 0.0, 100.0], [40.0, 20.0, 90.0], [-30.0, 10.0, 100.0]])
    d = c.design(Snapshot.of(s, c.DESIGN_FIELDS))
    assert d.errors.position.shape == (31, 31) and np.isfinite(d.errors.position).mean() > 0.95
    e = c.error_at(Snapshot.of(s, c.DESIGN_FIELDS), 100.0, 50.0)
    assert float(e.semi_major) >= float(e.semi_minor) > 0
    s.z = 100.0  # target depth = station depth: (0, 0) is on station 1
    assert c.error_at(Snapshot.of(s, c.DESIGN_FIELDS), 0.0, 0.0) is None
    s.z = 120.0
    sp = c.best_spacing(Snapshot.of(s, c.DESIGN_FIELDS))
    r = sp.result
    assert c.SPACING_RANGE[0] <= r.d <= c.SPACING_RANGE[1]
    assert r.value >= np.max(r.curve) - 1e-9  # the refined optimum is at least the scanned best
    assert sp.paper.stations[1, 0] == 15.0 and sp.best.stations[1, 0] == r.d


def test_optimised_layout_and_error_quantities():
    from app import compute as c
    s = Scenario(resolution=21, layout_kind="triangle", n_stations=3)
    r = c.optimised_layout(Snapshot.of(s, c.DESIGN_FIELDS))
    assert r.stations.shape == (3, 3) and c.SPACING_RANGE[0] <= r.d <= c.SPACING_RANGE[1]
    d = c.design(Snapshot.of(s, c.DESIGN_FIELDS))
    for quantity in Scenario.param.error_quantity.objects:
        overlay = views.error_map(d, "t", quantity)
        assert overlay.get(0).vdims[0].unit in ("m", "m/s")


@pytest.mark.parametrize("preset", list(PRESETS))
def test_a_snapshots_values_build_the_same_core_inputs_as_the_scenario(preset):
    # The maps are computed from plain values (building a Scenario per map cost ms under the GIL).
    s = Scenario()
    s.apply_preset(preset)
    s.param.update(plane="x–z", stations=[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    for fields in (FIELDS, DESIGN_FIELDS):
        v = Snapshot.of(s, fields).scenario()
        assert (v.core_plane(), v.velocity(), v.core_options()) == (s.core_plane(), s.velocity(), s.core_options())
        assert all(getattr(v, name) == getattr(s, name) for name in fields)
