"""The dashboard's sensor kinds (issue 26 item 5): magnetic maps, veils, captions, inputs."""

import numpy as np
import pytest

import core
from app.state.applies import DESIGN_TAB, MAPS_TAB, TRACK_TAB, applies
from app.state.scenario import PRESETS, Scenario
from app.tabs.design.compute import ERROR_MAP_READS
from app.tabs.design.compute import design
from app.tabs.maps import data as map_data, figures as map_figures
from app.tabs.maps.compute import Snapshot, compute

MAGNETOMETER, GRADIOMETER = "magnetometer (B, nT)", "gradiometer (G, nT/m)"
BOTH, ELECTRIC = "magnetometer + gradiometer (BG)", "electric (E, V/m)"
SMALL = dict(resolution=24, extent=60.0, z=110.0)  # a coarse grid near the stations: fast, observable


def same(x, y):
    """Equal arrays, NaN where the other is NaN (the app must add nothing to core's numbers)."""
    return np.array_equal(np.asarray(x), np.asarray(y), equal_nan=True)


@pytest.mark.parametrize("label,kind,noise", [(MAGNETOMETER, "B", 0.02), (GRADIOMETER, "G", 0.03),
                                              (BOTH, "BG", (0.02, 0.03))])
def test_a_magnetic_map_is_core_evaluate_map_with_the_same_sensor(label, kind, noise):
    s = Scenario(sensor=label, noise_b=0.02, noise_g=0.03, mx=-2000.0, my=500.0, mz=4000.0, **SMALL)
    assert s.maps.measure == "CRLB position error (m)"  # moved off the electric paper's square rule
    p = compute(Snapshot.of(s))
    sensor = core.Sensor(kind, noise)
    for st, res in ((core.single_station(s.stations.h), p.a), (core.dual_station(s.stations.h, s.stations.d), p.b)):
        want = core.evaluate_map(s.snapshot().core_plane(), st, velocity=s.snapshot().velocity(), moments=(-2000.0, 500.0, 4000.0),
                                 measure="crlb_position", T=s.sensor.T, steps=s.sensor.steps, sensor=sensor)
        assert same(res.value, want.value) and same(res.observable, want.observable)
    assert p.kinds == (kind, kind)


def test_one_magnetometer_or_gradiometer_is_veiled_at_every_point_and_says_why():
    for label, kind, power in ((MAGNETOMETER, "magnetometer", "3"), (GRADIOMETER, "gradiometer", "4")):
        p = compute(Snapshot.of(Scenario(sensor=label, **SMALL)))  # A: one station, B: two
        assert not p.a.observable.any(), "rank 7 of 8 at every point (spec §11)"
        assert p.b.observable.mean() > 0.9, "two stations a spacing apart are observable"
        assert p.unobservable[0].startswith("unobservable (rank 7 of 8): one " + kind)
        said = map_data.veiled_text(p, 0)
        assert "rank 7 of 8" in said and kind in said
        assert map_data.veiled_text(p, 1) == ""
        assert f"one {kind}, moment unknown: rank Γ = 7 < 8" in p.note
        assert f"{power}mx, {power}my, {power}mz" in p.note
    p = compute(Snapshot.of(Scenario(sensor=BOTH, **SMALL)))  # B + G at one station: observable
    assert p.a.observable.mean() > 0.9 and p.note == "" and map_data.veiled_text(p, 0) == ""


def test_captions_colour_bars_and_hovers_name_the_kind_and_its_units():
    s = Scenario(sensor=GRADIOMETER, **SMALL)
    p = compute(Snapshot.of(s))
    assert p.titles[:2] == ("A: single gradiometer", "B: dual gradiometer, d = 15 m")
    for text in p.captions:
        assert "sensor gradiometer" in text and "m = (-3000, 1000, 5000) A·m²" in text
        assert "noise 0.01 nT/m" in text and "V/m" not in text and "σ =" not in text
        assert "all 8 unknown" in text
    assert p.value_labels == ("CRLB 1σ (m), gradiometer (nT/m)",) * 2
    figs = map_figures.build()
    map_figures.fill(figs, p)
    assert figs.colorbars[0].title == "CRLB 1σ (m), gradiometer (nT/m), log scale"
    assert figs.hovers[0].tooltips[-1][0] == "CRLB 1σ (m), gradiometer (nT/m)"
    assert "rank 7 of 8" in figs.labels[0].text and figs.labels[0].visible
    assert p.filename == "dual_vs_single_gradiometer_x_y_crlb"
    s.sensor.sensor = BOTH
    both = compute(Snapshot.of(s)).captions[0]
    assert "magnetometer + gradiometer" in both and "noise 0.01 nT and 0.01 nT/m" in both
    s.maps.measure = "D-optimal ½·log10 det F"
    assert compute(Snapshot.of(s)).value_labels[0] == "½·log10 det F, B + G (nT, nT/m)"


def test_the_electric_default_names_no_kind():
    p = compute(Snapshot.of(Scenario(resolution=24)))
    assert p.titles[:2] == ("A: single station", "B: dual, d = 15 m")
    assert p.kinds == ("E", "E") and p.value_labels == (p.value_label, p.value_label)
    assert p.captions[0].startswith("P = (100, 20) A·m, v = (2, 2) m/s") and "sensor" not in p.captions[0]
    assert p.captions[0].endswith("noise 1e-07 V/m, N = 3, exact dipole, all 7 unknown")


def test_the_sensor_comparison_preset_puts_one_kind_against_another_at_one_station():
    s = Scenario()
    s.apply_preset("Seed 003 sensors")
    assert (s.stations.layout, s.sensor.sensor, s.maps.sensor_b) == ("single", MAGNETOMETER, BOTH)
    s.region.resolution = 24
    p = compute(Snapshot.of(s))
    assert p.titles[:2] == ("A: single, magnetometer", "B: single, magnetometer + gradiometer")
    assert p.kinds == ("B", "BG") and len(p.stations[0]) == len(p.stations[1]) == 1
    assert not p.a.observable.any() and p.b.observable.mean() > 0.9
    want = core.evaluate_map(s.snapshot().core_plane(), core.single_station(s.stations.h), velocity=s.snapshot().velocity(),
                             moments=(s.target.mx, s.target.my, s.target.mz), measure="crlb_position", steps=s.sensor.steps,
                             sensor=core.Sensor("BG", (s.sensor.noise_b, s.sensor.noise_g)))
    assert same(p.b.value, want.value)
    assert "sensors A magnetometer, B magnetometer + gradiometer" in p.captions[2]
    assert map_data.veiled_text(p, 2).startswith("no difference:\nA is unobservable")
    s.sensor.sensor = GRADIOMETER  # the third kind, against both
    p = compute(Snapshot.of(s))
    assert p.titles[0] == "A: single, gradiometer" and not p.a.observable.any()
    s.maps.sensor_b = ELECTRIC  # an electric B beside a magnetic A: each in its own units
    p = compute(Snapshot.of(s))
    assert p.kinds == ("G", "E") and "P_B = (100, 20) A·m" in p.captions[2]
    assert "m_A = (-3000, 1000, 5000) A·m²" in p.captions[2]
    assert "Seed 003 sensors" in PRESETS


def test_a_magnetic_kind_moves_the_paper_measure_to_the_crlb_and_says_so():
    s = Scenario()
    assert s.maps.measure == "log10|det Γ| (paper)"
    s.sensor.sensor = MAGNETOMETER
    assert s.maps.measure == "CRLB position error (m)"
    assert "square-Γ rule is the electric paper's" in s.message and s.refused == ["sensor"]
    s.maps.measure = "Observability index log10 η"  # asked again while magnetic: moved again
    assert s.maps.measure == "CRLB position error (m)"
    s.maps.measure = "D-optimal ½·log10 det F"  # all rows: kept
    assert s.maps.measure == "D-optimal ½·log10 det F"


def test_the_design_tab_uses_the_sensor():
    s = Scenario(sensor=BOTH, stations=[[0.0, 0.0, 100.0]], **SMALL)
    d = design(Snapshot.of(s, ERROR_MAP_READS))
    want = core.crlb_maps(d.plane, [[0.0, 0.0, 100.0]], velocity=s.snapshot().velocity(), moments=(s.target.mx, s.target.my, s.target.mz),
                          steps=s.sensor.steps, sensor=core.Sensor("BG", (s.sensor.noise_b, s.sensor.noise_g)))
    assert same(d.errors.position, want.position) and np.isfinite(d.errors.position).mean() > 0.9


def test_inputs_follow_the_kind():
    s = Scenario()
    electric = {n for n in ("Ph", "Pv", "noise", "sigma", "model", "sea_model") if applies(n, s.snapshot(), MAPS_TAB)}
    assert electric == {"Ph", "Pv", "noise", "sigma", "model", "sea_model"}
    assert not any(applies(n, s.snapshot(), MAPS_TAB) for n in ("mx", "my", "mz", "noise_b", "noise_g", "sensor_b"))
    s.sensor.sensor = GRADIOMETER
    # the Track tab tracks with the scenario's kind too (issue 26): its inputs follow it
    for tab in (MAPS_TAB, DESIGN_TAB, TRACK_TAB):
        assert all(applies(n, s.snapshot(), tab) for n in ("mx", "my", "mz", "noise_g"))
        assert not any(applies(n, s.snapshot(), tab) for n in ("Ph", "Pv", "noise", "noise_b", "sigma", "model",
                                                    "sea_model"))
    s.maps.comparison = "Sensor kind B − A (seed 003)"  # G against B + G: both noises
    assert applies("noise_b", s.snapshot(), MAPS_TAB) and applies("noise_g", s.snapshot(), MAPS_TAB)
    assert applies("sensor_b", s.snapshot(), MAPS_TAB) and applies("layout", s.snapshot(), MAPS_TAB)
    s.maps.comparison = "Moment split B − A (Fig. 4)"
    assert applies("mz_b", s.snapshot(), MAPS_TAB) and not applies("Ph_b", s.snapshot(), MAPS_TAB)


def test_a_zero_magnetic_moment_is_said_not_computed_into_a_direction():
    p = compute(Snapshot.of(Scenario(sensor=GRADIOMETER, mx=0.0, my=0.0, mz=0.0, **SMALL)))
    assert not p.a.observable.any() and not p.b.observable.any()
    assert p.note.count("the target has no magnetic field") == 2


def test_a_gradiometer_baseline_sets_the_scale_on_maps_design_and_track():
    """Issue 36 item 4: the gradiometer's baseline is an input of the page (Maps, Layout design,
    Track), the same core.Sensor everywhere, and the page says its effect: one gradiometer of
    baseline L > 0 is observable (the differences are not homogeneous in r: spec §11's scale
    symmetry breaks at order (L/r)²), where the point tensor is rank 7 of 8 everywhere."""
    from app.page import tensor_text
    from app.tabs.design.compute import _fisher_options
    from app.tabs.track import track

    s = Scenario(sensor=GRADIOMETER, baseline=0.5, **SMALL)
    p = compute(Snapshot.of(s))
    sensor = core.Sensor("G", 0.01, baseline=0.5)
    want = core.evaluate_map(s.snapshot().core_plane(), core.single_station(s.stations.h),
                             velocity=s.snapshot().velocity(), moments=(-3000.0, 1000.0, 5000.0),
                             measure="crlb_position", T=s.sensor.T, steps=s.sensor.steps,
                             sensor=sensor)
    assert same(p.a.value, want.value) and same(p.a.observable, want.observable)
    assert p.a.observable.mean() > 0.9  # one gradiometer, observable with its baseline
    assert "baseline 0.5 m" in p.captions[0]
    assert _fisher_options(s.snapshot())["sensor"] == sensor  # Layout design
    assert track.case_of(s.snapshot()).sensor == sensor  # Track
    assert all(applies("baseline", s.snapshot(), tab) for tab in (MAPS_TAB, DESIGN_TAB, TRACK_TAB))
    assert not applies("baseline", Scenario(sensor=MAGNETOMETER).snapshot(), MAPS_TAB)
    assert "sets the scale" in tensor_text("G", 0.5) and "point gradient tensor" in tensor_text("BG", 0.0)
    point = compute(Snapshot.of(Scenario(sensor=GRADIOMETER, **SMALL)))
    assert not point.a.observable.any() and "baseline" not in point.captions[0]
