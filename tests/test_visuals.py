"""Issue 25, item 4: what the maps and the Track tab draw, without a browser (the served page:
tests/test_browser_visuals.py)."""

import numpy as np
import pytest
from bokeh.colors import RGB

from app.kit.cache import SHARED
from app.state.scenario import Scenario
from app.tabs.design import compute as dc
from app.tabs.maps import compute as c
from app.tabs.maps import data as map_data, maps
from app.tabs.maps.compute import Snapshot
from app.tabs.track import track

CRLB = "CRLB position error (m)"


def _constant_along(codes, sign):
    """Whether ``codes`` is constant along every line i + sign·j = const (a diagonal stripe)."""
    i, j = np.indices(codes.shape)
    key = i + sign * j
    return all(np.unique(codes[key == k]).size == 1 for k in np.unique(key))


def test_runaway_marks_are_not_stripes_like_the_unobservable_veil():
    # both were diagonal stripes (one each way) and were confused; runaway points are dots now
    n = 48
    everywhere = np.ones((n, n), bool)
    unobservable = map_data.veil_codes(~everywhere, np.zeros((n, n)))
    runaway = map_data.veil_codes(everywhere, np.zeros((n, n)), runaway=everywhere)
    assert set(np.unique(runaway)) == {map_data.RUNAWAY, map_data.RUNAWAY_GAP}
    assert _constant_along(unobservable, +1)  # the veil: stripes
    assert not _constant_along(runaway, +1) and not _constant_along(runaway, -1)  # no stripe either way
    # nor horizontal or vertical lines: each row and each column has both codes somewhere
    dots = runaway == map_data.RUNAWAY
    assert not dots.all(axis=1).any() and not dots.all(axis=0).any()


def test_the_design_and_track_maps_dot_runaway_points_as_the_maps_tab_does():
    d = dc.design(Snapshot.of(Scenario(resolution=41), dc.ERROR_MAP_READS))
    far = c.runaway(d.plane, d.stations, d.errors.position, d.errors.observable)
    assert far.any()
    from app.kit import views

    layer = np.flipud(views.runaway_layer(d).data) > 0
    np.testing.assert_array_equal(layer, far & map_data.runaway_dots(far.shape))


def test_the_runaway_legend_shows_only_when_a_map_has_runaway_marks():
    det = c.compute(Snapshot.of(Scenario(resolution=31)))
    crlb = c.compute(Snapshot.of(Scenario(resolution=31, measure=CRLB)))
    assert any(r.any() for r in crlb.runaway)
    assert "runaway" not in maps.legend(det)  # it was shown for every measure
    assert "runaway" in maps.legend(crlb) and "unobservable" in maps.legend(det)


def _blueness(hex_colour):
    rgb = RGB(*(int(hex_colour[k:k + 2], 16) for k in (1, 3, 5)))
    return rgb.b - rgb.r


@pytest.mark.parametrize("measure", ["log10|det Γ| (paper)", "Observability index log10 η",
                                     "D-optimal ½·log10 det F", CRLB])
def test_b_better_has_the_same_colour_on_every_difference_map(measure):
    # the CRLB difference (lower is better) showed "B better" in red, the others in blue
    p = c.compute(Snapshot.of(Scenario(resolution=31, measure=measure, difference="Signed log-ratio")))
    low, high, palette = map_data.ranges(p)[2]
    assert low < 0 < high and palette is not map_data.Viridis256
    better_low = measure == CRLB  # log10(σB/σA) < 0: B locates better; else log10(B/A) > 0
    better, worse = (palette[0], palette[-1]) if better_low else (palette[-1], palette[0])
    assert _blueness(better) > 50 and _blueness(worse) < -50  # #053061 blue, #67001f red
    # and the colour bar says which side is better
    assert "B better" in p.diff_label or "B locates better" in p.diff_label


@pytest.fixture(scope="module")
def track_out():
    return track.compute(Scenario(track_runs=2, track_filter="ekf", track_duration=60.0))


def _plan_figure(out):
    import holoviews as hv

    return hv.render(track.plan_view(out), backend="bokeh")


def test_the_track_colour_bar_is_in_metres_on_a_log_scale(track_out):
    # it said "(m)" over ticks of log10 m (−2 … 3)
    from bokeh.models import ColorBar, LogColorMapper

    fig = _plan_figure(track_out)
    bars = [m for m in fig.select(type=ColorBar)]
    assert len(bars) == 1
    assert isinstance(bars[0].color_mapper, LogColorMapper)
    assert "(m)" in bars[0].title and "log" in bars[0].title
    # the mapper's range is the bound's own, in metres
    bound = track_out["res"].pcrlb_m
    finite = bound[np.isfinite(bound)]
    assert bars[0].color_mapper.low == pytest.approx(finite.min(), rel=1e-6)
    assert bars[0].color_mapper.high == pytest.approx(finite.max(), rel=1e-6)


def test_the_track_legend_is_outside_the_frame(track_out):
    # inside (top left) it covered the estimates
    from bokeh.models import Legend

    fig = _plan_figure(track_out)
    legends = list(fig.select(type=Legend))
    assert len(legends) == 1
    assert legends[0] not in fig.center and any(legends[0] in side for side in (fig.right, fig.below))


def test_the_track_help_quotes_the_moments_and_noise_and_where_they_are_set():
    # it said "the sensor noise set above", while the noise is in the sidebar's collapsed
    # Advanced section on the left
    s = Scenario(noise=2e-7, Ph=150.0)
    text = track.note_text(s.snapshot(track.NOTE_READS))
    assert "set above" not in text
    assert "2e-07 V/m" in text and "P = (150, 20) A·m" in text and "Advanced" in text
    s.sensor.sensor = next(k for k, v in track.SENSORS.items() if v == "B")
    text = track.note_text(s.snapshot(track.NOTE_READS))
    assert f"{s.sensor.noise_b:g} nT" in text and "A·m²" in text


@pytest.mark.parametrize("text, why", [("abc", "is not a number"), ("1,5", "use a point for decimals"),
                                       ("", "empty"), ("nan", "not a finite number")])
def test_text_typed_in_a_number_box_is_refused_with_its_reason(text, why):
    # Bokeh's numeric box dropped "abc" in the browser, silently
    from app.kit.inputs import number_input

    s = Scenario()
    column = number_input(s.target, "Ph", css_classes=["w-Ph"])
    box, slider = column.objects
    box.value = text
    assert why in s.message and s.message.startswith("P_h (A·m)") and s.refused == ["Ph"]
    assert s.target.Ph == 100.0 and box.value == "100" and slider.value == 100.0  # the last good value
    box.value = "150"  # a number is taken, and the message goes
    assert s.target.Ph == 150.0 and slider.value == 150.0 and s.message == ""


def test_a_whole_number_box_refuses_a_fraction_and_shows_values_exactly():
    from app.kit.inputs import number_input, shown_text

    s = Scenario()
    box = number_input(s.region, "resolution").objects[0]
    old = s.region.resolution
    box.value = "2.5"
    assert "not a whole number" in s.message and s.region.resolution == old
    assert shown_text(1e-7) == "1e-07" and shown_text(2.8284271247461903) == "2.83"
    assert shown_text(-0.001) == "-0.001" and shown_text(-0.5) == "-0.5" and shown_text(0.0) == "0"
    s = Scenario(speed=2.8284271247461903)
    box = number_input(s.target, "speed").objects[0]
    assert box.value == "2.83" and s.target.speed == 2.8284271247461903  # showing it rounded changes nothing


def test_a_new_session_does_not_compute_the_track_before_its_tab_is_shown():
    # pn.panel(lambda: ..., lazy=True) ran the lambda at once (an ``interactive``): every new
    # session ran the Monte-Carlo, and the tab's first render carried its plots (2-3 s blank)
    s = Scenario(track_runs=2, track_filter="ekf", track_duration=60.0)
    SHARED.clear()
    tab = track.track_tab(s)
    assert len(SHARED) == 0
    tab.get_root()  # shown: computed now (outside a server, at once)
    assert len(SHARED) == 1


def test_the_png_export_is_high_resolution_and_draws_the_pages_numbers():
    import io

    from PIL import Image

    from app.tabs.maps import export

    p = c.compute(Snapshot.of(Scenario(resolution=41)))
    img = Image.open(io.BytesIO(export.to_png(p).getvalue()))
    assert img.size[0] >= 1600  # the save tool's PNG was 403 × 446
    fig = export.figure(p)
    d = map_data.prepare(p)
    for which, ax in enumerate(fig.axes[:3]):
        shown = ax.images[0].get_array()
        values = d.maps[which][0]
        np.testing.assert_array_equal(np.ma.getmaskarray(shown), ~np.isfinite(values))
        np.testing.assert_allclose(shown.compressed(), values[np.isfinite(values)])
        assert ax.images[0].get_clim() == pytest.approx(d.ranges[which][:2])
        assert ax.get_aspect() == 1.0  # a metre is a metre
    assert fig.axes[0].get_title().startswith("A: single station")


def test_the_png_export_of_an_x_z_section_states_its_vertical_exaggeration():
    from app.tabs.maps import export

    p = c.compute(Snapshot.of(Scenario(resolution=31, plane="x–z", z_min=100.0, z_max=400.0)))
    fig = export.figure(p)
    ax = fig.axes[0]
    assert ax.get_aspect() == 2.0 and ax.get_ylabel() == "z (m), vertical ×2"
    top, bottom = ax.get_ylim()
    assert top > bottom  # depth down


@pytest.mark.filterwarnings(  # Panel 1.9 deprecates button_type/button_style (as test_calibration_tab)
    "ignore:.*deprecated and will be removed in version 2.0:PendingDeprecationWarning")
def test_the_preset_button_of_the_scenario_is_solid_and_no_other():
    # one watcher restyles the eight buttons (each button's own binding re-read every input of
    # the scenario: ~half of a slider change's watcher time on the server)
    import panel as pn

    from app.page import create_app
    from app.state.scenario import PRESETS

    app = create_app()
    s = app.scenario  # the template's (create_app)
    buttons = [b for b in pn.Column(*app.sidebar).select(pn.widgets.Button) if b.name in PRESETS]
    assert len(buttons) == len(PRESETS)

    def solid():
        return [b.name for b in buttons if b.button_style == "solid"]

    assert solid() == ["Fig. 5"]  # the page opens on Fig. 5's scenario
    s.apply_preset("Seed 001 sea trial")
    assert solid() == ["Seed 001 sea trial"]
    s.apply_preset("Fig. 2")
    assert solid() == ["Fig. 2"]
    s.target.Ph = 123.0
    assert solid() == []
