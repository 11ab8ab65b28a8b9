"""The Shape tab's pure functions (app/tabs/shape/shape.py) and its parameters in the Scenario and the link."""

import re

import holoviews as hv
import numpy as np
import pytest

from app.state import url
from app.state.scenario import Scenario, preset_values
from app.tabs.design import compute as design_compute
from app.tabs.maps.compute import READS
from app.tabs.shape import shape, text as shape_text
from app.tabs.track import track
from core.shape.bound import shape_bound
from core.shape.cases import CASES


def values(**changed):
    s = Scenario()
    return {**{n: s.value(n) for n in shape.PARAMS}, **changed}


def test_every_paper_case_row_is_a_preset_that_rebuilds_its_case():
    rows = [row for _, rs in CASES.values() for row in rs]
    for row in rows:  # every row is a preset (a row equal to Fig. 4 is the Fig. 4 preset)
        name = shape.preset_of(values(**shape.values_of(row)))
        case = shape.case_of(values(**shape.PRESETS[name]))
        np.testing.assert_allclose(case.target.positions, row.target.positions, atol=1e-12)
        np.testing.assert_allclose(case.track.positions, row.track.positions, atol=1e-12)
        assert case.outliers.samples(case.track) == row.outliers.samples(row.track), name
        assert (case.noise_g, case.lag) == (row.noise_g, row.lag)
    assert len(shape.PRESETS) == len({shape.preset_of(values(**shape.values_of(r))) for r in rows}) > 10


def test_the_defaults_are_fig4_and_fig5_has_its_outliers():
    assert shape.preset_of(values()) == "seed003-fig4"
    assert shape.parse_outliers(shape.PRESETS["seed003-fig5"]["shape_outliers"]) == (-20.0, -10.0, 0.0)


@pytest.mark.parametrize("text, why", [
    ("-20, ten", "'ten' is not a number"),
    ("-20, 55", "off the pass"),
    ("nan", "off the pass"),
])
def test_outlier_text_is_refused_with_what_is_accepted(text, why):
    with pytest.raises(ValueError, match=why):
        shape.parse_outliers(text)
    assert shape.parse_outliers(" −20 , 0 ") == (-20.0, 0.0)
    assert shape.parse_outliers("") == ()


@pytest.mark.parametrize("changed, why", [
    (dict(shape_height=0.4), "make a disc"),  # H ≤ R with the type cylinder
    (dict(shape_inner_height=3.5, shape_inner_radius=0.2), "cavity must fit"),
    (dict(shape_inner_height=1.0), "cavity needs both"),
    (dict(shape_offset=0.0, shape_above=0.5), "passes [0-9.]+ m from"),
    (dict(shape_mx=0.0, shape_my=0.0, shape_mz=0.0), "moment is zero"),
    (dict(shape_outliers="100"), "off the pass"),
])
def test_values_accepted_alone_but_not_together_are_refused(changed, why):
    with pytest.raises(ValueError, match=why):
        shape.case_of(values(**changed))


def test_the_scenario_refuses_an_out_of_range_shape_value_and_keeps_the_last_good():
    s = Scenario()
    s.shape.shape_offset = 500.0
    assert s.shape.shape_offset == 5.0
    assert "outside the accepted range" in s.message and s.refused == ["shape_offset"]
    s.shape.shape_noise = 0.05
    assert s.shape.shape_noise == 0.05 and s.message == ""
    s.shape.shape_runs = 0
    assert s.shape.shape_runs == 1 and "shape_runs" in s.refused


def test_switching_the_type_sets_that_types_sizes_and_says_so():
    s = Scenario()
    s.shape.shape_type = "disc"
    assert (s.shape.shape_height, s.shape.shape_radius) == (0.3, 1.0)
    assert "Disc" in s.message and s.refused == ["shape_type"]
    shape.case_of(values(**{n: s.value(n) for n in shape.PARAMS}))  # consistent now
    s.shape.shape_radius = 0.2  # H > R: a disc no more, said by the tab
    with pytest.raises(ValueError, match="make a cylinder"):
        shape.case_of({n: s.value(n) for n in shape.PARAMS})


def test_shape_inputs_are_not_map_inputs_nor_reset_by_a_paper_figure():
    read = {*READS, *design_compute.ERROR_MAP_READS, *design_compute.SPACING_READS,
            *design_compute.LAYOUT_READS, *track.READS}
    assert not [n for n in read if n.startswith("shape_")]
    assert not [n for n in preset_values("Fig. 1") if n.startswith("shape_")]
    s = Scenario()
    s.shape.shape_offset = 12.0
    s.apply_preset("Fig. 5")
    assert s.shape.shape_offset == 12.0


def test_the_link_carries_the_shape_inputs_and_refuses_bad_ones():
    s = Scenario()
    s.update(shape_offset=12.5, shape_outliers="-20, 0", shape_window="seed 003 window (lag 5)")
    q = url.query(s, "Shape")
    assert "shape_offset=12.5" in q and "shape_outliers=-20%2C+0" in q and "tab=Shape" in q
    assert url.link_problem("shape_offset", 500) is not None
    assert url.link_problem("shape_type", "sphere") is not None
    assert url.link_problem("shape_offset", 12.5) is None


def test_verdict_and_bound_are_cores_and_the_bound_grows_with_the_offset():
    near = shape.compute(shape.key_of(Scenario()))
    case = near["case"]
    b = shape_bound(case.target, case.track, case.noise_g)
    assert near["bound"].main_scale_m == pytest.approx(b.main_scale_m, rel=1e-9)
    assert near["cpa"] == pytest.approx(np.hypot(5.0, 5.0), abs=1e-9)  # fig4: y 5 m, 5 m above
    text = shape.verdict_text(near)
    s = near["res"].summary["filters"]["nhukf"]
    assert f"main scale **{s['main_scale_m']:.3g} m**" in text
    assert f"span read ± {b.main_scale_m:.2g} m, second-moment read ± {b.spread_main_scale_m:.2g} m" in text
    far_scenario = Scenario()
    far_scenario.shape.shape_offset = 20.0
    far = shape.compute(shape.key_of(far_scenario))
    assert far["cpa"] > near["cpa"]
    assert far["bound"].main_scale_m > 100 * near["bound"].main_scale_m  # CPA^7.6: docs/shape.md
    assert far["bound"].spread_main_scale_m < far["bound"].main_scale_m / 10
    # the curve is increasing and holds the current pass
    ms = [c.main_scale_m for c in far["curve"]]
    assert np.all(np.diff(ms) > 0) and far["cpa"] in far["cpas"]


def test_views_have_units_and_mark_the_outliers():
    s = Scenario()
    s.update(shape.PRESETS["seed003-fig5"])
    v = shape.views(shape.key_of(s))
    err = hv.render(v["error"])
    assert err.xaxis[0].axis_label == "platform x (m)"
    assert err.yaxis[0].axis_label == "position error (m)"
    out = shape.compute(shape.key_of(s))
    assert out["res"].outlier_samples == [4 * 5, 6 * 5, 8 * 5]  # x = −20, −10, 0 at 5 m / sample
    labels = [el.label for el in v["error"]]
    assert "outlier samples" in labels
    plan, side = hv.render(v["plan"]), hv.render(v["side"])
    assert (plan.xaxis[0].axis_label, plan.yaxis[0].axis_label) == ("x (m)", "y (m)")
    assert side.yaxis[0].axis_label == "z (down) (m)"  # the side view: depth down
    assert side.y_range.start > side.y_range.end  # depth down
    bound = hv.render(v["bound"])
    assert (bound.xaxis[0].axis_label, bound.yaxis[0].axis_label) == ("closest approach (m)", "1σ bound (m)")


def test_a_tie_between_line_and_plane_is_shown_as_such_with_both_scales():
    """With an even number of passes the verdict can tie (core says "tie" and gives the main
    scale of each kind): the tab must not print it as a 100 % verdict nor a "nan m" scale."""
    import copy
    out = shape.compute(shape.key_of(Scenario()))
    tied = dict(out, res=copy.deepcopy(out["res"]))
    d = tied["res"].summary["filters"]["ukf"]
    d.update(kind="tie", kind_share={"line": 0.5, "plane": 0.5}, main_scale_m=float("nan"),
             main_scale_by_kind_m={"line": 3.1, "plane": 1.2})
    text = shape.verdict_text(tied)
    assert "a tie (line 50 %, 3.1 m, plane 50 %, 1.2 m)" in text
    assert "nan" not in text and "100 %" not in text


def test_a_fit_that_converged_on_no_pass_says_so_plainly():
    """When no pass's batch fit converges plausibly, core's summary gives kind "none" with no
    kind shares (core.shape.experiment); the tab printed "none (100 % of passes)", read as a
    verdict. It must say that no fit converged, on how many passes, with no ✓, no share and no
    "nan"; the filters' lines are unchanged."""
    import copy
    out = shape.compute(shape.key_of(Scenario()))
    before = shape.verdict_text(out)
    bare = dict(out, res=copy.deepcopy(out["res"]))
    d = bare["res"].summary["filters"]["fit"]
    runs = d["runs"]
    d.update(kind="none", kind_share={}, main_scale_by_kind_m={}, converged_share=0.0,
             converged_runs=0, **{k: float("nan") for k in (
                 "main_scale_m", "main_scale_error_m", "axis_error_deg", "centroid_error_m", "nees")})
    text = shape.verdict_text(bare)
    fit_line = next(ln for ln in text.split("\n\n") if ln.startswith("**Batch fit (whole pass)**"))
    assert "**no fit converged**" in fit_line
    assert (f"none of {runs} passes" if runs > 1 else "the pass") in fit_line
    assert "none (" not in text and "% of passes" not in fit_line
    assert "✓" not in fit_line and "nan" not in text
    for label in ("**UKF**", "**NHUKF (Huber)**"):  # the other estimators' lines stay as they were
        assert [ln for ln in text.split("\n\n") if ln.startswith(label)] == \
            [ln for ln in before.split("\n\n") if ln.startswith(label)]


def test_the_defaults_run_the_papers_window_and_show_the_batch_fit():
    """The tab's default update is seed 003's window (the one-sample update is a choice, and its
    Fig. 4 preset a comparison); the verdict, the plan view and the error view show the batch
    fit beside the filters, and say how the verdict is decided."""
    s = Scenario()
    assert s.shape.shape_window == "seed 003 window (lag 5)"
    assert "seed003-fig4 (one-sample update, for comparison)" in shape.PRESETS
    out = shape.compute(shape.key_of(s))
    assert out["case"].lag == 5
    text = shape.verdict_text(out)
    assert "filters: seed 003's window update (lag 5)" in text
    assert "**Batch fit (whole pass)**: **line** ✓" in text and "**This pass can size the target**" in text
    assert "How the verdict is decided" in text
    v = shape.views(shape.key_of(s))
    assert "Batch fit dipoles" in [el.label for el in v["plan"]]
    assert "Batch fit (whole pass)" in [el.label for el in v["error"]]
    assert "main scale, second-moment read" in [el.label for el in v["bound"]]


def test_a_pass_that_cannot_size_the_target_gets_no_tick():
    """Issue 40, defect 10: at a lateral offset of 60 m the page showed "line ✓, main scale
    2.89 m ± 1.8e+05 m" beside "this pass cannot size the target". Now nothing gets a ✓ there,
    and the text says why, with both reads' bounds; at the paper's pass the right kind does."""
    s = Scenario()
    s.shape.shape_offset = 60.0
    out = shape.compute(shape.key_of(s))
    assert not out["bound"].sizable
    text = shape.verdict_text(out)
    assert "✓" not in text.replace(shape_text.HOW, "") and "** ✓" not in text
    assert "**This pass cannot size the target**" in text and "second-moment read ±" in text
    # Issue 46 defect 14: the axis bound there was "± 7.6e+03°"; past 90° it bounds nothing
    assert out["bound"].axis_deg > shape_text.NO_ANGLE_BOUND_DEG
    assert "(no bound)" in text and "°)" not in text
    near = shape.verdict_text(shape.compute(shape.key_of(Scenario())))
    assert re.search(r"\(bound ± [0-9.e+-]+°\)", near)  # a near pass keeps its bound
    assert near.count("** ✓") >= 2  # at least the NHUKF and the fit: right kind and sizable
