"""The dashboard's state in small param parts, one per concern (composed into one
:class:`app.state.scenario.Scenario`).

No Panel import. The shared scenario is :class:`Target`, :class:`Stations`, :class:`Medium`,
:class:`Sensor`, :class:`Region`, and each tab's own settings a part of their own
(:class:`Maps`, :class:`Design`, :class:`Track`, :class:`Calibration`, :class:`Shape`);
:data:`PARTS` lists them. Parameter names are unique across the parts.

Refusals (the base class :class:`app.state.part.Part`): numeric parameters carry only *soft* bounds
(the slider range); a value typed outside a part's ``accepted`` hard limits (what the core and
a sane grid accept) is never kept: the last good value is restored and the reason is said in
:attr:`app.state.scenario.Scenario.message`.
"""

from __future__ import annotations

import math

import param

import core

from .part import CARDS, Part, declared, limits
from .sensors import KINDS, MODELS
from .survey import SURVEY_CRITERIA, SURVEY_QUANTITIES, Survey

#: Most stations a custom layout may have.
MAX_STATIONS = 8

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
    "Sensor kind B − A (seed 003)": "sensor_kinds",
}
CRITERIA = {
    "Mean D-optimal over the region": "mean_dopt",
    "Worst-case D-optimal over the region": "worst_dopt",
    "Area with CRLB error under threshold": "area_crlb",
    **SURVEY_CRITERIA,  # issue 49's: A, E, worst point, N−1 coverage (app/state/survey.py)
}
#: Error maps of the design tab: label -> core.CrlbErrors attribute.
ERROR_QUANTITIES = {
    "3-D position error (m)": "position",
    "Horizontal error, semi-major axis (m)": "semi_major",
    "Depth error σz (m)": "sigma_z",
    "Speed error σ|v| (m/s)": "sigma_speed",
    **SURVEY_QUANTITIES,  # the worst single-loss map (app/state/survey.py)
}
#: Sensor kinds (spec §11, core.Sensor): label -> core kind, of the sensor parts (app.state.sensors).
SENSORS = {part.label: part.kind for part in KINDS}
#: Measures that use the paper's square Γ (electric only): a magnetic kind moves off them.
SQUARE_MEASURES = ("log10|det Γ| (paper)", "Observability index log10 η")
DIFFERENCES = {"log10 Δ|det| (paper, Δ ≤ 0 blank)": "paper", "Signed log-ratio": "ratio"}
#: The unknown states: label -> whether the target's moments are known (their states are then
#: dropped: core.Sensor.state_names past position and velocity).
STATE_SETS = {"all 7 unknown": False, "moments known (5 states)": True}
SEA_MODELS = ("whole space", "layered")

def _in(**declaration):
    """An input's declaration beyond param's own (``hard``, ``depth``, ``card``, ``shown``, ``moves``,
    ``fmt``, ``slider``: app.state.part), kept in the parameter's metadata."""
    return declaration


def _num(default, soft, label, doc, **kw):
    return param.Number(default, softbounds=soft, label=label, doc=doc, **kw)


class Target(Part):
    """The target: its sources (electric moments P_h, P_v; a magnetic moment vector), its motion
    and its depth."""

    Ph = _num(100.0, (0, 1000), "P_h (A·m)", "Horizontal dipole moment of the target, A·m.",
        metadata=_in(moment=True, kinds=("E",), card=("Target", 0), hard=(0.0, 1e5, "A·m")))
    Pv = _num(20.0, (0, 1000), "P_v (A·m)", "Vertical dipole moment of the target, A·m.",
        metadata=_in(moment=True, kinds=("E",), card=("Target", 1), hard=(0.0, 1e5, "A·m")))
    mx = _num(-3000.0, (-20000, 20000), "m_x (A·m²)", "Magnetic moment of the target, x, A·m².",
        metadata=_in(moment=True, kinds=("B", "G", "BG"), card=("Target", 2), hard=(-1e7, 1e7, "A·m²")))
    my = _num(1000.0, (-20000, 20000), "m_y (A·m²)", "Magnetic moment of the target, y, A·m².",
        metadata=_in(moment=True, kinds=("B", "G", "BG"), card=("Target", 3), hard=(-1e7, 1e7, "A·m²")))
    mz = _num(5000.0, (-20000, 20000), "m_z (A·m²)", "Magnetic moment of the target, z (down), A·m².",
        metadata=_in(moment=True, kinds=("B", "G", "BG"), card=("Target", 4), hard=(-1e7, 1e7, "A·m²")))
    speed = _num(2.0 * math.sqrt(2.0), (0.1, 20), "Speed (m/s)", "Target speed, m/s (> 0).",
        metadata=_in(card=("Target", 5), hard=(0.01, 100.0, "m/s"), shown=lambda w: not w.on_track))
    heading = _num(45.0, (-180, 180), "Heading (°)",
                   "Course over ground, degrees from +x towards +y; the horizontal dipole points along it.",
        metadata=_in(card=("Target", 6), hard=(-180.0, 180.0, "°"), shown=lambda w: not w.on_track))
    z = _num(120.0, (0, 1000), "Target depth z (m)", "Target depth for the x–y plane, m (same axis as h).",
        metadata=_in(seabed="within", card=("Target", 7), hard=(0.0, 5000.0, "m"), depth=True, shown=lambda w: w.plane == "x–y" or not w.on_maps))


def _station_problem(st, lo, hi):
    """What is wrong with one station of a layout, in words (never a Python list: issue 46
    defect 7 quoted "got '[nan, 0.0, 100.0]'"), or None."""
    if not isinstance(st, (list, tuple)) or len(st) != 3:
        n = len(st) if isinstance(st, (list, tuple)) else 1
        return f"it has {n} coordinate{'s' if n != 1 else ''}"
    for axis, c in zip("xyz", st):
        if isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c):
            return f"its {axis} is empty or not a number"
        if not lo <= c <= hi:
            return f"its {axis} = {c:.10g} m is outside that range"
    return None


class Stations(Part):
    """Where the sensors are: the paper's single / dual station at depth h and spacing d, and
    the custom layout of the Layout design and Track tabs."""

    also_checked = ("stations",)

    @classmethod
    def problem(cls, name, value):
        if name != "stations":
            return super().problem(name, value)
        lo, hi, _ = Region.accepted["y"]  # x, y and z alike
        if not 1 <= len(value) <= MAX_STATIONS:
            if len(value) > MAX_STATIONS:
                return f"At most {MAX_STATIONS} stations: a {len(value)}th was refused"
            return f"A layout needs 1 to {MAX_STATIONS} stations; got {len(value)}"
        for i, st in enumerate(value):
            why = _station_problem(st, lo, hi)
            if why:
                return f"Station {i + 1} must be three numbers (x, y, z) in {lo:g} … {hi:g} m: {why}"
            if st[2] < 0:
                return (f"Station {i + 1}: depth z = {st[2]:g} m is above the sea surface; depths are "
                        f"measured down from the surface (z ≥ 0)")
        return None

    h = _num(100.0, (0, 1000), "Station depth h (m)",
             "Depth of the paper's stations, and of every custom station at it (Layout design, "
             "Track): they move with h; one given its own depth in the table keeps it, m.",
        metadata=_in(seabed="bottom", card=("Stations", 0), hard=(0.0, 5000.0, "m"), depth=True))
    d = _num(15.0, (0.5, 300), "Station spacing d (m)", "Station 2 sits at (d, 0, h); station 1 at (0, 0, h).",
        metadata=_in(card=("Stations", 1), hard=(0.1, 5000.0, "m"), shown=lambda w: w.on_maps and not (w.comparison in ("moments_scaled", "moment_split", "sensor_kinds") and w.layout == "single")))
    layout = param.Selector(objects=["single", "dual"], default="dual", label="Layout for Figs. 3–4",
                            doc="Station layout used by the moment comparisons.",
        metadata=_in(card=("Stations", 2), shown=lambda w: w.on_maps and w.comparison in ("moments_scaled", "moment_split", "sensor_kinds")))
    stations = param.List([[0.0, 0.0, 100.0], [15.0, 0.0, 100.0]], item_type=list,
                          label="Stations (x, y, z) (m)",
                          doc="Custom layout for the design tab: 1 to 8 stations anywhere, m.",
        metadata=_in(seabed="bottom"))


class Medium(Part):
    """The sea (spec §7) and the electric field model."""

    sea_model = param.Selector(objects=list(SEA_MODELS), default="whole space", label="Sea",
                               doc="Whole space (the paper) or layered: insulating air above, a "
                                   "seabed below; z and h are then depths in [0, D].",
        metadata=_in(kinds=("E",), card=("Sea", 0), moves=True))
    sea_depth = _num(200.0, (1, 500), "Sea depth D (m)", "Water depth D of the layered sea, m.",
        metadata=_in(kinds=("E",), card=("Sea", 1), hard=(0.5, 10000.0, "m"), shown=lambda w: w.layered))
    seabed_sigma = _num(1.0, (0, 10), "Seabed conductivity σb (S/m)",
                        "Conductivity of the seabed half-space, S/m (0: insulating).",
        metadata=_in(kinds=("E",), card=("Sea", 2), hard=(0.0, 1000.0, "S/m"), shown=lambda w: w.layered))
    sigma = _num(4.0, (0.1, 10), "Conductivity σ (S/m)", "Sea conductivity, S/m; shifts log10|det Γ| only.",
        metadata=_in(kinds=("E",), card=("Advanced", 3), hard=(1e-3, 100.0, "S/m")))
    model = param.Selector(objects=list(MODELS), default="exact dipole", label="Field model",
                           doc="'paper' reproduces the printed equations, which are not a dipole field.",
        metadata=_in(kinds=("E",), layered="exact dipole", card=("Advanced", 0), moves=True))


class Sensor(Part):
    """What every station measures, how noisy, how often, and what is unknown (spec §11)."""

    sensor = param.Selector(objects=list(SENSORS), default="electric (E, V/m)", label="Sensor",
                            doc="What every station measures: the electric field (the paper), the "
                                "magnetic field, its gradient tensor, or both (spec §11): the label "
                                "of a sensor part (app.state.sensors), which builds its core.Sensor.",
        metadata=_in(card=("View", 0), moves=True))
    noise = _num(1e-7, (1e-9, 1e-5), "Sensor noise (V/m)", "Noise standard deviation per component, V/m.",
        metadata=_in(kinds=("E",), card=("Advanced", 4), hard=(1e-12, 1e-2, "V/m"), slider=False))
    noise_b = _num(0.01, (1e-3, 10), "Magnetometer noise (nT)",
                   "Noise standard deviation per field component, nT.",
        metadata=_in(kinds=("B", "BG"), card=("Advanced", 5), hard=(1e-6, 1e3, "nT"), fmt='0.[0000]'))
    noise_g = _num(0.01, (1e-3, 10), "Gradiometer noise (nT/m)",
                   "Noise standard deviation per tensor component, nT/m.",
        metadata=_in(kinds=("G", "BG"), card=("Advanced", 6), hard=(1e-6, 1e3, "nT/m"), fmt='0.[0000]'))
    baseline = _num(0.0, (0, 2), "Gradiometer baseline L (m)",
                    "0: the point gradient tensor. L > 0: magnetometers ±L/2 along each axis read "
                    "as differences (seed 003: 0.5 m). It sets the scale: one gradiometer alone "
                    "becomes observable, its bound growing steeply with range / L; targets within "
                    "L of a station are masked.",
        metadata=_in(kinds=("G", "BG"), card=("Advanced", 7), hard=(0.0, 10.0, "m")))
    T = _num(1.0, (0.1, 10), "Sample interval T (s)", "Time between measurements, s.",
        metadata=_in(card=("Advanced", 2), hard=(1e-3, 1000.0, "s")))
    steps = param.Integer(3, softbounds=(1, 10), label="Instants N (Fisher)",
                          doc="Number of instants for the Fisher measures.",
        metadata=_in(card=("Advanced", 8), hard=(1, 20, "instants")))
    state_set = param.Selector(objects=list(STATE_SETS), default="all 7 unknown", label="Unknown states",
                               doc="Treat the moments as known to make one station observable.",
        metadata=_in(card=("Advanced", 1)))


class Region(Part):
    """The grid of target positions the maps and the design cover."""

    plane = param.Selector(objects=["x–y", "x–z"], default="x–y", label="Map plane",
                           doc="x–y: horizontal plane at target depth z. x–z: vertical plane at fixed y.",
        metadata=_in(card=("View", 5), shown=lambda w: w.on_maps))
    y = _num(50.0, (-500, 500), "Fixed y (m)", "y of the x–z plane, m.",
        metadata=_in(card=("Target", 8), hard=(-5000.0, 5000.0, "m"), shown=lambda w: w.on_maps and w.plane == "x–z"))
    extent = _num(300.0, (10, 2000), "Half-width of x (and y) (m)", "Maps span ±extent in x (and y), m.",
        metadata=_in(card=("Advanced", 9), hard=(1.0, 10000.0, "m")))
    z_min = _num(100.0, (0, 1000), "x–z plane: z from (m)", "Shallowest target depth of the x–z plane, m.",
        metadata=_in(seabed="surface", card=("Advanced", 10), hard=(0.0, 5000.0, "m"), depth=True, shown=lambda w: w.on_maps and w.plane == "x–z"))
    z_max = _num(400.0, (0, 2000), "x–z plane: z to (m)", "Deepest target depth of the x–z plane, m.",
        metadata=_in(seabed="bottom", card=("Advanced", 11), hard=(0.0, 5000.0, "m"), depth=True, shown=lambda w: w.on_maps and w.plane == "x–z"))
    resolution = param.Integer(200, softbounds=(20, 400), label="Grid points per axis",
                               doc="Map resolution; at most 400 per axis.",
        metadata=_in(card=("Advanced", 12), hard=(20, 400, "points per axis")))

    def rules(self):
        if self.z_min >= self.z_max:
            return ["x–z plane: 'z to' must be deeper than 'z from'"]
        return []


class Maps(Part):
    """The Maps tab's own settings: the measure, the comparison and scenario B."""

    measure = param.Selector(objects=list(MEASURE_LABELS), default="log10|det Γ| (paper)", label="Measure",
                             doc="What the maps show.",
        metadata=_in(card=("View", 1), shown=lambda w: w.on_maps))
    comparison = param.Selector(objects=list(COMPARISONS), default="Dual − single (Fig. 5)", label="Compare",
                                doc="Which two scenarios the maps A and B and their difference show.",
        metadata=_in(card=("View", 2), shown=lambda w: w.on_maps))
    difference = param.Selector(objects=list(DIFFERENCES), default="log10 Δ|det| (paper, Δ ≤ 0 blank)",
                                label="Difference map", doc="How B is compared with A.",
        metadata=_in(card=("View", 4), shown=lambda w: w.on_maps and w.measure in ("log10_det", "d_optimal")))
    k = _num(10.0, (0.1, 100), "Moment factor k", "Fig. 3: B has both moments × k.",
        metadata=_in(card=("Scenario B of Figs. 3, 4, 6", 0), hard=(1e-3, 1e3, ""), shown=lambda w: w.on_maps and w.comparison == "moments_scaled"))
    Ph_b = _num(70.7, (0, 1000), "B: P_h (A·m)", "Fig. 4: horizontal moment of scenario B, A·m.",
        metadata=_in(card=("Scenario B of Figs. 3, 4, 6", 1), hard=(0.0, 1e5, "A·m"), shown=lambda w: w.split and w.sensor == "E"))
    Pv_b = _num(70.7, (0, 1000), "B: P_v (A·m)", "Fig. 4: vertical moment of scenario B, A·m.",
        metadata=_in(card=("Scenario B of Figs. 3, 4, 6", 2), hard=(0.0, 1e5, "A·m"), shown=lambda w: w.split and w.sensor == "E"))
    d_ref = _num(10.0, (0.5, 300), "Reference spacing (m)", "Fig. 6: spacing of scenario A, m.",
        metadata=_in(card=("Scenario B of Figs. 3, 4, 6", 6), hard=(0.1, 5000.0, "m"), shown=lambda w: w.on_maps and w.comparison == "spacing"))
    sensor_b = param.Selector(objects=list(SENSORS), default="magnetometer + gradiometer (BG)",
                              label="B: sensor", doc="Sensor comparison: the kind of scenario B.",
        metadata=_in(card=("View", 3), moves=True, shown=lambda w: w.on_maps and w.comparison == "sensor_kinds"))
    mx_b = _num(0.0, (-20000, 20000), "B: m_x (A·m²)", "Moment split, magnetic: m_x of scenario B, A·m².",
        metadata=_in(card=("Scenario B of Figs. 3, 4, 6", 3), hard=(-1e7, 1e7, "A·m²"), shown=lambda w: w.split and w.sensor != "E"))
    my_b = _num(0.0, (-20000, 20000), "B: m_y (A·m²)", "Moment split, magnetic: m_y of scenario B, A·m².",
        metadata=_in(card=("Scenario B of Figs. 3, 4, 6", 4), hard=(-1e7, 1e7, "A·m²"), shown=lambda w: w.split and w.sensor != "E"))
    mz_b = _num(6000.0, (-20000, 20000), "B: m_z (A·m²)", "Moment split, magnetic: m_z of scenario B, A·m².",
        metadata=_in(card=("Scenario B of Figs. 3, 4, 6", 5), hard=(-1e7, 1e7, "A·m²"), shown=lambda w: w.split and w.sensor != "E"))


class Design(Part):
    """The Layout design tab's own settings."""

    criterion = param.Selector(objects=list(CRITERIA), default="Mean D-optimal over the region",
                               label="Spacing criterion", doc="What the best spacing maximises.")
    error_quantity = param.Selector(objects=list(ERROR_QUANTITIES), default="3-D position error (m)",
                                    label="Error map", doc="Which Cramér–Rao error the design map shows.")
    layout_kind = param.Selector(objects=["line", "triangle", "square", "free"], default="square",
                                 label="Optimise: layout shape",
                                 doc="Shape of the N-station layout to optimise ('free': any positions, slow).")
    n_stations = param.Integer(4, softbounds=(1, 8), label="Optimise: stations N",
                               doc="Number of stations of the layout to optimise, 1 to 8.",
        metadata=_in(hard=(1, MAX_STATIONS, "stations")))
    ellipse_x = param.Number(100.0, softbounds=(-1000.0, 1000.0),
                             label="Error ellipse at x (m)",
                             doc="x of the target whose horizontal error ellipse is drawn, m.",
        metadata=_in(hard=(-5000.0, 5000.0, "m")))
    ellipse_y = param.Number(100.0, softbounds=(-1000.0, 1000.0),
                             label="Error ellipse at y (m)",
                             doc="y of the target whose horizontal error ellipse is drawn, m.",
        metadata=_in(hard=(-5000.0, 5000.0, "m")))
    threshold = _num(10.0, (0.1, 100), "CRLB threshold (m)",
                     "For 'area within threshold': position error (1σ, m) that counts as good.",
        metadata=_in(hard=(0.01, 1e5, "m")))


class Track(Part):
    """The Track tab's own settings (app/tabs/track/track.py): a straight track over the custom stations,
    at the target depth z, with the target's moments and the sensor above."""

    track_x0 = param.Number(-250.0, softbounds=(-1000.0, 1000.0),
                            label="Track start x (m)", doc="x of the track's start, m.",
        metadata=_in(hard=(-5000.0, 5000.0, "m")))
    track_y0 = param.Number(-120.0, softbounds=(-1000.0, 1000.0),
                            label="Track start y (m)", doc="y of the track's start, m.",
        metadata=_in(hard=(-5000.0, 5000.0, "m")))
    track_heading = param.Number(25.0, softbounds=(-180.0, 180.0), label="Track heading (°)",
                                 doc="Course of the straight track, degrees from +x towards +y.",
        metadata=_in(hard=(-180.0, 180.0, "°")))
    track_speed = param.Number(2.0, softbounds=(0.1, 20.0),
                               label="Track speed (m/s)", doc="Target speed along the track, m/s.",
        metadata=_in(hard=(0.1, 50.0, "m/s")))
    track_duration = param.Number(250.0, softbounds=(10.0, 600.0),
                                  label="Track duration (s)",
                                  doc="Length of the track in time, s (one measurement every T).",
        metadata=_in(hard=(2.0, 600.0, "s")))
    track_axes = param.Selector(objects=[3, 2], default=3, label="Sensor axes",
                                doc="3: every station measures Ex, Ey, Ez; 2: horizontal Ex, Ey only.")
    track_sigma_a = param.Number(0.1, softbounds=(0.0, 1.0),
                                 label="Acceleration noise σa (m/s²)",
                                 doc="DWNA process noise per horizontal axis, m/s² (seed 001: 0.1).",
        metadata=_in(fmt="0.[000]", hard=(0.0, 10.0, "m/s²")))
    track_alpha = param.Number(0.001, softbounds=(0.0, 0.1),
                               label="Moment random walk α (moment²/step)",
                               doc="Variance of the moments' random walk per step: (A·m)² for the "
                                   "electric dipole (seed 001: 0.001), (A·m²)² for a magnetic one.",
        metadata=_in(fmt="0.[0000]", hard=(0.0, 100.0, "moment²/step")))
    track_filter = param.Selector(objects=["bank", "ekf", "puekf"], default="bank", label="Tracker",
                                  doc="bank: seed 001's 12 filters, no prior, ML selection; ekf / "
                                      "puekf: one filter from a prior about the truth.")
    track_runs = param.Integer(5, softbounds=(1, 20), label="Monte-Carlo runs",
                               doc="Noise realisations shown and averaged in the TRMSE, 1 to 20.",
        metadata=_in(hard=(1, 20, "runs")))


class Calibration(Part):
    """The Calibration tab's own problem (seed 004, app/tabs/calibration/calibration.py); its headings text is
    parsed, and refused, by that tab."""

    own_presets = True

    cal_source = param.Selector(
        objects=["Designed manoeuvre", "Seed 004 simulation", "Seed 004 Table 1", "Uploaded CSV"],
        default="Seed 004 simulation", label="Calibration data",
        doc="Designed or simulated manoeuvres use seed 004's simulated ship (K, Bp) as the truth.")
    cal_convention = param.Selector(
        objects=list(core.calibration.CONVENTIONS), default="seed004", label="Attitude convention",
        doc="How heading, roll and pitch make A (core.calibration.CONVENTIONS); seed004 is its eq. (2).")
    cal_headings = param.String("0, 90, 180, 270", label="Headings (°)",
                                doc="Designed manoeuvre: headings sailed in turn, degrees from north.",
        metadata=_in(sources=("Designed manoeuvre",)))
    cal_roll_deg = param.Number(10.0, softbounds=(0.0, 45.0), label="Roll amplitude (°)",
                                doc="Designed manoeuvre: roll = amplitude · cos(2πn/N), degrees.",
        metadata=_in(sources=("Designed manoeuvre",), hard=(0.0, 45.0, "°")))
    cal_pitch_deg = param.Number(5.0, softbounds=(0.0, 30.0), label="Pitch amplitude (°)",
                                 doc="Designed manoeuvre: pitch = amplitude · sin(2πn/N), degrees.",
        metadata=_in(sources=("Designed manoeuvre",), hard=(0.0, 30.0, "°")))
    cal_n_attitudes = param.Integer(12, softbounds=(1, 120), label="Attitudes N",
                                    doc="Number of attitudes of a designed or simulated manoeuvre.",
        metadata=_in(sources=("Designed manoeuvre", "Seed 004 simulation"), hard=(1, 120, "attitudes")))
    cal_noise_nt = param.Number(100.0, softbounds=(0.1, 5000.0), label="Reading error bound ± (nT)",
                                doc="Uniform reading errors within ± this, nT; the filter and the CRLB "
                                    "use σ = bound/√3.",
        metadata=_in(hard=(0.1, 5000.0, "nT")))
    cal_angle_noise_deg = param.Number(0.05, softbounds=(0.0, 2.0), label="Angle error bound ± (°)",
                                       doc="Uniform errors of each recorded angle within ± this, degrees.",
        metadata=_in(hard=(0.0, 2.0, "°")))
    cal_be_n = param.Number(34000.0, softbounds=(-1e5, 1e5), label="Be north (nT)",
                            doc="Geomagnetic field, north component, nT.",
        metadata=_in(vector="Be", hard=(-1e5, 1e5, "nT")))
    cal_be_e = param.Number(2000.0, softbounds=(-1e5, 1e5), label="Be east (nT)",
                            doc="Geomagnetic field, east component, nT.",
        metadata=_in(vector="Be", hard=(-1e5, 1e5, "nT")))
    cal_be_d = param.Number(35000.0, softbounds=(-1e5, 1e5), label="Be down (nT)",
                            doc="Geomagnetic field, down component, nT.",
        metadata=_in(vector="Be", hard=(-1e5, 1e5, "nT")))
    cal_iterations = param.Integer(600, softbounds=(1, 5000), label="Kalman iterations",
                                   doc="Filter steps; the readings are reused cyclically (seed 004).",
        metadata=_in(hard=(1, 5000, "iterations")))
    cal_p0_bp_nt = param.Number(3000.0, softbounds=(0.01, 1e6), label="Prior σ of Bp in P(0) (nT)",
                                doc="Square root of P(0)'s Bp entry, nT (K entries: 1). Small values "
                                    "slow the filter down.",
        metadata=_in(hard=(0.01, 1e6, "nT")))
    cal_seed = param.Integer(4, softbounds=(0, 1_000_000), label="Random seed",
                             doc="Seed of the simulated attitudes and errors.",
        metadata=_in(sources=("Designed manoeuvre", "Seed 004 simulation"), hard=(0, 1_000_000, "")))


class Shape(Part):
    """The Shape tab's own problem (seed 003, app/tabs/shape/shape.py): a target (a grid of 0.1 m dipole
    cells) passed by a gradiometer on a straight track along +x; the defaults are seed 003's
    Fig. 4."""

    own_presets = True

    shape_type = param.Selector(objects=["cylinder", "disc"], default="cylinder", label="Target type",
                                doc="Seed 003: a cylinder has H > R (read as a line), a disc H ≤ R "
                                    "(read as a plane). Switching sets typical sizes if H, R disagree.",
        metadata=_in(group="Target"))
    shape_height = _num(3.0, (0.1, 6.0), "Height H (m)", "Target height H along its axis, m.",
        metadata=_in(group="Target", hard=(0.1, 20.0, "m")))
    shape_radius = _num(0.5, (0.05, 3.0), "Radius R (m)", "Target radius R, m.",
        metadata=_in(group="Target", hard=(0.05, 10.0, "m")))
    shape_inner_height = _num(0.0, (0.0, 6.0), "Cavity height H_in (m, 0: solid)",
                              "Hollow target: height of the coaxial cavity, m (0 with R_in = 0: solid).",
        metadata=_in(group="Target", hard=(0.0, 20.0, "m")))
    shape_inner_radius = _num(0.0, (0.0, 3.0), "Cavity radius R_in (m, 0: solid)",
                              "Hollow target: radius of the coaxial cavity, m (< R).",
        metadata=_in(group="Target", hard=(0.0, 10.0, "m")))
    shape_roll = _num(30.0, (-180, 180), "Roll θ (°)", "Attitude: roll about x, degrees (R = Rz·Ry·Rx).",
        metadata=_in(group="Target", hard=(-180.0, 180.0, "°")))
    shape_pitch = _num(45.0, (-180, 180), "Pitch β (°)", "Attitude: pitch about y, degrees.",
        metadata=_in(group="Target", hard=(-180.0, 180.0, "°")))
    shape_yaw = _num(60.0, (-180, 180), "Yaw φ (°)", "Attitude: yaw about z, degrees.",
        metadata=_in(group="Target", hard=(-180.0, 180.0, "°")))
    shape_mx = _num(-3.0, (-10, 10), "Cell moment mx (A·m²)", "Moment of each 0.1 m cell, x (A·m²).",
        metadata=_in(group="Target", hard=(-1000.0, 1000.0, "A·m² per cell")))
    shape_my = _num(1.0, (-10, 10), "Cell moment my (A·m²)", "Moment of each 0.1 m cell, y (A·m²).",
        metadata=_in(group="Target", hard=(-1000.0, 1000.0, "A·m² per cell")))
    shape_mz = _num(5.0, (-10, 10), "Cell moment mz (A·m²)", "Moment of each 0.1 m cell, z (A·m²).",
        metadata=_in(group="Target", hard=(-1000.0, 1000.0, "A·m² per cell")))
    shape_offset = _num(5.0, (-30, 30), "Track lateral offset y (m)",
                        "y of the straight track along x (the target's centre is the origin), m.",
        metadata=_in(group="Pass and noise", hard=(-100.0, 100.0, "m")))
    shape_above = _num(5.0, (-30, 30), "Track height above the target (m)",
                       "Height of the track above the target's centre, m (z = −height: z is down).",
        metadata=_in(group="Pass and noise", hard=(-100.0, 100.0, "m")))
    shape_noise = param.Number(0.01, softbounds=(1e-3, 1.0), label="Noise σ (nT/m)",
                               doc="Gaussian noise of each tensor component, nT/m (seed 003: 0.01).",
        metadata=_in(fmt="0.[00000]", group="Pass and noise", hard=(1e-5, 10.0, "nT/m")))
    shape_outliers = param.String("", label="Outliers at platform x (m)",
                                  doc="Comma-separated x positions (m) of the samples that get an "
                                      "outlier on all five components (Fig. 5: −20, −10, 0); empty: none.",
        metadata=_in(group="Pass and noise"))
    shape_outlier_size = _num(500.0, (0, 2000), "Outlier size (σ)",
                              "Added to each hit component, in units of the noise σ (Fig. 5: 500).",
        metadata=_in(group="Pass and noise", hard=(0.0, 1e5, "σ")))
    shape_window = param.Selector(objects=["seed 003 window (lag 5)", "one sample"],
                                  default="seed 003 window (lag 5)", label="Filter update",
                                  doc="Seed 003's window of three lagged readings (eq. 15, the paper's "
                                      "method; every sample counts three times, so the filters' σ is "
                                      "optimistic). One sample: the honest update, shown for "
                                      "comparison (it misreads the axis in about half of the passes).",
        metadata=_in(group="Filters"))
    shape_runs = param.Integer(1, softbounds=(1, 20), label="Monte-Carlo passes",
                               doc="Noise realisations: errors and shape are their medians, 1 to 20.",
        metadata=_in(group="Filters", hard=(1, 20, "passes")))
    shape_seed = param.Integer(0, softbounds=(0, 100), label="Random seed", doc="Seed of the noise.",
        metadata=_in(group="Filters", hard=(0, 1_000_000, "")))


#: The parts of a scenario: attribute -> class. Their parameter names are unique across them.
PARTS = {"target": Target, "stations": Stations, "medium": Medium, "sensor": Sensor,
         "region": Region, "maps": Maps, "design": Design, "survey": Survey, "track": Track,
         "calibration": Calibration, "shape": Shape}
#: Each parameter's part: name -> attribute of :data:`PARTS`.
PART_OF = {n: attr for attr, cls in PARTS.items() for n in cls.names()}
assert len(PART_OF) == sum(len(cls.names()) for cls in PARTS.values()), "parameter names must be unique"
for _cls in PARTS.values():  # each part's limits, as its inputs declare them
    _cls.accepted = limits(_cls)
#: Every part's hard limits: name -> (lowest, highest, unit).
ACCEPTED = {n: lim for cls in PARTS.values() for n, lim in cls.accepted.items()}
#: Inputs that are depths below the sea surface (m; never negative), as declared: in a layered
#: sea they lie in the water column [0, D].
DEPTHS = tuple(n for n, a in PART_OF.items() if declared(PARTS[a].param[n]).get("depth"))


def parameter(name):
    """The class-level param.Parameter of input ``name`` (its label, default, type)."""
    return PARTS[PART_OF[name]].param[name]


def sidebar():
    """The sidebar as the inputs declare it: ((card title, [input names in their places],
    collapsed), …) in :data:`CARDS`' order."""
    placed = {}
    for name in PART_OF:
        card = declared(parameter(name)).get("card")
        if card is not None:
            placed.setdefault(card[0], []).append((card[1], name))
    unknown = set(placed) - set(CARDS)
    if unknown:
        raise KeyError(f"inputs declared on cards that do not exist: {sorted(unknown)}")
    return tuple((title, [n for _, n in sorted(placed.get(title, []))], collapsed)
                 for title, collapsed in CARDS.items())


def shown(name, where):
    """Whether input ``name`` applies where ``where`` (:class:`Where`) says: one of its declared
    ``kinds`` is measured there, and its declared rule holds (an input with neither always
    applies)."""
    d = declared(parameter(name))
    if "kinds" in d and not where.kinds & set(d["kinds"]):
        return False
    rule = d.get("shown")
    return True if rule is None else bool(rule(where))


def inputs(*parts, but=()):
    """The inputs of the parts named ``parts`` (keys of :data:`PARTS`), in their order, but those
    named in ``but``: what a computation reads, the key of its results (:class:`app.state.snapshot.Snapshot`)."""
    unknown = set(but) - {n for a in parts for n in PARTS[a].names()}
    if unknown:
        raise KeyError(f"not inputs of {parts}: {sorted(unknown)}")
    return tuple(n for a in parts for n in PARTS[a].names() if n not in but)


def defaults(parts=None):
    """Every input's default: name -> value (of the parts named ``parts``; default all)."""
    return {n: PARTS[a].param[n].default for a in (parts or PARTS) for n in PARTS[a].names()}
