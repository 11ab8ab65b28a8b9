"""The base of the dashboard's state parts (:mod:`app.parts`): a param class whose inputs are
checked against hard limits, and whose refusals its owning :class:`app.scenario.Scenario` says.

No Panel import.
"""

from __future__ import annotations

import math

import param

#: Inputs that are depths below the sea surface (m): a negative value is above the surface.
DEPTHS = ("h", "z", "z_min", "z_max")


class Part(param.Parameterized):
    """One concern's inputs, checked: a value outside :attr:`accepted` (or, for a part that
    overrides :meth:`problem`, any value it refuses) is reported to the owning
    :class:`Scenario`, which restores the last good value and says why."""

    #: Hard limits: name -> (lowest, highest, unit). Depths (spec §7: z positive down, the sea
    #: surface at z = 0) are never negative: there is no sea above the surface.
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
        if name in DEPTHS and value < 0:
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
