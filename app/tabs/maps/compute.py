"""From a Scenario to the numbers on screen: two maps (A, B), their difference, and notes.

Pure functions of a :class:`Snapshot` (the scenario's values, frozen and hashable), the key of
the process's one cache of results (:mod:`app.kit.cache`), so that three views of one scenario, and
every session showing it, compute it once.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

import core

from app.kit import timings
from app.kit.cache import KERNEL_LOCK
from app.kit.runaway import RUNAWAY_LIMIT, runaway
from app.state.scenario import (
    COMPARISONS,
    DIFFERENCES,
    PAPER_MAPS,
    SENSORS,
    ScenarioValues,
    preset_of,
)
from app.state.sensors import KINDS as SENSOR_PARTS
from app.state.snapshot import SCENE, Snapshot

#: The inputs the comparison maps read (:func:`compute`): the scene (a target in a sea, seen by
#: sensors on the paper's stations, over a region) and the Maps tab's own settings; not the
#: custom stations of the Layout design and Track tabs. The key of the maps' results: a change of
#: any other input leaves them as they are (tests/test_tab_keys.py checks this against what
#: :func:`compute` reads).
READS = SCENE
#: Every input the maps read, as a set.
MAP_INPUTS = frozenset(READS)


@dataclass(frozen=True)
class Panels:
    """Everything the three maps need."""

    plane: core.Plane
    a: core.MapResult
    b: core.MapResult
    diff: np.ndarray
    titles: tuple  # (A, B, difference)
    stations: tuple  # ((S_a, 3), (S_b, 3)) arrays, m
    measure: str  # core measure key
    value_label: str
    value_unit: str
    diff_label: str
    clim: tuple  # shared colour range of A and B (of log10 metres for the CRLB)
    note: str  # plain text; empty if every point is observable
    log_scale: bool = False  # A and B are drawn as log10 of their values (the CRLB, metres)
    unobservable: tuple = ("unobservable", "unobservable")  # hover text of a veiled point of A, B
    paper: tuple = ((), "")  # (which maps are a paper figure: 0 A, 1 B, 2 difference; caption)
    preset: str = ""  # the paper figure whose parameters these are, or ""
    blank: str = ""  # hover text of a difference-map point with no value that is not veiled
    captions: tuple = ("", "", "")  # each map's parameters, one line (under it, and in its PNG)
    filename: str = "observability_map"  # of a saved PNG, after the scenario
    runaway: tuple = ()  # CRLB maps: bool (n, n) of A, B, difference where the bound runs away
    far_note: str = ""  # plain text on the runaway points; empty if none
    kinds: tuple = ("E", "E")  # sensor kind of A and B (core.Sensor kinds: E, B, G, BG)
    value_labels: tuple = ()  # colour-bar label of A and B (naming a magnetic kind and its unit)

    def shown(self, which):
        """The values map ``which`` (0 A, 1 B, 2 difference) is coloured by; NaN where none."""
        if which == 2:
            return self.diff
        values = (self.a, self.b)[which].value
        if not self.log_scale:
            return values
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.log10(values)
        return np.where(np.isfinite(out), out, np.nan)


#: A sensor kind in titles and captions (core kind -> words, and the unit of its readings), as its
#: sensor part says (app.state.sensors).
KIND_NAMES = {part.kind: (part.words, part.unit) for part in SENSOR_PARTS}


def moment_text(moments, kind):
    """A map's moments in words: P = (P_h, P_v) A·m, or m = (m_x, m_y, m_z) A·m²."""
    if kind == "E":
        return "P = (" + ", ".join(f"{v:g}" for v in moments) + ") A·m"
    return "m = (" + ", ".join(f"{v:g}" for v in moments) + ") A·m²"


def scenarios_ab(s: ScenarioValues):
    """(stations, moments, title, sensor kind) for A and B under the chosen comparison; moments
    are (P_h, P_v) A·m for the electric kind, (m_x, m_y, m_z) A·m² for a magnetic one."""
    single, dual = core.single_station(s.h), core.dual_station(s.h, s.d)
    layout = single if s.layout == "single" else dual
    lname = "single" if s.layout == "single" else f"dual d = {s.d:g} m"
    kind_a = SENSORS[s.sensor]
    mom = s.moments(kind_a)
    # electric titles are the paper's (unchanged); a magnetic kind is named in each title
    tag = "" if kind_a == "E" else f" {KIND_NAMES[kind_a][0]}"
    kind = COMPARISONS[s.comparison]
    if kind == "dual_vs_single":
        return ((single, mom, f"A: single{tag}" if tag else "A: single station", kind_a),
                (dual, mom, f"B: dual{tag}, d = {s.d:g} m", kind_a))
    if kind == "moments_scaled":
        return ((layout, mom, f"A: {lname}{tag}, {moment_text(mom, kind_a)}", kind_a),
                (layout, tuple(s.k * v for v in mom), f"B: {lname}{tag}, moments × {s.k:g}", kind_a))
    if kind == "moment_split":
        mom_b = (s.Ph_b, s.Pv_b) if kind_a == "E" else (s.mx_b, s.my_b, s.mz_b)
        return ((layout, mom, f"A: {lname}{tag}, {moment_text(mom, kind_a)}", kind_a),
                (layout, mom_b, f"B: {lname}{tag}, {moment_text(mom_b, kind_a)}", kind_a))
    if kind == "sensor_kinds":
        kind_b = SENSORS[s.sensor_b]
        return ((layout, mom, f"A: {lname}, {KIND_NAMES[kind_a][0]}", kind_a),
                (layout, s.moments(kind_b), f"B: {lname}, {KIND_NAMES[kind_b][0]}", kind_b))
    ref = core.dual_station(s.h, s.d_ref)
    return ((ref, mom, f"A: dual{tag}, d = {s.d_ref:g} m", kind_a), (dual, mom, f"B: dual{tag}, d = {s.d:g} m", kind_a))


def difference(a, b, measure, mode):
    """B compared with A: (values, label, short label for a title). Never subtracts determinants
    (spec §5). NaN where the comparison has no finite value (see :func:`blank_reason`)."""
    if measure == "crlb_position":
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.log10(b.value / a.value)
        return (np.where(np.isfinite(out), out, np.nan), "log10(σ_B / σ_A) (< 0: B locates better)",
                "log10(σB / σA)")
    if DIFFERENCES[mode] == "paper" and measure in ("log10_det", "d_optimal"):
        return (core.log10_positive_difference(b.value, a.value), "log10(|B| − |A|), blank where ≤ 0",
                "log10(|B| − |A|)")
    return core.log10_ratio(b.value, a.value), "log10(B / A) (> 0: B better)", "log10(B / A)"


def blank_reason(measure, mode):
    """Why a point of the difference map that is not veiled has no value (hover text)."""
    if measure != "crlb_position" and DIFFERENCES[mode] == "paper" and measure in ("log10_det",
                                                                                    "d_optimal"):
        return "blank: Δ ≤ 0 (B no more observable than A), or on a station"
    return "undefined: on a station"


def unobservable_text(s, stations, kind="E"):
    """Hover text of a veiled point: the rank where it is known (one station with the moments
    unknown: rank 6 of 7 electric, rank 7 of 8 for one magnetometer or one gradiometer at every
    point, spec §4 and §11), else only that Γ is rank-deficient."""
    options = s.core_options(kind)
    if kind == "E":
        if len(stations) == 1 and not options["known"] and options["sensor"].sea is None:
            return "unobservable (rank 6): colours are round-off"
        n = 7 - len(options["known"])
    else:
        if len(stations) == 1 and not options["known"] and kind in ("B", "G"):
            return (f"unobservable (rank 7 of 8): one {KIND_NAMES[kind][0]} cannot tell range "
                    "from moment strength")
        n = 8 - len(options["known"])
    return f"unobservable (rank < {n}: σ_min/σ_max ≤ {core.RANK_RTOL:g}): colours are round-off"


def colour_range(*arrays):
    """(low, high) covering 0.5–99.5 % of the finite values of all ``arrays``: a station's
    singular neighbourhood must not wash out the rest of a map. (0, 1) if none is finite."""
    vals = np.concatenate([a[np.isfinite(a)] for a in arrays])
    if vals.size == 0:
        return (0.0, 1.0)
    lo, hi = np.percentile(vals, [0.5, 99.5])
    return (float(lo), float(hi if hi > lo else lo + 1.0))


def _probe(s, st, moments):
    """A point of the map's own plane near station ``st`` (in x–z: at its fixed y)."""
    sx, sy, sz = st[0]
    on_xy = s.plane == "x–y"
    return np.array([sx + s.extent / 3, sy + s.extent / 3 if on_xy else s.y,
                     s.z if on_xy else 0.5 * (s.z_min + s.z_max), *s.velocity(), *moments])


def unobservable_note(s: ScenarioValues, results, stations, moments, kinds=("E", "E")):
    """Plain-text explanation where a map is mostly structurally unobservable, else ''.
    ``results``: ((title, core.MapResult), ...) of A and B; ``stations``, ``moments`` (A·m, or
    A·m² magnetic) and ``kinds`` (sensor kinds): each map's own (B's unobservable direction is
    B's, not A's)."""
    lines = []
    for (name, res), st, mom, kind in zip(results, stations, moments, kinds):
        frac = 1.0 - res.observable.mean()
        if frac < 0.5:
            continue
        options = s.core_options(kind)
        if kind == "E" and len(st) == 1 and not options["known"]:
            probe = _probe(s, st, mom)
            n = core.unobservable_direction(probe, st, T=s.T, sensor=options["sensor"])
            nice = ", ".join(f"{v:+.3f}" for v in n)
            lines.append(
                f"{name}: one station, source strength unknown: rank Γ = 6 < 7 at every point "
                f"({frac:.0%} of the map flagged). The field is homogeneous: moving the target λ "
                f"times farther (and faster) with moments × λ³ changes no measurement, so range and "
                f"source strength cannot be told apart. The colours there are float64 round-off "
                f"(|det Γ| ≈ 1e-20 × Π‖Γ_j‖), not observability. Unobservable direction at "
                f"({probe[0]:.0f}, {probe[1]:.0f}, {probe[2]:.0f}) m: n ∝ (x−sx, y−sy, z−sz, vx, vy, "
                f"3Ph, 3Pv) = ({nice}). Use 'moments known' or a second station."
            )
        elif kind != "E" and not any(mom):
            lines.append(f"{name}: the moment is m = (0, 0, 0) A·m²: the target has no magnetic "
                         "field, so nothing about it is observable. Set m_x, m_y or m_z.")
        elif kind in ("B", "G") and len(st) == 1 and not options["known"]:
            power, what = (3, "B(λr, λ³m) = B") if kind == "B" else (4, "G(λr, λ⁴m) = G")
            probe = _probe(s, st, mom)
            n = core.unobservable_direction(probe, st, T=s.T, steps=int(s.steps), sensor=options["sensor"])
            nice = ", ".join(f"{v:+.3f}" for v in n)
            lines.append(
                f"{name}: one {KIND_NAMES[kind][0]}, moment unknown: rank Γ = 7 < 8 at every point "
                f"({frac:.0%} of the map flagged; spec §11). {what}: moving the target λ times farther "
                f"(and faster) with its moment × λ^{power} changes no reading, for any number of "
                f"instants, so range and moment strength cannot be told apart. Unobservable direction at "
                f"({probe[0]:.0f}, {probe[1]:.0f}, {probe[2]:.0f}) m: n ∝ (x−sx, y−sy, z−sz, vx, vy, "
                f"{power}mx, {power}my, {power}mz) = ({nice}). Use both kinds (B + G), a second "
                "station or 'moments known'."
            )
        else:
            line = f"{name}: {frac:.0%} of the map is numerically singular (σ_min/σ_max ≤ {core.RANK_RTOL:g})."
            n_free = 7 - len(options["known"])
            if kind == "E" and core.MEASURES[options["measure"]][2] and 3 * len(st) >= n_free:
                line += (" The paper's square rule keeps only the first instant's rows here, and one "
                         "snapshot cannot see the speed: use the D-optimal or CRLB measure (all rows, "
                         "N instants).")
            lines.append(line)
    return "\n".join(lines)


def runaway_note(results, masks):
    """Plain text on the points of the CRLB maps A and B that :func:`runaway` flags, else ''."""
    lines = []
    for (name, res), mask in zip(results, masks):
        if mask.any():
            lines.append(f"{name}: at {mask.sum() / max(res.observable.sum(), 1):.0%} of the observable "
                         f"points the CRLB exceeds {RUNAWAY_LIMIT:.0%} of the range to the nearest "
                         "station (dotted white).")
    if lines:
        lines.append("There the linearised bound no longer predicts a tracker's error: the field "
                     "changes by ~2× across such an error, and an estimator runs away along the "
                     "range–strength direction or locks onto another solution (see the Track tab). "
                     "Read those metres as 'not trackable from these stations', not as an error to quote.")
    return "\n".join(lines)


def sea_text(s):
    """The medium, for captions: the whole space, or the layered sea's depth and seabed."""
    if s.sea_model != "layered":
        return "whole space, "
    return f"sea depth D = {s.sea_depth:g} m over a {s.seabed_sigma:g} S/m seabed, "


def layout_text(stations):
    """The stations of a map, for its caption: one station, or how many and their spacing (m)."""
    st = np.asarray(stations, dtype=float).reshape(-1, 3)
    if len(st) == 1:
        return "1 station"
    if len(st) == 2:
        return f"2 stations d = {float(np.linalg.norm(st[1] - st[0])):g} m apart"
    return f"{len(st)} stations"


def _kind_pair(kinds):
    return (kinds, kinds) if isinstance(kinds, str) else tuple(kinds)


def caption(s, moments=None, stations=None, kinds="E"):
    """The parameters of a scenario's map as one line of plain text. ``moments``: the map's
    ((P_h, P_v) A·m or (m_x, m_y, m_z) A·m²; default the scenario's), or (A's, B's) for the
    difference map; ``stations``: the map's (S, 3) stations (m), or a text naming A's and B's;
    ``kinds``: the map's sensor kind, or (A's, B's). Electric maps name no kind (the paper's)."""
    ka, kb = _kind_pair(kinds)
    pair = not isinstance(kinds, str)
    moments = s.moments(ka) if moments is None else moments
    if pair or (len(moments) == 2 and np.ndim(moments[0]) == 1):
        mom_a, mom_b = moments
    else:
        mom_a = mom_b = moments
    if tuple(mom_a) != tuple(mom_b) or (ka == "E") != (kb == "E"):
        sym = {"E": "P", "B": "m", "G": "m", "BG": "m"}
        power = (f"{sym[ka]}_A {moment_text(mom_a, ka)[2:]}, {sym[kb]}_B {moment_text(mom_b, kb)[2:]}")
    else:
        power = moment_text(mom_a, ka)
    used = [ka] if ka == kb else [ka, kb]
    sensor = "" if used == ["E"] else (
        f"sensor {KIND_NAMES[ka][0]}, " if len(used) == 1 else
        f"sensors A {KIND_NAMES[ka][0]}, B {KIND_NAMES[kb][0]}, ")
    vx, vy = (0.0 if abs(c) < 1e-9 * s.speed else c for c in s.velocity())  # cos 90° is 6e-17
    where = (f"target depth z = {s.z:g} m" if s.plane == "x–y"
             else f"x–z plane at y = {s.y:g} m, z {s.z_min:g}–{s.z_max:g} m")
    layout = f"{stations}, " if isinstance(stations, str) else (
        "" if stations is None else f"{layout_text(stations)}, ")
    n = int(s.resolution)
    electric = "E" in used
    medium = (f"σ = {s.sigma:g} S/m, {sea_text(s)}" if electric else
              "static field (the sea does not change it), ")
    noises = []
    if electric:
        noises.append(f"{s.noise:.3g} V/m")
    if any(k in ("B", "BG") for k in used):
        noises.append(f"{s.noise_b:.3g} nT")
    if any(k in ("G", "BG") for k in used):
        noises.append(f"{s.noise_g:.3g} nT/m" + (f", baseline {s.baseline:g} m" if s.baseline > 0 else ""))
    states = s.state_set if electric else (
        "all 8 unknown" if s.state_set == "all 7 unknown" else "moments known (5 states)")
    model = f"{s.model}, " if electric else ""
    return (f"{sensor}{power}, v = ({vx:.3g}, {vy:.3g}) m/s, {where}, {layout}"
            f"stations at depth h = {s.h:g} m, grid {n} × {n} over x ±{s.extent:g} m, T = {s.T:g} s, {medium}"
            f"noise {' and '.join(noises)}, N = {s.steps}, {model}{states}")


#: A measure's name on a magnetic map's colour bar: short, as the bar's title must fit its height
#: with the kind after it.
SHORT_MEASURES = {"crlb_position": "CRLB 1σ (m)", "d_optimal": "½·log10 det F"}
#: A magnetic kind on a colour bar.
SHORT_KINDS = {"B": "magnetometer", "G": "gradiometer", "BG": "B + G"}


def value_label(measure, kind):
    """A colour bar's label: the measure's (core.MEASURES), and for a magnetic kind a short name
    of the measure, the kind and the unit of its readings ("CRLB 1σ (m), gradiometer (nT/m)")."""
    if kind == "E":
        return core.MEASURES[measure][0]
    return f"{SHORT_MEASURES[measure]}, {SHORT_KINDS[kind]} ({KIND_NAMES[kind][1]})"


def filename(s, preset=""):
    """A saved map's file name (no extension): the paper figure, or the comparison, and the plane."""
    stem = preset or COMPARISONS[s.comparison]
    kind = SENSORS[s.sensor]  # a magnetic kind is named (the electric names are unchanged)
    stem += "" if kind == "E" or preset else f"_{KIND_NAMES[kind][0]}"
    slug = "".join(c if c.isalnum() else "_" for c in f"{stem}_{s.plane}_{s.measure.split(' ')[0]}")
    return "_".join(part for part in slug.lower().split("_") if part)


def compute(snapshot: Snapshot) -> Panels:
    """The maps for one scenario. Pure: same snapshot, same numbers."""
    s = snapshot.scenario()
    measure = s.measure_key()
    plane = s.core_plane()
    (st_a, mom_a, title_a, kind_a), (st_b, mom_b, title_b, kind_b) = scenarios_ab(s)
    vel = s.velocity()
    with KERNEL_LOCK:
        timings.stamp_current("locked")  # app/kit/timings.py, when APP_TIMINGS asks
        a = core.evaluate_map(plane, st_a, velocity=vel, moments=mom_a, measure=measure,
                              **s.core_options(kind_a, measure=False))
        b = core.evaluate_map(plane, st_b, velocity=vel, moments=mom_b, measure=measure,
                              **s.core_options(kind_b, measure=False))
    timings.stamp_current("unlocked")
    diff, diff_label, diff_short = difference(a, b, measure, s.difference)
    label, unit, _ = core.MEASURES[measure]
    note = unobservable_note(s, ((title_a, a), (title_b, b)), (st_a, st_b), (mom_a, mom_b),
                             (kind_a, kind_b))
    log_scale = measure == "crlb_position"  # metres over decades: coloured by log10 (as the design tab)
    preset = preset_of(s, MAP_INPUTS) or ""
    p = Panels(
        plane=plane, a=a, b=b, diff=diff, titles=(title_a, title_b, "B vs A: " + diff_short),
        stations=(st_a, st_b), measure=measure, value_label=label, value_unit=unit,
        diff_label=diff_label, clim=(0.0, 1.0), note=note, log_scale=log_scale,
        unobservable=(unobservable_text(s, st_a, kind_a), unobservable_text(s, st_b, kind_b)),
        paper=PAPER_MAPS.get(preset, ((), "")), preset=preset,
        blank=blank_reason(measure, s.difference),
        captions=(caption(s, mom_a, st_a, kind_a), caption(s, mom_b, st_b, kind_b),
                  caption(s, (mom_a, mom_b), f"A: {layout_text(st_a)}, B: {layout_text(st_b)}",
                          (kind_a, kind_b))),
        filename=filename(s, preset), kinds=(kind_a, kind_b),
        value_labels=(value_label(measure, kind_a), value_label(measure, kind_b)),
    )
    p = dataclasses.replace(p, clim=colour_range(p.shown(0), p.shown(1)))
    if not log_scale:
        return p
    ra, rb = (runaway(plane, st, res.value, res.observable) for st, res in ((st_a, a), (st_b, b)))
    both = (ra | rb) & a.observable & b.observable & np.isfinite(diff)
    return dataclasses.replace(p, runaway=(ra, rb, both),
                               far_note=runaway_note(((title_a, a), (title_b, b)), (ra, rb)))


__all__ = ["MAP_INPUTS", "READS", "Panels", "Snapshot", "compute", "difference"]
