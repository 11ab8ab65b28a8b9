"""The dashboard's state: the small param parts of :mod:`app.state.parts`, one per concern, composed
into one Scenario; the paper's presets.

No Panel import. The parts (:data:`PARTS`) are the shared scenario — :class:`Target`,
:class:`Stations`, :class:`Medium`, :class:`Sensor`, :class:`Region` — and one part per tab's
own settings (:class:`Maps`, :class:`Design`, :class:`Track`, :class:`Calibration`,
:class:`Shape`). A tab is a function of the inputs it reads (declared once, by the parts and the
inputs it takes: ``app.tabs.maps.compute.READS``, ``app.tabs.track.track.READS`` …) and recomputes when one of them
changes; a link and a
preset are derived from every part. Parameter names are unique across the parts, so a link
writes them flat (``?Ph=100&track_heading=33``) and links of earlier versions still open.

Refusals: a value outside a part's hard limits (:attr:`app.state.part.Part.accepted`), or one that
breaks a rule between values (the x–z range, the water column), is never kept: the last good
value is restored and the reason is said in :attr:`Scenario.message`, naming the inputs in
:attr:`Scenario.refused`. So a bad value never reaches the core, never raises in the server,
and the last good maps stay.
"""

from __future__ import annotations

import threading
import types
from contextlib import ExitStack, contextmanager

import param
from param.parameterized import batch_call_watchers

import core

from .derive import LAYERED, SEABED, groups, having, moments, on_seabed, read_by  # noqa: F401
from .presets import presets
from .sensors import BY_KIND

# The parts live in app/state/parts.py (their base in app/state/part.py); their names are this module's too
# (``from app.state.scenario import Target``), as before the split.
from .part import CARDS, Part, Where  # noqa: F401
from .parts import (  # noqa: F401
    ACCEPTED,
    COMPARISONS,
    CRITERIA,
    DEPTHS,
    DIFFERENCES,
    ERROR_QUANTITIES,
    MAX_STATIONS,
    MEASURE_LABELS,
    MODELS,
    PART_OF,
    PARTS,
    SEA_MODELS,
    SENSORS,
    SQUARE_MEASURES,
    STATE_SETS,
    Calibration,
    Design,
    Maps,
    Medium,
    Region,
    Sensor,
    Shape,
    Stations,
    Target,
    Track,
    defaults,
    inputs,
    parameter,
    shown,
    sidebar,
)

#: The paper's figures (spec §5) and the seeds' cases as parameter sets: the scenario files of
#: app/state/presets/paper/ (docs/study.md), one place for each.
PRESETS = presets("paper")

#: Which map shows each paper figure: preset -> (map index 0 A, 1 B, 2 difference, caption).
PAPER_MAPS = {
    "Fig. 1": ((0,), "map A is the paper's Fig. 1: log10|det Γ| of one station over x–y"),
    "Fig. 2": ((0, 1), "maps A and B are the paper's Fig. 2(a) (P_h > P_v) and 2(b) (P_h = P_v), x–z"),
    "Fig. 3": ((2,), "the difference map is the paper's Fig. 3: moments × 10 minus the original"),
    "Fig. 4": ((2,), "the difference map is the paper's Fig. 4(a): (70.7, 70.7) − (100, 0) A·m"),
    "Fig. 5": ((2,), "the difference map is the paper's Fig. 5(b): dual (d = 15 m) minus single"),
    "Fig. 6": ((2,), "the difference map is the paper's Fig. 6: dual d = 50 m minus d = 10 m"),
}



class Scenario(param.Parameterized):
    """Everything the page shows, composed of :data:`PARTS` (``scenario.target.Ph``…), with the
    rules between them and the feedback on refused values."""

    message = param.String("", doc="Why the last input was refused (plain text).")
    refused = param.List([], item_type=str,
                         doc="The parameters the message is about (shown next to their inputs); "
                             "empty for a message about the page's link.")

    def __init__(self, **values):
        unknown = sorted(set(values) - set(PART_OF))
        if unknown:
            raise TypeError(f"Scenario has no input {', '.join(unknown)}")
        super().__init__()
        self._restoring_in = threading.local()  # per thread: Panel runs watchers on two at once
        #: One update (a preset, a link) at a time, its watchers included: Panel runs two clicks'
        #: watchers on two of its threads at once, and two presets interleaved left a mix of both
        self._updating = threading.RLock()
        # Hard limits hold from the start: a bad value given here falls back to the default.
        notes = [n for n in (self.problem(k, v) for k, v in values.items()) if n]
        good = {k: v for k, v in values.items() if self.problem(k, v) is None}
        for attr, cls in PARTS.items():
            setattr(self, attr, cls(self, **{n: good[n] for n in cls.names() if n in good}))
        if notes:
            self.message = "; ".join(notes) + ". Used the default."
        # the rules between parts, each watching what triggers it
        def unless_restoring(rule):
            return lambda *_: None if self._restoring else rule()

        self.watch_inputs(unless_restoring(self._seabed), ["sea_model"])
        self.watch_inputs(unless_restoring(self._layered_values), list(LAYERED))
        self.watch_inputs(unless_restoring(self._all_rows), ["sensor", "sensor_b", "comparison", "measure"])
        self.watch_inputs(unless_restoring(self._shape_sizes), ["shape_type"])
        self._all_rows()

    def __setattr__(self, name, value):
        # an input set here would be a stray attribute that nothing reads: say where it lives
        if name in PART_OF and name not in PARTS:
            raise AttributeError(f"{name} is an input of scenario.{PART_OF[name]}: set "
                                 f"scenario.{PART_OF[name]}.{name} (or scenario.update({name}=…))")
        super().__setattr__(name, value)

    # -- the parts, by input name
    def part_of(self, name):
        """The part holding input ``name``."""
        return getattr(self, PART_OF[name])

    def value(self, name):
        return getattr(self.part_of(name), name)

    def values(self, parts=None):
        """Every input's value: name -> value (of the parts named ``parts``; default all)."""
        return {n: getattr(getattr(self, a), n) for a in (parts or PARTS) for n in PARTS[a].names()}

    def inputs(self, names):
        """The values of the inputs ``names``: name -> value."""
        return {n: self.value(n) for n in names}

    def ref(self, name):
        """Input ``name`` as a bound parameter (for pn.bind, widgets' from_param, watching)."""
        return self.part_of(name).param[name]

    def watch(self, fn, parts):
        """Call ``fn(*events)`` when any input of the parts named ``parts`` changes."""
        for attr in parts:
            part = getattr(self, attr)
            part.param.watch(fn, list(part.names()))

    def watch_inputs(self, fn, names):
        """Call ``fn(*events)`` when any of the inputs ``names`` changes (one batch of events per
        part)."""
        by_part = {}
        for n in names:
            by_part.setdefault(PART_OF[n], []).append(n)
        for attr, these in by_part.items():
            getattr(self, attr).param.watch(fn, these)

    def update(self, values=None, as_given=False, **more):
        """Set many inputs at once (a link, a preset): every watcher sees them together, the
        rules between them are checked on the whole; if one is broken nothing changes and
        :attr:`message` says why.

        ``as_given`` (a link): a rule may move only the inputs *not* in ``values``; one that
        would have to move a given value refuses the whole update instead (a link ``?sea_model=
        layered&sea_depth=80&h=100`` is refused for its h, not opened with h moved to 80)."""
        with self._updating:
            self._update({**(values or {}), **more}, as_given)

    #: Whether this thread restores or moves values: no part checks, no rule (on this thread only)
    _restoring = property(lambda self: getattr(self._restoring_in, "on", False),
                          lambda self, on: setattr(self._restoring_in, "on", on))

    def _update(self, values, as_given=False):
        notes = [p for p in (self.problem(n, v) for n, v in values.items()) if p]
        before = self.values()
        was, self._restoring = self._restoring, True  # no part checks, no rule, until all are set
        try:
            with self._batched():
                if not notes:
                    self._quietly(**values)
                    self.param.update(message="", refused=[])
                    # the rules that move values, as if each input had been set by hand
                    if values.get("sea_model") == "layered" and before["sea_model"] != "layered":
                        self._seabed(keep=values if as_given else ())
                    notes = self.rules()
                    if as_given and not notes:
                        self._all_rows()
                        self._shape_sizes()
                        now = self.values()
                        notes = [f"{parameter(n).label} = {values[n]} does not fit the other values "
                                 f"({self.message})" for n in values if now[n] != values[n]][:1]
                if notes:
                    now = self.values()
                    self._quietly(**{n: v for n, v in before.items() if now[n] != v})
                    self.param.update(message="; ".join(notes) + ". Kept the last good value.",
                                      refused=list(values))
                    return
                self._all_rows()
                if "shape_type" in values:
                    self._shape_sizes()
        finally:
            self._restoring = was

    @contextmanager
    def _batched(self):
        """Watchers of every part see the changes made inside at once, at the end."""
        with ExitStack() as stack:
            for attr in PARTS:
                stack.enter_context(batch_call_watchers(getattr(self, attr)))
            yield

    def _quietly(self, **values):
        """Set values without checking them (restoring, or moving them by a rule)."""
        by_part = {}
        for n, v in values.items():
            by_part.setdefault(PART_OF[n], {})[n] = v
        was, self._restoring = self._restoring, True
        try:
            for attr, vals in by_part.items():
                getattr(self, attr).param.update(vals)
        finally:
            self._restoring = was

    # -- refusals
    @staticmethod
    def problem(name, value):
        """None if ``value`` is acceptable for input ``name`` on its own, else why."""
        return PARTS[PART_OF[name]].problem(name, value)

    def rules(self):
        """Why the inputs disagree with each other (each part's own rules, then the water
        column's); else []."""
        return [n for attr in PARTS for n in getattr(self, attr).rules()][:1] or self.column_problems()

    def checked(self, events):
        """A part's watcher: restore the last good value of any input set outside its limits or
        against the rules, and say so."""
        if self._restoring:
            return
        notes = [p for p in (self.problem(ev.name, ev.new) for ev in events) if p]
        moved = {}  # stations on the seabed stay there when D changes
        for ev in events:
            if ev.name == "sea_depth" and not notes and self.medium.sea_model == "layered":
                moved = self._follow_seabed(ev.old, ev.new)
                self._quietly(**moved)
            elif ev.name == "h" and not notes:
                # the custom stations at the station depth move with it (the Layout design and
                # Track tabs' stations stayed at the old h while the sidebar said "every station")
                moved = self._follow_h(ev.old, ev.new)
                self._quietly(**moved)
        notes = notes or self.rules()
        if not notes:
            if self.message:
                self.param.update(message="", refused=[])
            return
        back = {ev.name: ev.old for ev in events}
        if moved and "sea_depth" in back:
            back.update(self._follow_seabed(self.medium.sea_depth, back["sea_depth"]))
        elif moved:
            back.update(self._follow_h(self.stations.h, back["h"]))
        self._quietly(**back)
        kept = "layout" if [ev.name for ev in events] == ["stations"] else "value"
        self.param.update(message="; ".join(notes) + f". Kept the last good {kept}.",
                          refused=[ev.name for ev in events])

    def column_problems(self, stations=None, names=DEPTHS):
        """In a layered sea, why depths (and custom stations) are outside [0, D]; else []."""
        if self.medium.sea_model != "layered":
            return []
        D = self.medium.sea_depth
        notes = [f"{parameter(n).label} = {self.value(n):g} m is outside the water column "
                 f"0 … {D:g} m" for n in names if not 0.0 <= self.value(n) <= D]
        notes += [f"Station {i + 1} depth {st[2]:g} m is outside the water column 0 … {D:g} m"
                  for i, st in enumerate(self.stations.stations if stations is None else stations)
                  if not 0.0 <= st[2] <= D]
        return notes[:1]

    # -- rules that move values
    def _seabed(self, keep=()):
        """Switching to a layered sea puts each input where its declaration says (``seabed``:
        the stations on the seabed, h = D; the target and the x–z plane into the water column)
        and the field model to the exact dipole (its ``layered`` value: the paper's printed
        equations have no images). ``keep``: inputs it leaves as they are."""
        if self.medium.sea_model != "layered":
            return
        D = self.medium.sea_depth
        moved = {**{n: on_seabed(rule, self.value(n), D) for n, rule in SEABED.items()}, **LAYERED}
        moved = {n: v for n, v in moved.items() if n not in keep}
        if not moved:
            return
        said = [f"{parameter(n).label.split(' (')[0]} {self.value(n):g} → {moved[n]:g} m"
                for n in DEPTHS if n in moved and self.value(n) != moved[n]]
        said += [f"custom stations to the seabed ({D:g} m)" for n in moved
                 if isinstance(self.value(n), list) and moved[n] != self.value(n)]
        said += [f"{parameter(n).label.lower()} → {v} (the paper's printed equations have no images)"
                 for n, v in LAYERED.items() if n in moved and self.value(n) != v]
        self._quietly(**moved)
        note = ("Layered sea: moved " + "; ".join(said) + ". These stay when you switch back to the "
                "whole space." if said else "")
        self.param.update(message=note, refused=["sea_model"] if note else [])

    def _all_rows(self):
        """A magnetic kind on the maps moves the measure off the paper's square-Γ rule (the
        electric paper's, refused by core for magnetic kinds) to the CRLB, and says so."""
        if self.maps.measure not in SQUARE_MEASURES or not self.magnetic_maps():
            return
        self._quietly(measure="CRLB position error (m)")
        self.param.update(message=f"{parameter('measure').label}: the paper's square-Γ rule is the "
                                  "electric paper's; magnetic sensors use all rows of N instants: "
                                  "measure → CRLB position error.",
                          refused=["sensor" if SENSORS[self.sensor.sensor] != "E" else "sensor_b"])

    def magnetic_maps(self):
        """Whether map A or B measures with a magnetic kind."""
        return _magnetic_maps(self.sensor.sensor, self.maps.comparison, self.maps.sensor_b)

    def _layered_values(self):
        """In a layered sea, an input declared with the only value a layered sea takes (the
        exact dipole) is set back to it."""
        if self.medium.sea_model != "layered":
            return
        for n, v in LAYERED.items():
            if self.value(n) != v:
                self._quietly(**{n: v})
                self.param.update(message="The paper's printed equations have no layered-sea form: "
                                          "use the whole space.", refused=[n])

    def _follow_seabed(self, old, new):
        """Values that sat on the old seabed (declared ``seabed="bottom"``: h, z_max, custom
        stations), moved to the new one."""
        moved = {}
        for n, rule in SEABED.items():
            value = self.value(n)
            if rule != "bottom":
                continue
            if isinstance(value, list):  # stations: each station's depth
                stations = [[st[0], st[1], new if st[2] == old else st[2]] for st in value]
                moved.update({n: stations} if stations != value else {})
            elif value == old:
                moved[n] = new
        return moved

    def _follow_h(self, old, new):
        """The custom stations that sat at the old station depth h, moved to the new one (a
        station given a depth of its own, in the Layout design table, keeps it)."""
        stations = [[st[0], st[1], new if st[2] == old else st[2]] for st in self.stations.stations]
        return {"stations": stations} if stations != self.stations.stations else {}

    def _shape_sizes(self):
        """A type the sizes disagree with (a cylinder has H > R, a disc H ≤ R) sets the type's
        typical sizes (seed 003's cylinder, Table 5's disc) and a solid body, and says so."""
        s = self.shape
        cylinder = s.shape_type == "cylinder"
        if (s.shape_height > s.shape_radius) == cylinder:
            return
        H, R = (3.0, 0.5) if cylinder else (0.3, 1.0)
        self._quietly(shape_height=H, shape_radius=R, shape_inner_height=0.0, shape_inner_radius=0.0)
        self.param.update(message=f"{s.shape_type.capitalize()}: set H = {H:g} m, R = {R:g} m, "
                                  "solid (the sizes were the other type's).", refused=["shape_type"])

    # -- presets
    def apply_preset(self, name):
        """Load one of :data:`PRESETS` as a complete scenario: every input of every part is the
        preset's or its default, whatever was set before, but the parts with problems (and
        presets) of their own (calibration, shape) and the :data:`TAB_OWN` tabs' own settings
        that no preset sets (:func:`preset_values`)."""
        self.update(preset_values(name))

    def active_preset(self):
        """The paper figure (a :data:`PRESETS` name) whose parameters the scenario holds, or None."""
        return preset_of(types.SimpleNamespace(**{k: self.value(k) for k in PRESET_INPUTS}))

    def snapshot(self, parts=None):
        """The values of ``parts`` (default all) with the methods that build core's inputs."""
        return ScenarioValues.of(self.values(parts))


def _magnetic_maps(sensor, comparison, sensor_b):
    return SENSORS[sensor] != "E" or (COMPARISONS[comparison] == "sensor_kinds"
                                      and SENSORS[sensor_b] != "E")


#: Parts that are one tab's own settings shown beside the paper-figure buttons (the Layout design
#: and Track tabs): a figure button leaves those of their inputs that no figure sets as the user
#: set them (Fig. 1 reset the Track tab's runs from 2 to 5, without a word).
TAB_OWN = ("design", "survey", "track")


def preset_values(name):
    """Every input :meth:`Scenario.apply_preset` sets for preset ``name``: its values over the
    defaults of every part but those with presets of their own, and but the inputs of the
    :data:`TAB_OWN` parts that no preset sets (a preset is still whole: what one preset sets,
    another sets back)."""
    shared = [a for a, cls in PARTS.items() if not cls.own_presets]
    kept = {n for a in TAB_OWN for n in PARTS[a].names()} - set(PRESET_INPUTS)
    return {**{n: v for n, v in defaults(shared).items() if n not in kept},
            **{k: [list(v) for v in val] if k == "stations" else val
               for k, val in PRESETS[name].items()}}


#: Every input some preset sets (what :meth:`Scenario.active_preset` reads).
PRESET_INPUTS = tuple(sorted({k for preset in PRESETS.values() for k in preset}))


def preset_of(values, names=None):
    """The first :data:`PRESETS` name whose parameters ``values`` (attributes) all hold, or None.
    ``names``: compare only these parameters (a map snapshot holds only what the maps use)."""
    for name, preset in PRESETS.items():
        if all(getattr(values, k) == v for k, v in preset.items() if names is None or k in names):
            return name
    return None


class ScenarioValues(types.SimpleNamespace):
    """A scenario's values (flat: ``v.Ph``, ``v.plane``), read-only use, with the methods that
    build core's inputs: what the computations need, without the parts' checks and watchers
    (they took a few ms of Python, under the GIL, for every map of every session)."""

    @classmethod
    def of(cls, values):
        """Every input's default, overridden by ``values`` (already accepted by a Scenario)."""
        return cls(**{**defaults(), **values})

    def core_plane(self):
        n = int(self.resolution)
        if self.plane == "x–y":
            return core.Plane("xy", (-self.extent, self.extent), (-self.extent, self.extent), self.z, n)
        return core.Plane("xz", (-self.extent, self.extent), (self.z_min, self.z_max), self.y, n)

    def velocity(self):
        return core.velocity_from_heading(self.speed, self.heading)

    def magnetic_maps(self):
        """Whether map A or B measures with a magnetic kind."""
        return _magnetic_maps(self.sensor, self.comparison, self.sensor_b)

    def measure_key(self):
        """The core key of the maps' measure, as the Scenario moves it (``_all_rows``): also for
        values that did not pass the rule."""
        return ("crlb_position" if self.measure in SQUARE_MEASURES and self.magnetic_maps()
                else MEASURE_LABELS[self.measure])

    def core_options(self, kind=None, measure=True):
        """Keywords of core's map functions for sensor ``kind`` (a :data:`SENSORS` value; default
        the scenario's): the measurement as one ``core.Sensor``, electric (its noise in V/m, the
        medium) or magnetic (its noise in nT and nT/m; a static field does not see the sea).
        ``measure``: with the maps' measure (:meth:`measure_key`); the Layout design tab's
        computations read none."""
        kind = SENSORS[self.sensor] if kind is None else kind
        common = dict(T=self.T, steps=int(self.steps))
        if measure:
            common["measure"] = self.measure_key()
        sensor = BY_KIND[kind].sensor(self)  # the kind's sensor part builds it (app.state.sensors)
        # known moments: the sensor's states past position and velocity (x, y, z, vx, vy)
        known = sensor.state_names[5:] if STATE_SETS[self.state_set] else ()
        return dict(common, known=known, sensor=sensor)

    def moments(self, kind=None):
        """The target's moments for sensor ``kind``: (P_h, P_v) A·m, or (m_x, m_y, m_z) A·m²."""
        kind = SENSORS[self.sensor] if kind is None else kind
        return tuple(getattr(self, n) for n in moments(kind))
