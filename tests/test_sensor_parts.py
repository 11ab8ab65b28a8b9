"""The sensor kind is a selector of sensor parts (issue 39 item 1): each kind of the Sensor
selector is a small param part (app.state.sensors) that builds its own ``core.Sensor``.

Checked here: the selector offers exactly the parts' labels; each part builds, for the same
inputs, the same ``core.Sensor`` as the code it replaced (written out below as it was in
``ScenarioValues.core_options``); and each part reads exactly the inputs declared with its kind
(``kinds``, app.state.part), so what the page shows for a kind and what the kind measures with agree.
"""

from __future__ import annotations

import itertools

import pytest

import core
from app.state import sensors
from app.state.derive import moments, read_by
from app.state.scenario import MODELS, SENSORS, PART_OF, Scenario, ScenarioValues, parameter


def built_before(v, kind):
    """The ``core.Sensor`` as ``ScenarioValues.core_options`` built it before the sensor parts."""
    if kind != "E":
        noise = {"B": v.noise_b, "G": v.noise_g, "BG": (v.noise_b, v.noise_g)}[kind]
        baseline = v.baseline if "G" in kind and v.baseline > 0 else None
        return core.Sensor(kind, noise, baseline=baseline)
    sea = core.Sea(v.sea_depth, v.seabed_sigma) if v.sea_model == "layered" else None
    return core.Sensor("E", v.noise, v.sigma, sea, MODELS[v.model])


#: Inputs that change what a sensor is: both seas and field models, baselines 0 and > 0, noises.
VARIANTS = [dict(sea_model=sea, model=model, baseline=baseline, noise=noise, noise_b=nb, noise_g=ng,
                 sigma=sigma, sea_depth=D, seabed_sigma=sb)
            for (sea, D, sb), model, baseline, (noise, nb, ng), sigma in itertools.product(
                [("whole space", 200.0, 1.0), ("layered", 8.4, 0.4), ("layered", 150.0, 0.0)],
                list(MODELS), [0.0, 0.5, 2.0], [(1e-7, 0.01, 0.01), (3e-9, 0.2, 5.0)], [4.0, 0.3])]


def test_the_selector_offers_the_sensor_parts():
    assert list(parameter("sensor").objects) == [p.label for p in sensors.KINDS]
    assert list(parameter("sensor_b").objects) == [p.label for p in sensors.KINDS]
    assert SENSORS == {p.label: p.kind for p in sensors.KINDS}
    assert sorted(p.kind for p in sensors.KINDS) == sorted(core.KINDS)
    assert all(isinstance(p, sensors.SensorKind) for p in sensors.KINDS)


def test_the_kinds_words_and_units_in_titles_are_the_parts():
    from app.tabs.maps.compute import KIND_NAMES

    assert KIND_NAMES == {"E": ("electric", "V/m"), "B": ("magnetometer", "nT"),
                          "G": ("gradiometer", "nT/m"), "BG": ("magnetometer + gradiometer", "nT, nT/m")}
    for p in sensors.KINDS:  # the label names the kind and its unit
        assert f"({p.kind}" in p.label and (p.kind == "BG" or p.unit in p.label)


@pytest.mark.parametrize("part", sensors.KINDS, ids=lambda p: p.kind)
def test_each_part_builds_the_same_sensor_as_before(part):
    for values in VARIANTS:
        v = ScenarioValues.of(values)
        built = part.sensor(v)
        assert built == built_before(v, part.kind), values
        assert built.kind == part.kind
        # and through the scenario: core_options of the kind, as the maps and tabs call it
        assert v.core_options(part.kind)["sensor"] == built


@pytest.mark.parametrize("part", sensors.KINDS, ids=lambda p: p.kind)
def test_each_part_reads_the_inputs_declared_with_its_kind(part):
    """What the part's sensor and the kind's moments read, over every variant, is what the inputs
    declare (``kinds``): an input shown for a kind is one its sensor reads, and the other way round."""
    read = set()

    class Recorded(ScenarioValues):
        def __getattribute__(self, name):
            if name in PART_OF:
                read.add(name)
            return super().__getattribute__(name)

    for values in VARIANTS:
        v = Recorded.of(values)
        part.sensor(v)
        part.noise_text(v)
        v.moments(part.kind)
    assert read == set(read_by(part.kind)), sorted(read ^ set(read_by(part.kind)))
    assert set(moments(part.kind)) <= read


def test_the_scenarios_sensor_is_its_chosen_part():
    for part in sensors.KINDS:
        s = Scenario(sensor=part.label, measure="CRLB position error (m)")
        v = s.snapshot()
        assert sensors.BY_LABEL[s.sensor.sensor] is part
        assert v.core_options()["sensor"] == part.sensor(v) == built_before(v, part.kind)
