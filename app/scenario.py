"""The dashboard's whole state: one param class, no Panel import.

Numeric parameters carry only *soft* bounds (the slider range): a value typed outside them is
still offered to :class:`Scenario`, which checks it against :data:`ACCEPTED` (what the core and a
sane grid accept), restores the last good value and says why in :attr:`Scenario.message`. So a
bad value never reaches the core, never raises in the server, and the last good maps stay.
"""

from __future__ import annotations

import math
import types

import param

import core

#: Hard limits: name -> (lowest, highest, unit). Enforced by Scenario; sliders span less.
#: Depths (spec §7: z positive down, the sea surface at z = 0) are never negative: there is no sea
#: above the surface, whatever the field model.
ACCEPTED = {
    "Ph": (0.0, 1e5, "A·m"),
    "Pv": (0.0, 1e5, "A·m"),
    "Ph_b": (0.0, 1e5, "A·m"),
    "Pv_b": (0.0, 1e5, "A·m"),
    "k": (1e-3, 1e3, ""),
    "h": (0.0, 5000.0, "m"),
    "z": (0.0, 5000.0, "m"),
    "y": (-5000.0, 5000.0, "m"),
    "speed": (0.01, 100.0, "m/s"),
    "heading": (-180.0, 180.0, "°"),
    "d": (0.1, 5000.0, "m"),
    "d_ref": (0.1, 5000.0, "m"),
    "T": (1e-3, 1000.0, "s"),
    "sigma": (1e-3, 100.0, "S/m"),
    "noise": (1e-12, 1e-2, "V/m"),
    "steps": (1, 20, "instants"),
    "extent": (1.0, 10000.0, "m"),
    "z_min": (0.0, 5000.0, "m"),
    "z_max": (0.0, 5000.0, "m"),
    "resolution": (20, 400, "points per axis"),
    "threshold": (0.01, 1e5, "m"),
}

MEASURE_LABELS = {
    "log10|det Γ| (paper)": "log10_det",
    "Observability index log10 η": "log10_eta",
    "D-optimal ½·log10 det F": "d_optimal",
    "CRLB position error (m)": "crlb_position",
}
COMPARISONS = {
    "Dual − single (Fig. 5)": "dual_vs_single",
    "Moments ×k − original (Fig. 3)": "moments_scaled",
    "Moment split B − A (Fig. 4)": "moment_split",
    "Spacing d − reference d (Fig. 6)": "spacing",
}
CRITERIA = {
    "Mean D-optimal over the region": "mean_dopt",
    "Worst-case D-optimal over the region": "worst_dopt",
    "Area with CRLB error under threshold": "area_crlb",
}
#: Error maps of the design tab: label -> core.CrlbErrors attribute.
ERROR_QUANTITIES = {
    "3-D position error (m)": "position",
    "Horizontal error, semi-major axis (m)": "semi_major",
    "Depth error σz (m)": "sigma_z",
    "Speed error σ|v| (m/s)": "sigma_speed",
}
#: Most stations a custom layout may have.
MAX_STATIONS = 8
#: Parameters that are depths below the sea surface (m): a negative value is above the surface.
DEPTHS = ("h", "z", "z_min", "z_max")
DIFFERENCES = {"log10 Δ|det| (paper, Δ ≤ 0 blank)": "paper", "Signed log-ratio": "ratio"}
MODELS = {"exact dipole": "exact", "paper eqs. (10)–(12) as printed": "paper"}
STATE_SETS = {"all 7 unknown": (), "moments known (5 states)": ("Ph", "Pv")}

_COMMON = dict(Ph=100.0, Pv=20.0, h=100.0, z=120.0, speed=2.0 * math.sqrt(2.0), heading=45.0,
               T=1.0, plane="x–y", extent=300.0, measure="log10|det Γ| (paper)")
#: The paper's figures (spec §5) as parameter sets.
PRESETS = {
    "Fig. 1": dict(_COMMON, layout="single", comparison="Dual − single (Fig. 5)", d=15.0),
    "Fig. 2": dict(_COMMON, plane="x–z", y=50.0, z_min=100.0, z_max=400.0, layout="single",
                   comparison="Moment split B − A (Fig. 4)", Ph_b=100.0, Pv_b=100.0),
    "Fig. 3": dict(_COMMON, layout="single", comparison="Moments ×k − original (Fig. 3)", k=10.0),
    "Fig. 4": dict(_COMMON, layout="single", comparison="Moment split B − A (Fig. 4)",
                   Ph=100.0, Pv=0.0, Ph_b=70.7, Pv_b=70.7),
    "Fig. 5": dict(_COMMON, layout="dual", comparison="Dual − single (Fig. 5)", d=15.0),
    "Fig. 6": dict(_COMMON, layout="dual", comparison="Spacing d − reference d (Fig. 6)",
                   d=50.0, d_ref=10.0),
}

#: Which map shows each paper figure: preset -> (map index 0 A, 1 B, 2 difference, caption).
PAPER_MAPS = {
    "Fig. 1": ((0,), "map A is the paper's Fig. 1: log10|det Γ| of one station over x–y"),
    "Fig. 2": ((0, 1), "maps A and B are the paper's Fig. 2(a) (P_h > P_v) and 2(b) (P_h = P_v), x–z"),
    "Fig. 3": ((2,), "the difference map is the paper's Fig. 3: moments × 10 minus the original"),
    "Fig. 4": ((2,), "the difference map is the paper's Fig. 4(a): (70.7, 70.7) − (100, 0) A·m"),
    "Fig. 5": ((2,), "the difference map is the paper's Fig. 5(b): dual (d = 15 m) minus single"),
    "Fig. 6": ((2,), "the difference map is the paper's Fig. 6: dual d = 50 m minus d = 10 m"),
}


def _num(default, soft, label, doc, **kw):
    return param.Number(default, softbounds=soft, label=label, doc=doc, **kw)


class Scenario(param.Parameterized):
    """Everything a view needs to draw the maps."""

    # -- target and sources
    Ph = _num(100.0, (0, 1000), "P_h (A·m)", "Horizontal dipole moment of the target, A·m.")
    Pv = _num(20.0, (0, 1000), "P_v (A·m)", "Vertical dipole moment of the target, A·m.")
    speed = _num(2.0 * math.sqrt(2.0), (0.1, 20), "Speed (m/s)", "Target speed, m/s (> 0).")
    heading = _num(45.0, (-180, 180), "Heading (°)",
                   "Course over ground, degrees from +x towards +y; the horizontal dipole points along it.")
    # -- geometry
    plane = param.Selector(objects=["x–y", "x–z"], default="x–y", label="Map plane",
                           doc="x–y: horizontal plane at target depth z. x–z: vertical plane at fixed y.")
    z = _num(120.0, (0, 1000), "Target depth z (m)", "Target depth for the x–y plane, m (same axis as h).")
    y = _num(50.0, (-500, 500), "Fixed y (m)", "y of the x–z plane, m.")
    h = _num(100.0, (0, 1000), "Station depth h (m)", "Depth of every station, m.")
    d = _num(15.0, (0.5, 300), "Station spacing d (m)", "Station 2 sits at (d, 0, h); station 1 at (0, 0, h).")
    layout = param.Selector(objects=["single", "dual"], default="dual", label="Layout for Figs. 3–4",
                            doc="Station layout used by the moment comparisons.")
    # -- comparison
    comparison = param.Selector(objects=list(COMPARISONS), default="Dual − single (Fig. 5)", label="Compare",
                                doc="Which two scenarios the maps A and B and their difference show.")
    k = _num(10.0, (0.1, 100), "Moment factor k", "Fig. 3: B has both moments × k.")
    Ph_b = _num(70.7, (0, 1000), "B: P_h (A·m)", "Fig. 4: horizontal moment of scenario B, A·m.")
    Pv_b = _num(70.7, (0, 1000), "B: P_v (A·m)", "Fig. 4: vertical moment of scenario B, A·m.")
    d_ref = _num(10.0, (0.5, 300), "Reference spacing (m)", "Fig. 6: spacing of scenario A, m.")
    difference = param.Selector(objects=list(DIFFERENCES), default="log10 Δ|det| (paper, Δ ≤ 0 blank)",
                                label="Difference map", doc="How B is compared with A.")
    measure = param.Selector(objects=list(MEASURE_LABELS), default="log10|det Γ| (paper)", label="Measure",
                             doc="What the maps show.")
    # -- advanced
    T = _num(1.0, (0.1, 10), "Sample interval T (s)", "Time between measurements, s.")
    sigma = _num(4.0, (0.1, 10), "Conductivity σ (S/m)", "Sea conductivity, S/m; shifts log10|det Γ| only.")
    noise = _num(1e-7, (1e-9, 1e-5), "Sensor noise (V/m)", "Noise standard deviation per component, V/m.")
    steps = param.Integer(3, softbounds=(1, 10), label="Instants N (Fisher)",
                          doc="Number of instants for the Fisher measures.")
    model = param.Selector(objects=list(MODELS), default="exact dipole", label="Field model",
                           doc="'paper' reproduces the printed equations, which are not a dipole field.")
    state_set = param.Selector(objects=list(STATE_SETS), default="all 7 unknown", label="Unknown states",
                               doc="Treat the moments as known to make one station observable.")
    extent = _num(300.0, (10, 2000), "Half-width of x (and y) (m)", "Maps span ±extent in x (and y), m.")
    z_min = _num(100.0, (0, 1000), "x–z plane: z from (m)", "Shallowest target depth of the x–z plane, m.")
    z_max = _num(400.0, (0, 2000), "x–z plane: z to (m)", "Deepest target depth of the x–z plane, m.")
    resolution = param.Integer(200, softbounds=(20, 400), label="Grid points per axis",
                               doc="Map resolution; at most 400 per axis.")
    # -- layout design
    stations = param.List([[0.0, 0.0, 100.0], [15.0, 0.0, 100.0]], item_type=list,
                          label="Stations (x, y, z) (m)",
                          doc="Custom layout for the design tab: 1 to 8 stations anywhere, m.")
    criterion = param.Selector(objects=list(CRITERIA), default="Mean D-optimal over the region",
                               label="Spacing criterion", doc="What the best spacing maximises.")
    error_quantity = param.Selector(objects=list(ERROR_QUANTITIES), default="3-D position error (m)",
                                    label="Error map", doc="Which Cramér–Rao error the design map shows.")
    layout_kind = param.Selector(objects=["line", "triangle", "square", "free"], default="square",
                                 label="Optimise: layout shape",
                                 doc="Shape of the N-station layout to optimise ('free': any positions, slow).")
    n_stations = param.Integer(4, bounds=(1, 8), label="Optimise: stations N",
                               doc="Number of stations of the layout to optimise, 1 to 8.")
    threshold = _num(10.0, (0.1, 100), "CRLB threshold (m)",
                     "For 'area within threshold': position error (1σ, m) that counts as good.")
    # -- feedback
    message = param.String("", doc="Why the last input was refused (plain text).")
    refused = param.List([], item_type=str,
                         doc="The parameters the message is about (shown next to their inputs); "
                             "empty for a message about the page's link.")

    def __init__(self, **params):
        # Hard limits hold from the start: a bad value given here falls back to the default.
        notes = [n for n in (self.problem(k, v) for k, v in params.items() if k in ACCEPTED) if n]
        params = {k: v for k, v in params.items() if k not in ACCEPTED or self.problem(k, v) is None}
        super().__init__(**params)
        if notes:
            self.message = "; ".join(notes) + ". Used the default."
        self._restoring = False
        self.param.watch(self._check, list(ACCEPTED))
        self.param.watch(self._check_stations, ["stations"])

    def _check(self, *events):
        """Restore the last good value of any parameter set outside ACCEPTED, and say so."""
        if self._restoring:
            return
        notes = [p for p in (self.problem(ev.name, ev.new) for ev in events) if p]
        if not notes and self.z_min >= self.z_max:
            notes.append("x–z plane: 'z to' must be deeper than 'z from'")
        if not notes:
            if self.message:
                self.param.update(message="", refused=[])
            return
        names = [ev.name for ev in events]
        self._restoring = True
        try:
            self.param.update({ev.name: ev.old for ev in events})
        finally:
            self._restoring = False
        self.param.update(message="; ".join(notes) + ". Kept the last good value.", refused=names)

    def _check_stations(self, event):
        problem = self.stations_problem(event.new)
        if problem:
            self._restoring = True
            try:
                self.stations = event.old
            finally:
                self._restoring = False
            self.param.update(message=problem + ". Kept the last good layout.", refused=["stations"])
        elif not self._restoring and self.message:
            self.param.update(message="", refused=[])

    @staticmethod
    def stations_problem(value):
        """None if ``value`` is 1–8 finite (x, y, z) positions within the accepted range (z: a depth,
        0 … 5000 m), else why."""
        lo, hi, _ = ACCEPTED["y"]
        if not 1 <= len(value) <= MAX_STATIONS:
            return f"A layout needs 1 to {MAX_STATIONS} stations; got {len(value)}"
        for i, st in enumerate(value):
            ok = len(st) == 3 and all(isinstance(c, (int, float)) and not isinstance(c, bool)
                                      and math.isfinite(c) and lo <= c <= hi for c in st)
            if not ok:
                return (f"Station {i + 1} must be three numbers (x, y, z) in {lo:g} … {hi:g} m; "
                        f"got {str(st)[:60]!r}")
            if st[2] < 0:
                return (f"Station {i + 1}: depth z = {st[2]:g} m is above the sea surface; depths are "
                        f"measured down from the surface (z ≥ 0)")
        return None

    @staticmethod
    def problem(name, value):
        """None if ``value`` is acceptable for ``name``, else a plain-text reason."""
        lo, hi, unit = ACCEPTED[name]
        label = Scenario.param[name].label
        is_int = isinstance(Scenario.param[name], param.Integer)
        ok_type = isinstance(value, int) if is_int else isinstance(value, (int, float))
        if isinstance(value, bool) or not ok_type or not math.isfinite(value):
            kind = "a whole number" if is_int else "a number"
            return f"{label} must be {kind}; got {str(value)[:40]!r}"
        if name in DEPTHS and value < 0:
            return (f"{label} = {value:g} is above the sea surface: depths are measured down from "
                    f"the surface, {lo:g} … {hi:g} {unit}")
        if not lo <= value <= hi:
            return f"{label} = {value:g} is outside the accepted range {lo:g} … {hi:g} {unit}".rstrip()
        return None

    def apply_preset(self, name):
        """Set the parameters of one of the paper's figures (:data:`PRESETS`)."""
        self.param.update(PRESETS[name])

    def active_preset(self):
        """The paper figure (a :data:`PRESETS` name) whose parameters the scenario holds, or None."""
        return preset_of(self)

    # -- what the core needs
    def core_plane(self):
        n = int(self.resolution)
        if self.plane == "x–y":
            return core.Plane("xy", (-self.extent, self.extent), (-self.extent, self.extent), self.z, n)
        return core.Plane("xz", (-self.extent, self.extent), (self.z_min, self.z_max), self.y, n)

    def velocity(self):
        return core.velocity_from_heading(self.speed, self.heading)

    def core_options(self):
        return dict(T=self.T, sigma=self.sigma, model=MODELS[self.model], known=STATE_SETS[self.state_set],
                    noise=self.noise, steps=int(self.steps), measure=MEASURE_LABELS[self.measure])


def preset_of(values):
    """The first :data:`PRESETS` name whose parameters ``values`` (attributes) all hold, or None."""
    for name, preset in PRESETS.items():
        if all(getattr(values, k) == v for k, v in preset.items()):
            return name
    return None


class ScenarioValues(types.SimpleNamespace):
    """A scenario's values, read-only use, with the methods that build core's inputs: what the
    map computations need, without building a Scenario (its parameters, checks and watchers took
    a few ms of Python, under the GIL, for every map of every session)."""

    core_plane = Scenario.core_plane
    velocity = Scenario.velocity
    core_options = Scenario.core_options

    @classmethod
    def of(cls, values):
        """Every parameter's default, overridden by ``values`` (already accepted by a Scenario)."""
        return cls(**{**{name: p.default for name, p in Scenario.param.objects().items()}, **values})
