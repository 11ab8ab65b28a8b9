"""A script that reproduces a study's numbers through the public ``core`` API alone (spec §12).

:func:`text` writes a readable ``.py``: the scenario's core inputs as literals (the planes,
stations, moments, the one ``core.Sensor``, the track's case, as the page builds them from its
inputs), the core calls the page makes, and the summary of :mod:`app.report.results` computed from
their results with numpy. Run as it is, it prints the numbers as JSON: the maps' (A and B, CRLB
position error), the custom layout's, the best spacing and the track's, equal to the report's
(tests/test_study.py). No ``app``, no Panel: a reader can check and extend them.
"""

from __future__ import annotations

import json

from app.state.scenario import CRITERIA, ScenarioValues
from app.tabs.design.compute import REGION_RESOLUTION, SPACING_POINTS, SPACING_RANGE, xy_region
from app.tabs.maps.compute import scenarios_ab
from app.tabs.track import track

HEAD = '''"""Reproduces the numbers of the observability study "{title}" through the public core API.

Written by `python -m study` (project {project}). Run: python {name}
Prints the numbers as JSON: per CRLB position-error map the share of the region within the
threshold T, the median and 90th percentile over the observable points, the share unobservable;
the best dual-station spacing; the track's final TRMSE against its PCRLB and its mean NEES.
"""

import json

import numpy as np

import core
from core import Plane, Sea, Sensor
from core.tracking.montecarlo import TrackCase, monte_carlo, nees_band

nan, inf = float("nan"), float("inf")  # as written in the literals below
THRESHOLD = {threshold!r}  # m: the design's CRLB threshold


def map_summary(value, observable, threshold=THRESHOLD):
    """Share of the region with a CRLB position error <= threshold (unobservable points count
    as over it), median and 90th percentile over the observable points, share unobservable."""
    value, observable = np.asarray(value, float), np.asarray(observable, bool)
    seen = observable & np.isfinite(value)
    errors = value[seen]
    return dict(share_within_threshold=float((seen & (value <= threshold)).mean()),
                share_unobservable=float(1.0 - observable.mean()),
                median_m=float(np.median(errors)) if errors.size else None,
                p90_m=float(np.percentile(errors, 90)) if errors.size else None)


numbers = {{}}
'''

MAPS = '''
# -- the Maps tab's maps A and B, as CRLB position error (m)
plane = {plane!r}
velocity = {velocity!r}  # (vx, vy) m/s
for key, stations, moments, options in (
    ("A", {st_a!r}, {mom_a!r}, {opt_a}),
    ("B", {st_b!r}, {mom_b!r}, {opt_b}),
):
    res = core.evaluate_map(plane, stations, velocity=velocity, moments=moments,
                            measure="crlb_position", **options)
    numbers[key] = map_summary(res.value, res.observable)
'''

DESIGN = '''
# -- the Layout design tab: the custom stations' CRLB map, and the best dual spacing
stations = {stations!r}
errors = core.crlb_maps({plane!r}, stations, velocity=velocity, moments={moments!r}, **{options})
numbers["layout_design"] = map_summary(errors.position, np.isfinite(errors.position))
problem = core.LayoutProblem({region!r}, h={h!r}, criterion={criterion!r}, threshold=THRESHOLD,
                             velocity=velocity, moments={moments!r}, **{options})
spacing = core.best_spacing(problem, d_range={d_range!r}, n_curve={n_curve!r})
numbers["best_d_m"] = float(spacing.d)
'''

TRACK = '''
# -- the Track tab: a Monte-Carlo of the tracker against the posterior CRLB
case = {case!r}
res = monte_carlo(case, filter={filter!r}, runs={runs!r}, seed=0, workers=1, keep_tracks={runs!r})
s = res.summary
numbers["track"] = dict(trmse_final_m=s["trmse_final_m"], pcrlb_final_m=s["pcrlb_final_m"],
                        nees=s.get("nees"))
if s.get("nees") is not None:
    lo, hi = nees_band(int(s.get("nees_dof", 7)), s["runs"])
    numbers["track"]["nees_consistent"] = bool(lo <= s["nees"] <= hi)
'''

TAIL = '''
print(json.dumps(numbers, indent=1))
'''


def _options(o):
    """Keyword arguments as source (the Sensor by its repr, evaluable in the script)."""
    return "dict(" + ", ".join(f"{k}={v!r}" for k, v in o.items()) + ")"


def _floats(stations):
    return [[float(c) for c in st] for st in stations]


def text(values, log=None, *, title="study", name="study.py", project=""):
    """The script (text) of the study of ``values`` (every input). ``log``: the calibration
    log (not used by the numbers the script prints)."""
    s = ScenarioValues.of({**values, "measure": "CRLB position error (m)"})
    (st_a, mom_a, _, kind_a), (st_b, mom_b, _, kind_b) = scenarios_ab(s)
    parts = [HEAD.format(title=title, project=project, name=name, threshold=float(values["threshold"])),
             MAPS.format(plane=s.core_plane(), velocity=tuple(float(v) for v in s.velocity()),
                         st_a=_floats(st_a), mom_a=tuple(map(float, mom_a)),
                         opt_a=_options(s.core_options(kind_a, measure=False)),
                         st_b=_floats(st_b), mom_b=tuple(map(float, mom_b)),
                         opt_b=_options(s.core_options(kind_b, measure=False)))]
    options = _options(s.core_options(None, measure=False))
    parts.append(DESIGN.format(stations=_floats(s.stations), plane=xy_region(s, int(s.resolution)),
                               moments=tuple(map(float, s.moments())), options=options,
                               region=xy_region(s, REGION_RESOLUTION), d_range=SPACING_RANGE,
                               n_curve=SPACING_POINTS, h=float(s.h), criterion=CRITERIA[s.criterion]))
    try:
        case = track.case_of(s)
    except ValueError as exc:  # the tab refuses it too: the script says why
        parts.append(f"\n# the Track tab refuses this scenario: {exc}\n")
    else:
        parts.append(TRACK.format(case=case, filter=track.tracker_of(s)[0], runs=int(s.track_runs)))
    parts.append(TAIL)
    return "".join(parts)


def expected(summary):
    """The numbers the script prints, read from a study's summary (:func:`app.report.results.summary`)."""
    keys = ("share_within_threshold", "share_unobservable", "median_m", "p90_m")
    out = {k: {n: summary["maps"][k][n] for n in keys} for k in "AB"}
    if summary.get("layout_design"):
        out["layout_design"] = {n: summary["layout_design"][n] for n in keys}
    if summary.get("best_spacing"):
        out["best_d_m"] = summary["best_spacing"]["best_d_m"]
    tr = summary.get("track")
    if tr:
        out["track"] = dict(trmse_final_m=tr["trmse_final_m"], pcrlb_final_m=tr["pcrlb_final_m"],
                            nees=tr["nees"])
        if tr["nees"] is not None:
            out["track"]["nees_consistent"] = tr["nees_consistent"]
    return json.loads(json.dumps(out))
