"""The dashboard state's sea (issue 17): whole space or layered, depth checks, the sea-trial preset,
and the maps computed through core's layered field."""

import numpy as np

import core
from app.state.scenario import PRESETS, Scenario
from app.tabs.maps import compute as c


def test_default_is_the_whole_space_and_fig_presets_stay_there():
    s = Scenario()
    assert s.snapshot().core_options()["sensor"].sea is None
    s.update(sea_model="layered")
    for name in (n for n in PRESETS if n.startswith("Fig.")):
        s.apply_preset(name)
        assert s.snapshot().core_options()["sensor"].sea is None


def test_layered_puts_the_stations_on_the_seabed():
    s = Scenario(sea_depth=150.0)
    s.medium.sea_model = "layered"
    assert s.stations.h == 150.0 and s.target.z == 120.0 and (s.region.z_min, s.region.z_max) == (0.0, 150.0)
    assert all(st[2] == 150.0 for st in s.stations.stations)
    assert s.snapshot().core_options()["sensor"].sea == core.Sea(150.0, 1.0)
    s.medium.sea_depth = 130.0  # the stations stay on the seabed
    assert s.stations.h == 130.0 and all(st[2] == 130.0 for st in s.stations.stations) and s.message == ""


def test_depths_outside_the_column_are_refused():
    s = Scenario(sea_depth=150.0)
    s.medium.sea_model = "layered"
    s.target.z = 160.0
    assert s.target.z == 120.0 and "outside the water column 0 … 150 m" in s.message
    s.stations.h = 151.0
    assert s.stations.h == 150.0 and "Station depth" in s.message
    s.medium.sea_depth = 100.0  # the target at 120 m would be below the seabed
    assert (s.medium.sea_depth, s.stations.h) == (150.0, 150.0) and "Target depth" in s.message
    s.stations.stations = [[0.0, 0.0, 149.0], [5.0, 0.0, 200.0]]
    assert s.stations.stations[1][2] == 150.0 and "Station 2 depth 200" in s.message


def test_paper_model_is_refused_in_a_layered_sea():
    s = Scenario(model="paper eqs. (10)–(12) as printed")
    s.medium.sea_model = "layered"
    assert s.medium.model == "exact dipole" and "no images" in s.message
    s.medium.model = "paper eqs. (10)–(12) as printed"
    assert s.medium.model == "exact dipole" and "layered-sea" in s.message


def test_seed_001_preset_maps_in_the_layered_sea():
    s = Scenario()
    s.apply_preset("Seed 001 sea trial")
    assert s.message == ""
    assert s.snapshot().core_options()["sensor"].sea == core.Sea(8.4, 0.4)
    assert (s.stations.h, s.stations.d, s.target.z, s.target.Ph, s.target.Pv) == (8.4, 10.0, 0.2, 100.0, 0.0)
    s.region.resolution = 20
    panels = c.compute(c.Snapshot.of(s))
    plane = s.snapshot().core_plane()
    opts = s.snapshot().core_options()
    measure = opts.pop("measure")
    want = core.evaluate_map(plane, core.dual_station(8.4, 10.0), velocity=s.snapshot().velocity(),
                             moments=(100.0, 0.0), measure=measure, **opts)
    np.testing.assert_array_equal(panels.b.value, want.value)
    assert np.all(np.isfinite(panels.a.value[panels.a.observable]))
