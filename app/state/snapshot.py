"""A snapshot of the scenario: the values of the inputs a computation reads, frozen and hashable,
the key of every tab's computations in the process's one cache (:mod:`app.kit.cache`)."""

from __future__ import annotations

from dataclasses import dataclass

from .scenario import Scenario, ScenarioValues, inputs

#: The scene, a snapshot's default reads: a target in a sea, seen by sensors on the paper's
#: stations, over a region, and the Maps tab's own settings (the maps read exactly these:
#: :data:`app.tabs.maps.compute.READS`); not the custom stations of the Layout design and Track
#: tabs.
SCENE = inputs("target", "stations", "medium", "sensor", "region", "maps", but=("stations",))


def _frozen(value):
    """A value as a key holds it: lists (stations, zones, fixed stations) as tuples, nested."""
    return tuple(_frozen(v) for v in value) if isinstance(value, list) else value


def _thawed(value):
    return [_thawed(v) for v in value] if isinstance(value, tuple) else value


@dataclass(frozen=True)
class Snapshot:
    """The values of the inputs a computation reads as a hashable tuple of (name, value) pairs:
    the key of every tab's computations in the one cache (:class:`app.kit.cache.PanelCache`)."""

    items: tuple

    @classmethod
    def of(cls, scenario: Scenario, reads=SCENE):
        """The values of the inputs ``reads`` (names; default :data:`SCENE`)."""
        return cls(tuple((n, _frozen(scenario.value(n))) for n in reads))

    @classmethod
    def of_values(cls, scenario: Scenario, values, reads=SCENE):
        """As :meth:`of`, with the inputs in ``values`` (name -> value) replaced: a dragged
        slider's value before it reaches the scenario (app/tabs/maps/live.py)."""
        unknown = set(values) - set(reads)
        if unknown:
            raise KeyError(f"not inputs read: {sorted(unknown)}")
        return cls(tuple((n, _frozen(values[n] if n in values else scenario.value(n)))
                         for n in reads))

    def scenario(self):
        """These values alone, with the methods that build core's inputs (not a live Scenario).
        Reading an input the snapshot does not hold raises AttributeError: a computation keyed
        on a snapshot cannot read a value its key leaves out."""
        return ScenarioValues(**{k: _thawed(val) for k, val in self.items})
