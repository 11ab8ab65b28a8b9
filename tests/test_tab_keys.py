"""Tabs depend on what they read (issue 39 item 2): each tab's cache key changes exactly when its
computation reads the input that changed.

For every cached computation of a tab, two sets of inputs are found independently and compared:

- what its key depends on: each input of the scenario is changed in turn, and the key (the
  :class:`app.state.snapshot.Snapshot` the tab builds, from the tab's own declaration) compared with the
  default's;
- what the computation reads: it runs on that key's values with every attribute read recorded,
  over scenarios that take each of its branches (each sensor kind, a layered sea, the x–z plane,
  each comparison, …). A snapshot's values hold its key's inputs only (reading another raises
  AttributeError), so a computation cannot read a value its key leaves out; this test finds the
  other way round, an input in the key that nothing reads (changing it would recompute a tab
  for nothing: h, d and the target's speed re-ran the Track tab's Monte-Carlo).

The Shape tab's computation is given its key's values as a plain mapping (``dict(key.items)``), so
it can read nothing else; what it reads of them is not recorded here. The Calibration tab keys its
task on its own part's values (app/tabs/calibration/calibration.py) and is not in the shared cache.
"""

from __future__ import annotations

import pytest

from app.state.scenario import PART_OF, Scenario, ScenarioValues, defaults, inputs
from app.tabs.design import compute as design_compute, survey_compute
from app.tabs.maps import compute
from app.tabs.maps.compute import Snapshot
from app.tabs.shape import shape
from app.tabs.track import track

#: The inputs read by the computation running now (see :class:`Recorded`).
READ = set()


class Recorded(ScenarioValues):
    """A snapshot's values that note each input read."""

    def __getattribute__(self, name):
        if name in PART_OF:
            READ.add(name)
        return super().__getattribute__(name)


class Recording(Snapshot):
    """A snapshot whose values note what is read of them (a key of its own in the cache)."""

    def scenario(self):
        return Recorded(**vars(super().scenario()))


class Values:
    """What a key reads of a scenario (``value(name)``), from a plain mapping."""

    def __init__(self, values):
        self.values = values

    def value(self, name):
        return self.values[name]


def other(value):
    """A value different from ``value`` of the same kind (a key compares values only)."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, (int, float)):
        return value + 1
    if isinstance(value, list):
        return [*value, [1.0, 2.0, 3.0]]
    return f"{value} (changed)"


def key_inputs(key):
    """The inputs whose change changes ``key(scenario)``."""
    base = defaults()
    return {n for n in base if key(Values({**base, n: other(base[n])})) != key(Values(base))}


#: Scenarios that take the computations' branches: the sensor kinds (and a gradiometer's
#: baseline), the sea, the unknowns, the plane, the comparisons and measures. Small grids and one
#: short track: the numbers do not matter here, only what is read.
SMALL = dict(resolution=21, track_runs=1, track_duration=10.0)
KINDS = [{}, dict(sensor="magnetometer (B, nT)"), dict(sensor="gradiometer (G, nT/m)", baseline=0.5),
         dict(sensor="magnetometer + gradiometer (BG)"), dict(sea_model="layered"),
         dict(state_set="moments known (5 states)")]
MAPS_ONLY = [dict(plane="x–z"), dict(layout="single"), dict(measure="CRLB position error (m)"),
             dict(comparison="Moments ×k − original (Fig. 3)"),
             dict(comparison="Moment split B − A (Fig. 4)"),
             dict(comparison="Moment split B − A (Fig. 4)", sensor="magnetometer (B, nT)"),
             dict(comparison="Spacing d − reference d (Fig. 6)"),
             dict(comparison="Sensor kind B − A (seed 003)")]


def reads(fn, reads_of, variants):
    """Every input ``fn`` reads of a snapshot of ``reads_of``, over the scenarios ``variants``."""
    found = set()
    for values in variants:
        s = Scenario(**SMALL)
        s.update(values)
        assert all(s.value(k) == v for k, v in values.items()), s.message  # taken, not refused
        READ.clear()
        fn(Recording(Snapshot.of(s, reads_of).items))
        found |= READ
    return found


#: Each cached computation of a tab: (its key's inputs, the computation, the scenarios to run).
COMPUTATIONS = {
    "Maps: the three maps": (compute.READS, compute.compute, KINDS + MAPS_ONLY),
    "Layout design: error map and ellipse": (
        design_compute.ERROR_MAP_READS,
        lambda snap: (design_compute.design(snap), design_compute.error_at(snap, 100.0, 50.0)),
        KINDS),
    "Layout design: best spacing": (design_compute.SPACING_READS, design_compute.best_spacing,
                                    KINDS[:1] + KINDS[3:]),
    "Layout design: optimised layout": (design_compute.LAYOUT_READS, design_compute.optimised_layout,
                                        KINDS[:1] + KINDS[3:]),
    "Layout design: the N−1 loss map": (survey_compute.LOSS_READS, survey_compute.loss_design, KINDS),
    "Layout design: stations-count curve": (survey_compute.COUNT_READS, survey_compute.count_curve,
                                            KINDS[:1] + KINDS[3:]),
    "Track: the Monte-Carlo": (track.READS, track.outputs_of, KINDS),
}


@pytest.mark.parametrize("name", list(COMPUTATIONS))
def test_a_tabs_key_changes_exactly_when_its_computation_reads_the_input(name):
    declared, fn, variants = COMPUTATIONS[name]
    in_key = key_inputs(lambda v: Snapshot.of(v, declared))
    read = reads(fn, declared, variants)
    assert {"keyed, never read": sorted(in_key - read), "read, not keyed": sorted(read - in_key)} == \
        {"keyed, never read": [], "read, not keyed": []}


def test_the_track_tab_does_not_rerun_for_the_paper_stations_or_the_targets_motion():
    """The issue's case: h, d and the target's speed re-ran the Track tab's Monte-Carlo."""
    in_key = key_inputs(lambda v: Snapshot.of(v, track.READS))
    assert {"h", "d", "layout", "speed", "heading"}.isdisjoint(in_key)
    assert {"stations", "z", "Ph", "track_speed", "T"} <= in_key


def test_the_maps_do_not_recompute_for_the_custom_stations_nor_another_tab():
    in_key = key_inputs(lambda v: Snapshot.of(v))
    assert "stations" not in in_key and {"h", "d", "speed", "measure"} <= in_key
    assert not [n for n in in_key if PART_OF[n] in ("design", "track", "calibration", "shape")]


def test_the_shape_tab_is_keyed_on_its_own_inputs_alone():
    assert key_inputs(shape.key_of) == set(inputs("shape"))


def test_a_snapshot_holds_its_keys_inputs_alone():
    """What makes a computation unable to read what its key leaves out."""
    v = Snapshot.of(Scenario(), track.READS).scenario()
    assert v.track_speed == 2.0
    with pytest.raises(AttributeError):
        v.h  # noqa: B018


def test_the_key_finder_sees_a_change():
    """key_inputs finds an input of a key (so that an empty difference above means something)."""
    assert key_inputs(lambda v: Snapshot.of(v, ("h", "stations"))) == {"h", "stations"}
