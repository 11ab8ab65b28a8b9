"""Every input of every tab at its extremes (issue 28): its lowest and highest accepted values,
and just beyond them. Each extreme either computes what its tab shows, within the time stated
for that tab (:data:`WITHIN`), or is refused with a message saying why; none raises.

The numbers are walked one at a time from the default scenario, in the context where they are
used (a magnetic moment with a magnetic sensor, the x–z plane's y in the x–z plane, the seabed
in a layered sea, …). Refusals come from :class:`app.state.scenario.Scenario` (the last good value is
kept and :attr:`Scenario.message` names the input) or from the tab, which says what is wrong in
its own pane. The Track, Calibration and Shape tabs are their real layouts built here, outside a
server: their computations (app.kit.offloop) then finish before the value's assignment returns, so
the time of that assignment is the tab's time for the value. The maps and the Layout design tab
are computed by the functions their tabs call (app.tabs.maps.compute, app.tabs.design.compute).
"""

import math
import time

import numpy as np
import panel as pn
import param
import pytest

from app.state.scenario import ACCEPTED, MAX_STATIONS, Scenario, parameter
from app.tabs.calibration import calibration, sources
from app.tabs.design import compute as design_compute
from app.tabs.maps import compute
from app.tabs.maps.compute import Snapshot
from app.tabs.shape import shape
from app.tabs.track import track

# The tabs' widgets use ``name``, ``button_type`` and ``button_style`` (Panel 1.5.5, the lowest
# declared version, has no ``label``, ``color`` or ``variant``); Panel 1.9 warns that they will be
# removed in Panel 2.0 when the tabs are built here.
pytestmark = pytest.mark.filterwarnings(
    "ignore:.*deprecated and will be removed in version 2.0:PendingDeprecationWarning")

#: Runs alone, after the rest (``pytest -m serial``; tests/conftest.py):
SERIAL = "it bounds the seconds each extreme value takes to compute"

#: Seconds an extreme may take to compute, on the 2-core development machine shared with other
#: work (measured at load 4-5, the slowest extreme of each tab: the maps 2.5 s, a magnetometer +
#: gradiometer pair of 200 × 200 maps, 0.2 s for the electric 400 × 400 with 20 instants; a track
#: of 20 Monte-Carlo runs of the 12-filter bank ~5 s; 20 passes of seed 003 ~15 s; the
#: calibration's 5,000 filter steps 0.4 s; the best spacing ~1 s): about twice to three times those.
WITHIN = {"maps": 5.0, "design": 15.0, "track": 30.0, "cal": 10.0, "shape": 45.0}

MAGNETIC = {"sensor": "magnetometer + gradiometer (BG)"}
#: Where a number is used (set before it): the default scenario uses every other one.
CONTEXT = {
    "y": {"plane": "x–z"}, "z_min": {"plane": "x–z"}, "z_max": {"plane": "x–z"},
    "k": {"comparison": "Moments ×k − original (Fig. 3)"},
    "Ph_b": {"comparison": "Moment split B − A (Fig. 4)"},
    "Pv_b": {"comparison": "Moment split B − A (Fig. 4)"},
    "d_ref": {"comparison": "Spacing d − reference d (Fig. 6)"},
    "sea_depth": {"sea_model": "layered"}, "seabed_sigma": {"sea_model": "layered"},
    **{n: MAGNETIC for n in ("mx", "my", "mz", "noise_b", "noise_g", "baseline")},
    **{n: {**MAGNETIC, "comparison": "Moment split B − A (Fig. 4)"} for n in ("mx_b", "my_b", "mz_b")},
    "threshold": {"criterion": "Area with CRLB error under threshold"},
    "cal_roll_deg": {"cal_source": "Designed manoeuvre"},
    "cal_pitch_deg": {"cal_source": "Designed manoeuvre"},
}


def tab_of(name):
    if name.startswith(("track_", "cal_", "shape_")):
        return name.split("_")[0]
    return "design" if name in ("threshold", "ellipse_x", "ellipse_y", "n_stations") else "maps"


def extremes(name):
    """(value, accepted?) pairs: the lowest and highest accepted and just beyond each."""
    lo, hi, _ = ACCEPTED[name]
    if isinstance(parameter(name), param.Integer):
        return [(lo, True), (hi, True), (lo - 1, False), (hi + 1, False)]
    eps = 1e-6 * max(abs(lo), abs(hi), 1e-300)
    return [(float(lo), True), (float(hi), True), (lo - eps, False), (hi + eps, False)]


def scenario_for(name):
    s = Scenario()
    s.update(CONTEXT.get(name, {}))
    s.param.update(message="", refused=[])
    return s


# ----------------------------------------------------------------------------- the tabs' outputs
class Tab:
    """One tab of scenario ``s``: ``shown()`` is (what it computed, or None) and its message."""

    def __init__(self, s, kind):
        self.s, self.kind = s, kind
        if kind == "track":
            self.layout = track._outputs(s)
        elif kind == "cal":
            self.layout = calibration.calibration_tab(s)
        elif kind == "shape":
            self.layout = shape.shape_tab(s)

    def _pane(self, css):
        return next(p for p in self.layout.select(pn.pane.PaneBase) if css in p.css_classes)

    def shown(self):
        """(computed: a str summary of what the tab shows, or None; the tab's message)."""
        s, kind = self.s, self.kind
        if kind == "maps":
            p = compute.compute(Snapshot.of(s))
            return f"maps {p.titles}", ""
        if kind == "design":
            snap = Snapshot.of(s, design_compute.ERROR_MAP_READS)
            d = design_compute.design(snap)
            ell = design_compute.error_at(snap, s.design.ellipse_x, s.design.ellipse_y)
            extra = ""
            if s.design.criterion.startswith("Area"):
                spacing = design_compute.best_spacing(Snapshot.of(s, design_compute.SPACING_READS))
                extra = f", best d = {spacing.result.d:.3g} m"
            if s.design.n_stations in (1, MAX_STATIONS):
                layout = design_compute.optimised_layout(Snapshot.of(s, design_compute.LAYOUT_READS))
                extra += f", optimised {len(layout.stations)} stations"
            return f"design {np.nanmin(d.errors.position):.3g} m, ellipse {ell is not None}{extra}", ""
        if kind == "track":
            problem, out = self.layout[0], self.layout[1]
            return (None if problem.visible else out[0].object), (problem.object if problem.visible else "")
        if kind == "cal":
            err, text = self._pane("w-cal-error").object, self._pane("w-cal-summary").object
            return (None if err else text), err
        problem, verdict = self._pane("w-shape-problem"), self._pane("w-shape-verdict")
        return (None if problem.visible else verdict.object), (problem.object if problem.visible else "")


def check(s, tab, name, value, accepted):
    """Set ``name`` = ``value`` and check the outcome (module docstring)."""
    before = s.value(name)
    s.param.update(message="", refused=[])
    t0 = time.perf_counter()
    setattr(s.part_of(name), name, value)  # must not raise
    shown, said = tab.shown()
    took = time.perf_counter() - t0
    what = f"{name} = {value!r}"
    if "Kept the last good" in s.message and name in s.refused:  # refused by the Scenario: said,
        assert s.value(name) == before, f"{what}: refused but not restored"  # last good kept
        return "refused", s.message
    assert accepted, f"{what} is beyond the accepted range but was taken: {s.message!r}"
    assert s.value(name) == value
    if shown is None:  # refused by the tab (values accepted alone but not together): said there
        assert said, f"{what}: the tab shows neither a result nor a message"
        return "refused by the tab", said
    if took > WITHIN[tab.kind] and tab.kind in ("maps", "design"):  # computed again (no cache):
        t0 = time.perf_counter()  # the shared machine may have been busy; one clean try must pass
        tab.shown()
        took = min(took, time.perf_counter() - t0)
    assert took <= WITHIN[tab.kind], f"{what}: {took:.1f} s (bar {WITHIN[tab.kind]} s on this machine)"
    return "computed", f"{took:.2f} s"


NUMBERS = sorted(ACCEPTED)


@pytest.mark.parametrize("name", NUMBERS)
def test_every_number_at_its_extremes_computes_or_is_refused_with_a_message(name):
    s = scenario_for(name)
    tab = Tab(s, tab_of(name))
    outcomes = {}
    for value, accepted in extremes(name):
        outcomes[value] = check(s, tab, name, value, accepted)
        if not accepted:
            assert outcomes[value][0] == "refused", f"{name} = {value!r}: {outcomes[value]}"
            lo, hi, unit = ACCEPTED[name]
            assert parameter(name).label in outcomes[value][1], outcomes[value]  # names the input
            assert f"{lo:g}" in outcomes[value][1] and f"{hi:g}" in outcomes[value][1], outcomes[value]
    print(name, outcomes)


# ----------------------------------------------------------------------- inputs that are not numbers
def test_the_custom_layout_at_its_extremes():
    s, tab = Scenario(), None
    tab = Tab(s, "design")
    lo, hi, _ = ACCEPTED["y"]
    cases = [([[0.0, 0.0, 100.0]], True),  # one station
             ([[10.0 * i, 5.0 * i, 100.0] for i in range(MAX_STATIONS)], True),
             ([[hi, lo, hi], [lo, hi, 0.0]], True),  # the far corners, at the surface and 5 km deep
             ([[10.0 * i, 0.0, 100.0] for i in range(MAX_STATIONS + 1)], False),
             ([], False),
             ([[hi + 1e-3, 0.0, 100.0]], False),
             ([[0.0, 0.0, -1e-3]], False),  # above the sea surface
             ([[0.0, math.nan, 100.0]], False)]
    for stations, accepted in cases:
        s.param.update(message="", refused=[])
        before = s.stations.stations
        t0 = time.perf_counter()
        s.stations.stations = stations
        shown, _ = tab.shown()
        took = time.perf_counter() - t0
        if accepted:
            assert s.stations.stations == stations and not s.message, (stations, s.message)
            assert shown and took <= WITHIN["design"], (stations, took)
        else:
            assert s.stations.stations == before and s.message and s.refused == ["stations"], (stations, s.message)


def test_the_calibration_headings_at_their_extremes():
    """1 to 72 headings within ±360° are taken (±360° is north, wrapped as core's attitudes are:
    it was refused by core, 'radians?', after the tab took it); more, beyond, or no numbers are
    refused by the tab with a message."""
    s = scenario_for("cal_roll_deg")
    tab = Tab(s, "cal")
    good = ["0", "360", "-360", "360, -360, 0, 90", ", ".join(str(5 * i - 180) for i in range(72)),
            "359.99, -359.99"]
    for text in good:
        for noise in (0.0, 2.0):  # the largest angle error pushes a heading past ±360° before wrapping
            s.calibration.cal_angle_noise_deg = noise
            assert check(s, tab, "cal_headings", text, True)[0] == "computed", (text, noise)
    assert np.allclose(sources.parse_headings("360, -360, 180, -180, 270, -270"), [0, 0, 180, 180, -90, 90])
    bad = ["", "north", "360.01", "-360.5", ", ".join(["0"] * 73), "nan", "1e400"]
    for text in bad:
        outcome, said = check(s, tab, "cal_headings", text, True)
        assert outcome == "refused by the tab" and "Headings must be" in said, (text, outcome, said)


def test_the_calibration_sources_and_the_shape_and_track_choices():
    """Every choice of the selectors that start a computation computes (each option is one the
    widget offers: there is no 'beyond')."""
    for name in ("cal_source", "cal_convention", "track_filter", "track_axes", "shape_type", "shape_window"):
        s = scenario_for(name)
        tab = Tab(s, tab_of(name))
        for option in parameter(name).objects:
            outcome, said = check(s, tab, name, option, True)
            if option == "Uploaded CSV":  # nothing uploaded yet: the tab says what to upload
                assert outcome == "refused by the tab" and "Upload a CSV" in said
            else:
                assert outcome == "computed", (name, option, said)


def test_the_shape_outliers_text_at_its_extremes():
    s = Scenario()
    tab = Tab(s, "shape")
    good = ["", "-40, 40", ", ".join(str(4 * i - 40) for i in range(20))]
    for text in good:
        assert check(s, tab, "shape_outliers", text, True)[0] == "computed", text
    for text in ["-40.01", "40.01", ", ".join(["0"] * 21), "x", "nan"]:
        outcome, said = check(s, tab, "shape_outliers", text, True)
        assert outcome == "refused by the tab" and "outliers" in said, (text, outcome, said)
