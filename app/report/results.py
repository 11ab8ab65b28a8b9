"""A study's results: every tab's computation for one scenario, by the page's own code, and the
numbers a planner quotes (spec §12).

:func:`compute` runs what each tab runs (app.compute, app.design_compute, app.track,
app.calibration, app.shape: the same functions, through the same cache keys) and
:func:`summary` reads the numbers out of them as plain JSON. Per CRLB map: the share of the
region with a position error ≤ T (the design's threshold, stated), the median and the 90th
percentile over the observable points, the share of points that are unobservable, the rank
verdict. The best spacing; the track's TRMSE against its PCRLB and the NEES flag; the
calibration's coefficients with their CRLB; the shape's sizing verdict. And every warning the
page shows for it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

import core
from ..kit.cache import SHARED
from ..state.scenario import Scenario
from ..tabs.calibration import calibration
from ..tabs.design import compute as design_compute
from ..tabs.maps.compute import READS as MAP_READS
from ..tabs.maps.compute import Snapshot
from ..tabs.maps.compute import compute as compute_maps
from ..tabs.shape import shape
from ..tabs.track import track

#: The tabs a study covers, in the page's order.
TABS = ("Maps", "Layout design", "Track", "Calibration", "Shape")
#: The Maps tab's measure whose values the summary quotes.
CRLB = "CRLB position error (m)"


@dataclass
class Computed:
    """Every tab's results for one scenario (the objects the page draws)."""

    values: dict
    maps: object  # app.compute.Panels: the maps as shown
    crlb: object  # app.compute.Panels of the CRLB position error (the same when it is shown)
    design: object  # app.kit.views.Design: the custom layout's CRLB map
    spacing: object  # app.design_compute.Spacing
    track: object  # app.track's dict, or an exception's text
    calibration: dict  # app.calibration.compute's dict
    shape: object  # app.shape's dict, or an exception's text
    failed: dict = field(default_factory=dict)  # tab -> why it could not be computed


def scenario_of(values):
    """A Scenario holding ``values`` (every input, already accepted together)."""
    s = Scenario()
    s.update({k: v for k, v in values.items() if s.value(k) != v}, as_given=True)
    if s.message.endswith("Kept the last good value."):
        raise ValueError(s.message)
    return s


def _tab(failed, name, fn):
    try:
        return fn()
    except ValueError as exc:  # the tab says it and keeps no numbers (as the page does)
        failed[name] = str(exc)
        return None


def compute(values, log=None):
    """Every tab's results for the scenario ``values`` (name -> value, every input) and the
    uploaded calibration ``log`` (bytes or None)."""
    s = scenario_of(values)
    # the page's cache (app.cache.SHARED) and keys: a report of the page's scenario reuses its maps
    maps = SHARED.get(Snapshot.of(s, MAP_READS), compute_maps)
    crlb = maps
    if maps.measure != "crlb_position":
        crlb = SHARED.get(Snapshot.of_values(s, {"measure": CRLB}, MAP_READS), compute_maps)
    failed = {}
    design = _tab(failed, "Layout design", lambda: SHARED.get(
        Snapshot.of(s, design_compute.ERROR_MAP_READS), design_compute.design))
    spacing = _tab(failed, "Layout design", lambda: SHARED.get(
        Snapshot.of(s, design_compute.SPACING_READS), design_compute.best_spacing))
    tracked = _tab(failed, "Track", lambda: track.compute(s))
    cal = calibration.compute(s.values(["calibration"]), log)
    if cal.get("error"):
        failed["Calibration"] = cal["error"]
    shaped = _tab(failed, "Shape", lambda: shape.compute(shape.key_of(s)))
    return Computed(values=s.values(), maps=maps, crlb=crlb, design=design, spacing=spacing,
                    track=tracked, calibration=cal, shape=shaped, failed=failed)


# -- the numbers
def _number(x):
    x = float(x)
    return x if math.isfinite(x) else None


def map_summary(value, observable, threshold):
    """The numbers of one CRLB position-error map (m): over every point of the region, the share
    with an error ≤ ``threshold`` (unobservable points count as over it), the share
    unobservable; over the observable points, the median and the 90th percentile."""
    value, observable = np.asarray(value, float), np.asarray(observable, bool)
    seen = observable & np.isfinite(value)
    within = seen & (value <= threshold)
    errors = value[seen]
    unobservable = float(1.0 - observable.mean())
    return dict(
        threshold_m=float(threshold), points=int(value.size),
        share_within_threshold=float(within.mean()), share_unobservable=unobservable,
        median_m=_number(np.median(errors)) if errors.size else None,
        p90_m=_number(np.percentile(errors, 90)) if errors.size else None,
        rank_verdict=("observable (full rank) at every point" if unobservable == 0 else
                      "unobservable (rank-deficient) everywhere" if unobservable == 1 else
                      f"unobservable (rank-deficient) at {100 * unobservable:.1f} % of the points"),
    )


def _maps_summary(c, T):
    p = c.crlb
    out = {}
    for which, (title, res) in enumerate(zip(p.titles[:2], (p.a, p.b))):
        out["AB"[which]] = dict(title=title, caption=p.captions[which], kind=p.kinds[which],
                                **map_summary(res.value, res.observable, T))
    return out


def _design_summary(c, T):
    if c.design is None:
        return None
    e = c.design.errors.position
    return dict(stations=np.asarray(c.design.stations).tolist(),
                **map_summary(e, np.isfinite(e), T))


def _spacing_summary(c):
    if c.spacing is None:
        return None
    r = c.spacing.result
    return dict(best_d_m=float(r.d), criterion=c.spacing.label,
                value=_number(r.value) if hasattr(r, "value") else None)


def _track_summary(c):
    if c.track is None:
        return None
    s = c.track["res"].summary
    flag = track.nees_check(s["nees"], s["runs"], states=int(s.get("nees_dof", 7))) if s.get(
        "nees") is not None else ""
    return dict(filter=s["filter"], runs=int(s["runs"]), trmse_final_m=_number(s["trmse_final_m"]),
                pcrlb_final_m=_number(s["pcrlb_final_m"]),
                nees=None if s.get("nees") is None else _number(s["nees"]),
                nees_consistent=flag == "", nees_flag=flag.replace("**", ""),
                linearisation_breaks_share=float(np.mean(c.track["breaks"])))


def _calibration_summary(c):
    res = c.calibration
    if res.get("error"):
        return dict(error=res["error"])
    kal = None if res["kalman"] is None else res["kalman"].coefficients[-1]
    lsq = None if res["lsq"] is None else np.r_[res["lsq"].K.ravel(), res["lsq"].Bp]
    rows = []
    for j, (name, unit) in enumerate(zip(core.COEFFICIENTS, core.calibration.COEFFICIENT_UNITS)):
        rows.append(dict(coefficient=name, unit="1" if unit == "1" else "nT",
                         observable=bool(res["obs"].observable[j]),
                         kalman=None if kal is None else _number(kal[j]),
                         least_squares=None if lsq is None else _number(lsq[j]),
                         crlb=_number(res["crlb"][j])))
    return dict(source=c.values["cal_source"], coefficients=rows, note=res.get("note", ""))


def _shape_summary(c):
    if c.shape is None:
        return None
    b = c.shape["bound"]
    return dict(sizable=bool(b.sizable), best_main_scale_sigma_m=_number(b.best_main_scale_m),
                target_main_scale_m=float(c.shape["case"].target.main_scale),
                closest_approach_m=float(c.shape["cpa"]),
                verdict=("this pass can size the target" if b.sizable
                         else "this pass cannot size the target"))


def warnings(c):
    """Every warning and veil the page shows for the scenario (plain text)."""
    said = [c.maps.note, c.maps.far_note]
    if c.crlb is not c.maps:
        said += [c.crlb.note, c.crlb.far_note]
    said += [f"{tab}: {why}" for tab, why in c.failed.items()]
    if c.track is not None:
        said.append(_track_summary(c)["nees_flag"])
        said.append(c.track.get("tracker_note", ""))
    said.append(c.calibration.get("note", ""))
    return [w for w in dict.fromkeys(said) if w]


def summary(c):
    """The study's numbers (JSON-ready) from :func:`compute`'s results."""
    T = float(c.values["threshold"])
    return dict(
        threshold_m=T,
        maps=_maps_summary(c, T),
        layout_design=_design_summary(c, T),
        best_spacing=_spacing_summary(c),
        track=_track_summary(c),
        calibration=_calibration_summary(c),
        shape=_shape_summary(c),
        warnings=warnings(c),
    )
