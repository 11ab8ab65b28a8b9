"""The base of the dashboard's state parts (:mod:`app.state.parts`): a param class whose inputs are
checked against hard limits, and whose refusals its owning :class:`app.state.scenario.Scenario` says.

Each input is declared once, on its part, with everything the page needs: param's own (default,
soft bounds, label with the unit, doc) and, in the parameter's ``metadata`` (:func:`declared`):

- ``hard``: (lowest, highest, unit), the limits a typed value must keep (refused otherwise);
- ``depth``: a depth below the sea surface (never negative; in the water column of a layered sea);
- ``card``: (title, place) of the sidebar card it is shown in (:data:`CARDS`), and ``shown``: a
  rule of a :class:`Where` saying when it applies (it is hidden otherwise);
- ``moves``: a choice whose change moves other values by a rule (said under it); ``fmt``: its
  slider's number format; ``slider``: False for a number with a box only;
- ``kinds``: the sensor kinds (core kinds E, B, G, BG) whose measurement reads it (shown only
  where one of them is measured, and what each kind's part reads: app.state.sensors); ``moment``: a
  component of the target's moments (the states a "moments known" scenario drops);
- ``seabed``: where a layered sea puts it, and keeps it when the sea depth D changes:
  ``"bottom"`` (on the seabed, z = D; a list of stations: each station's z), ``"within"`` (kept
  in the water column [0, D]), ``"surface"`` (z = 0); ``layered``: the only value a layered sea
  takes;
- ``group``: the card of a tab's own inputs it is shown in (the Shape tab's), in declaration
  order; ``sources``: the Calibration tab's data sources it applies to (default: every one);
  ``vector``: a component of a vector input (the geomagnetic field Be: north, east, down, in
  declaration order).

The sidebar, visibility, refusals, the URL and depth handling are derived from these.

No Panel import.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import param

#: The sidebar's cards, in order: title -> collapsed when the page opens. Each input says in its
#: declaration which card shows it, and where (its ``card``).
CARDS = {"View": False, "Target": False, "Stations": False, "Sea": False,
         "Scenario B of Figs. 3, 4, 6": True, "Advanced": True}


@dataclass(frozen=True)
class Where:
    """What an input's visibility rule (its ``shown`` declaration) reads: the tab it would be shown
    on and the choices that decide what applies there."""

    on_maps: bool  # the Maps tab is shown
    on_track: bool  # the Track tab is shown (it has a speed and heading of its own)
    kinds: frozenset  # the sensor kinds (core kinds) the tab's inputs feed: A's and B's on the maps
    sensor: str  # the scenario's sensor kind (core kind)
    comparison: str  # the maps' comparison (core key)
    measure: str  # the maps' measure (core key)
    plane: str
    layout: str
    sea_model: str

    @property
    def electric(self):
        return "E" in self.kinds

    @property
    def magnetic(self):
        return bool(self.kinds - {"E"})

    @property
    def layered(self):
        """A layered sea that matters: a static magnetic field does not see the sea."""
        return self.sea_model == "layered" and self.electric

    @property
    def split(self):
        """The Maps tab compares two moments (Fig. 4)."""
        return self.on_maps and self.comparison == "moment_split"


def declared(p):
    """The declaration of parameter ``p`` beyond param's own (module docstring): a dict."""
    return p.metadata or {}


def limits(cls):
    """The hard limits declared on the inputs of part ``cls``: name -> (lowest, highest, unit)."""
    return {n: declared(cls.param[n])["hard"] for n in cls.names() if "hard" in declared(cls.param[n])}


class Part(param.Parameterized):
    """One concern's inputs, checked: a value outside :attr:`accepted` (or, for a part that
    overrides :meth:`problem`, any value it refuses) is reported to the owning
    :class:`Scenario`, which restores the last good value and says why."""

    #: Hard limits: name -> (lowest, highest, unit), as declared (:func:`limits`; set on each part
    #: class by app.state.parts). Depths (spec §7: z positive down, the sea surface at z = 0) are never
    #: negative: there is no sea above the surface.
    accepted = {}
    #: Parameters checked beyond :attr:`accepted` (by an overridden :meth:`problem`).
    also_checked = ()
    #: A tab with a problem (and presets) of its own: the paper-figure presets leave it alone.
    own_presets = False

    def __init__(self, owner=None, **params):
        super().__init__(**params)
        self._owner = owner
        checked = [*self.accepted, *self.also_checked]
        if checked and owner is not None:
            self.param.watch(lambda *events: owner.checked(events), checked)

    @classmethod
    def names(cls):
        """This part's parameters (its inputs)."""
        return tuple(n for n in cls.param if n != "name")

    @classmethod
    def problem(cls, name, value):
        """None if ``value`` is acceptable for ``name`` on its own, else a plain-text reason."""
        if name not in cls.accepted:
            return None
        lo, hi, unit = cls.accepted[name]
        label = cls.param[name].label
        is_int = isinstance(cls.param[name], param.Integer)
        ok_type = isinstance(value, int) if is_int else isinstance(value, (int, float))
        if isinstance(value, bool) or not ok_type or not math.isfinite(value):
            kind = "a whole number" if is_int else "a number"
            return f"{label} must be {kind}; got {str(value)[:40]!r}"
        if declared(cls.param[name]).get("depth") and value < 0:
            return (f"{label} = {value:.10g} is above the sea surface: depths are measured down from "
                    f"the surface, {lo:g} … {hi:g} {unit}")
        if not lo <= value <= hi:
            # the value to 10 digits: "100000" for 100000.1 read as if the bound had been refused
            return f"{label} = {value:.10g} is outside the accepted range {lo:g} … {hi:g} {unit}".rstrip()
        return None

    def rules(self):
        """Why this part's values disagree with each other (e.g. an empty x–z range); else []."""
        return []

    def refuse(self, name, why):
        """Say, as the owner's refusal message next to input ``name``, why a typed text was not
        taken (e.g. not a number); the value is unchanged."""
        self._owner.param.update(message=f"{self.param[name].label}: {why}. Kept the last good value.",
                                 refused=[name])
