"""What the page derives from the inputs' declarations (app.state.part: a parameter's metadata)
beyond the sidebar and the limits (app.state.parts): what each sensor kind reads, the target's
moments, where a layered sea puts an input, a tab's own cards.

No Panel import.
"""

from __future__ import annotations

from functools import cache

from .part import declared
from .parts import PART_OF, parameter


def having(key, names=None):
    """The inputs (of ``names``; default all) that declare ``key``, in order: name -> its value."""
    return {n: declared(parameter(n))[key] for n in (PART_OF if names is None else names)
            if key in declared(parameter(n))}


@cache  # the declarations are the classes': each map's compute asked, ~600 lookups, 2.5 ms
def read_by(kind):
    """The inputs the measurement of sensor kind ``kind`` (core kind) reads, as declared (``kinds``)."""
    return tuple(n for n, kinds in having("kinds").items() if kind in kinds)


@cache
def moments(kind):
    """The target's moment inputs of sensor kind ``kind``, in order: (Ph, Pv) or (mx, my, mz)."""
    return tuple(n for n in having("moment") if n in read_by(kind))


def groups(names):
    """The cards of a tab's own inputs ``names``, as declared (``group``): ((title, [names]), …)
    in declaration order."""
    cards = {}
    for name, title in having("group", names).items():
        cards.setdefault(title, []).append(name)
    return tuple(cards.items())


#: Where a layered sea puts an input, as declared (``seabed``: "bottom", "within", "surface").
SEABED = having("seabed")
#: The only value a layered sea takes of an input, as declared (``layered``: the field model).
LAYERED = having("layered")


def on_seabed(rule, value, D):
    """Where a layered sea of depth ``D`` puts ``value`` of an input declared ``seabed=rule``."""
    if isinstance(value, list):  # stations: each station's depth
        return [[st[0], st[1], on_seabed(rule, st[2], D)] for st in value]
    return {"bottom": D, "within": min(max(value, 0.0), D), "surface": 0.0}[rule]


#: What the magnetic kinds' measurements read, as declared (``kinds``).
MAGNETIC_READS = tuple(n for n, kinds in having("kinds").items() if set(kinds) - {"E"})
