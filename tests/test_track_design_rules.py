"""Issue 40 (Track and Layout design, in process): short tracks, NEES consistency on the command
line, divergence judged only against a bound that predicts, the sea trial preset, station depth h."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.stats import chi2

import core
from core.cli import track as track_cli
from core.tracking import montecarlo as tr


def test_a_track_shorter_than_the_banks_start_window_is_tracked():
    # issue 40 defect 9: ?track_duration=5 (6 steps at T = 1 s, accepted by the inputs) raised
    # "init_steps must be an integer in [1, 3]; got 10" in the bank
    from app.state.scenario import Scenario
    from app.tabs.track import track

    s = Scenario()
    s.update(track_duration=5.0, track_runs=2)
    out = track.compute(s)
    assert out["res"].trmse_m.shape == (6,) and np.all(np.isfinite(out["res"].trmse_m))
    # the bank starts from the steps there are: min(init_steps, K)
    case = track.case_of(s.snapshot())
    sensors = case.sensors()
    ys = sensors.h(case.nominal_track()[None])
    F, Q = core.dwna_model(case.T, case.sigma_a, case.alpha)
    a = core.run_bank(ys, sensors, F, Q, depth=case.bank_depth, init_steps=10)
    b = core.run_bank(ys, sensors, F, Q, depth=case.bank_depth, init_steps=6)
    np.testing.assert_array_equal(a.x0, b.x0)
    with pytest.raises(ValueError):
        core.run_bank(ys, sensors, F, Q, depth=case.bank_depth, init_steps=0)


def test_the_nees_band_is_the_chi_square_band_of_the_runs_mean():
    lo, hi = tr.nees_band(7, 5)
    assert lo == pytest.approx(chi2.ppf(0.005, 35) / 5) and hi == pytest.approx(chi2.ppf(0.995, 35) / 5)
    assert lo < 7 < hi


def test_the_command_line_flags_an_inconsistent_nees(tmp_path, capsys):
    # issue 40 defect 14: "mean NEES 2.64e+03" was printed with no warning and no flag
    out = tmp_path / "trial"
    assert track_cli.main(["--case", "seed001-trial", "--runs", "3", "--out", str(out)]) == 0
    said = capsys.readouterr().out
    s = json.loads((out / "summary.json").read_text())
    lo, hi = tr.nees_band(7, 3)
    assert s["nees_band"] == pytest.approx([lo, hi]) and s["nees"] > hi  # measured: 7.18e+03
    assert s["nees_consistent"] is False
    assert "WARNING: mean NEES" in said and "overconfident" in said
    # a consistent filter: flagged consistent, no warning
    out2 = tmp_path / "sim"
    assert track_cli.main(["--case", "seed001-sim", "--filter", "ekf", "--runs", "4", "--seed", "2",
                           "--out", str(out2)]) == 0
    said = capsys.readouterr().out
    s = json.loads((out2 / "summary.json").read_text())
    assert s["nees_band"][0] <= s["nees"] <= s["nees_band"][1] and s["nees_consistent"] is True
    assert "WARNING" not in said


def test_divergence_is_not_judged_against_a_bound_that_predicts_nothing():
    # issue 40 (low): "diverged 0 %" beside a final error of 2.3 km: the final PCRLB (4.5 km)
    # is beyond its linearisation limit there, and 5 × it hid every error
    from app.state.scenario import Scenario
    from app.tabs.track import track

    s = Scenario()
    s.update(track_x0=-1000.0, track_y0=-900.0)
    out = track.compute(s)
    summary = out["res"].summary
    assert summary["diverged"] is None and summary["diverged_rule"].startswith("not judged")
    text = track.summary_text(out)
    assert "diverged 0 %" not in text and "not judged" in text
    lo, hi = summary["final_error_range_m"]
    assert lo > 1000.0  # the errors the page now quotes beside it (measured 1.5–3.4 km)
    # where the bound predicts, the share is judged and its rule said
    s.update(track_x0=-250.0, track_y0=-120.0)
    out = track.compute(s)
    assert out["res"].summary["diverged"] is not None
    assert "a run diverges when its final error exceeds max(5 × final PCRLB, 10 m)" in track.summary_text(out)


def test_the_station_depth_h_moves_the_custom_stations_at_it():
    # issue 40 defect 6: h = 120 moved neither the Layout design nor the Track stations; three
    # clicked stations then sat at 120 m beside two at 100 m, unsaid
    from app.state.scenario import Scenario
    from app.tabs.design.compute import drawn_stations
    from app.tabs.track import track

    s = Scenario()
    assert [st[2] for st in s.stations.stations] == [100.0, 100.0]
    s.stations.h = 120.0
    assert [st[2] for st in s.stations.stations] == [120.0, 120.0] and s.message == ""
    for x, y in [(-229.0, 168.0), (-134.0, -165.0), (55.0, 205.0)]:  # clicked: at h
        layout = s.stations.stations
        s.stations.stations = drawn_stations({"x": [st[0] for st in layout] + [x],
                                              "y": [st[1] for st in layout] + [y]}, layout, s.stations.h)
    assert [st[2] for st in s.stations.stations] == [120.0] * 5
    # the Track tab's stations are these
    assert {st[2] for st in track.case_of(s.snapshot()).stations} == {120.0}
    # a station given a depth of its own keeps it; the others follow h
    s.stations.stations = [[0.0, 0.0, 90.0], *s.stations.stations[1:]]
    s.stations.h = 110.0
    assert [st[2] for st in s.stations.stations] == [90.0] + [110.0] * 4
    # a refused h (above the sea surface) moves nothing
    s.stations.h = -5.0
    assert s.stations.h == 110.0 and [st[2] for st in s.stations.stations] == [90.0] + [110.0] * 4
    assert "above the sea surface" in s.message
    # in a layered sea, an h outside the water column is refused and the stations stay
    s.update(sea_model="layered", sea_depth=150.0)
    before = [list(st) for st in s.stations.stations]
    s.stations.h = 160.0
    assert s.stations.h != 160.0 and s.stations.stations == before and "water column" in s.message


# building the tab: Panel's Tabulator calls pandas' deprecated reset_index(inplace=True), and
# Panel 1.9 deprecates the buttons' button_type (as tests/test_input_extremes.py)
@pytest.mark.filterwarnings("ignore:The inplace keyword:pandas.errors.Pandas4Warning")
@pytest.mark.filterwarnings("ignore:.*deprecated and will be removed in version 2.0:PendingDeprecationWarning")
def test_a_depth_error_beyond_the_water_column_is_flagged():
    # issue 40 (low): "depth error of 1.24e+04 m" was printed, unflagged, in 8.4 m of water
    import panel as pn

    from app.kit.cache import SHARED
    from app.page import _widgets
    from app.state.scenario import Scenario
    from app.tabs.design.design import design_tab

    s = Scenario()
    s.apply_preset("Seed 001 sea trial")
    tab = design_tab(s, SHARED, _widgets())
    readout = next(p for p in tab.select(pn.pane.Markdown) if "w-ellipse-text" in p.css_classes)
    sigma_z = float(readout.object.split("depth error ")[1].split(" m;")[0])
    assert sigma_z > 8.4  # at the default point (100, 100) m
    assert "larger than the water column (8.4 m)" in readout.object
    # a whole-space depth error is not compared with any water column
    s.apply_preset("Fig. 5")
    tab = design_tab(s, SHARED, _widgets())
    readout = next(p for p in tab.select(pn.pane.Markdown) if "w-ellipse-text" in p.css_classes)
    assert "depth error" in readout.object and "water column" not in readout.object
