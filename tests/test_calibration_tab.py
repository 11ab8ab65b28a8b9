"""The Calibration tab's numbers and words (app/tabs/calibration/calibration.py), in-process (issue 25's items on
the tab: the noise the residuals give, the convention that fits, a rank-9 manoeuvre said as such,
inputs that follow the data source, numbers without float noise, distinct curve colours).
The same things in the browser: tests/test_calibration_browser.py."""

from __future__ import annotations

import io
import itertools
import re

import numpy as np
import panel as pn
import param
import pytest
from bokeh.models import GlyphRenderer

from app.state.scenario import Scenario
from app.tabs.calibration import calibration as ac
from app.tabs.calibration.plots import Figures, plot_data
from core import calibration as cal

#: Panel 1.9 deprecates the button_type/button_style every button of the app uses (as
#: tests/test_input_extremes.py, which builds the tabs too).
pytestmark = pytest.mark.filterwarnings(
    "ignore:.*deprecated and will be removed in version 2.0:PendingDeprecationWarning")


def values(preset=None, **extra):
    s = Scenario()
    if preset:
        s.update(ac.PRESETS[preset])
    s.update(extra)
    return {f: s.value(f) for f in ac.FIELDS}


def zyx_log(n=400, seed=4):
    """A CSV of seed 004's simulated ship recorded in the 'zyx' convention (uniform errors ±100 nT
    and ±0.05°), as the tab accepts an upload."""
    rng = np.random.default_rng(seed)
    sim = cal.SEED004_SIMULATION
    B, rec = cal.simulate_ship_data(np.array(sim["K"]), np.array(sim["Bp"]), cal.random_attitudes(n, rng),
                                    np.array(sim["be"]), rng, noise_nt=100.0, angle_noise_deg=0.05,
                                    convention="zyx")
    out = io.StringIO()
    np.savetxt(out, np.hstack([B, rec]), delimiter=",", header="B1,B2,B3,psi,theta,phi", comments="")
    return out.getvalue().encode()


# --------------------------------------------------------------------------- 1. σ from the residuals
def test_table1_offers_the_noise_of_its_residuals_and_its_bounds():
    """Table 1 with σ = 100 nT: residual ~400 nT, σ̂ = 489 nT (core's fit_diagnosis). The tab
    gives the CRLB for σ̂ beside the stated one's (4.9× larger: no angle errors, so the CRLB is
    linear in σ, to round-off) and offers σ̂'s ± bound (√3 σ̂, the input's unit); with it set,
    nothing is left to say about the noise."""
    res = ac.compute(values("Seed 004 Table 1"))
    d, fr = res["diagnosis"], res["from_residuals"]
    assert d.noise_misstated and fr is not None
    assert fr["sigma_nt"] == pytest.approx(d.sigma_hat_nt, rel=1e-12)  # no angle errors stated
    assert 485 < fr["sigma_nt"] < 495
    np.testing.assert_allclose(fr["crlb"], res["crlb"] * d.ratio, rtol=1e-9)
    table = ac.coefficient_table(res)
    assert list(table["CRLB σ from residuals"]) == [ac._fmt(x, " nT" if j >= 9 else "")
                                                   for j, x in enumerate(fr["crlb"])]
    assert "σ from the residuals (489.4 nT" in ac.summary(res)
    fix = ac.fixes(res)["noise"]
    assert fix == {"cal_noise_nt": pytest.approx(np.sqrt(3) * fr["sigma_nt"], rel=1e-12)}
    again = ac.compute({**values("Seed 004 Table 1"), **fix})
    assert again["from_residuals"] is None and again["diagnosis"].ratio == pytest.approx(1.0, rel=1e-9)
    assert "CRLB σ from residuals" not in ac.coefficient_table(again)


def test_stated_noise_that_fits_offers_nothing():
    res = ac.compute(values("Seed 004 simulation"))
    assert res["from_residuals"] is None and ac.fixes(res) == dict(noise=None, convention=None, be=None)
    assert "CRLB σ from residuals" not in ac.coefficient_table(res)


def test_angle_errors_share_stays_in_the_offered_noise():
    """With angle errors stated, σ̂ holds both shares; the reading σ offered is σ̂ with the angle
    share taken out, so that stating it makes σ̂/σ = 1 (to the linearisation's round-off)."""
    v = values("Seed 004 Table 1", cal_angle_noise_deg=0.2)
    res = ac.compute(v)
    fr = res["from_residuals"]
    assert fr is not None and fr["sigma_nt"] < res["diagnosis"].sigma_hat_nt
    again = ac.compute({**v, **ac.fixes(res)["noise"]})
    assert again["diagnosis"].ratio == pytest.approx(1.0, rel=1e-6)


# --------------------------------------------------------------------------- 2. the convention
def test_a_log_in_another_convention_names_it_and_the_tab_can_use_it():
    """A log recorded in 'zyx', solved with the default convention: a misfit that names 'zyx'
    and offers it (no noise offered: a misfit's bounds mean nothing at any noise); with 'zyx'
    chosen, the model fits (σ̂/σ within the χ² threshold: nothing said)."""
    data = zyx_log()
    v = values(cal_source="Uploaded CSV", cal_noise_nt=100.0, cal_angle_noise_deg=0.05)
    res = ac.compute(v, data)
    d = res["diagnosis"]
    assert d.level == "misfit" and "'zyx' attitude convention" in ac.summary(res)
    assert ac.fixes(res) == dict(noise=None, convention={"cal_convention": "zyx"}, be=None)
    good = ac.compute({**v, "cal_convention": "zyx"}, data)
    assert good["convention"] == "zyx" and good["diagnosis"].level == "ok", good["diagnosis"].messages


def test_simulated_cases_follow_the_convention():
    """The simulated ship is recorded in the chosen convention, so every convention's case is
    consistent (σ̂/σ within the threshold) and has the same rank."""
    for conv in cal.CONVENTIONS:
        res = ac.compute(values("Seed 004 simulation", cal_n_attitudes=60, cal_convention=conv))
        assert res["convention"] == conv and res["obs"].rank == 12
        assert res["diagnosis"].level == "ok", (conv, res["diagnosis"].messages)


# --------------------------------------------------------------------------- 3. rank 9
def test_four_level_headings_read_as_not_identifiable():
    """Rank 9: six coefficients have no bound. The summary names them as not identifiable and
    makes no 'within one CRLB σ' claim; the geomagnetic solution's ~0 nT is said to be no check;
    the table marks the estimates arbitrary."""
    res = ac.compute(values("Four level headings"))
    assert res["obs"].rank == 9
    lost = ("k13", "k23", "k33", "Bp1", "Bp2", "Bp3")
    assert ac.unidentifiable(res) == lost
    text = ac.summary(res)
    assert "**Not identifiable: k13, k23, k33, Bp1, Bp2 and Bp3**" in text
    assert "within one CRLB σ" not in text and "no convergence to report" in text
    assert "Not a check of K and Bp" in text
    assert text.count("k13, k23, k33") == 1  # said once (core's record-rank sentence not repeated)
    table = ac.coefficient_table(res).set_index("coefficient")
    for c in cal.COEFFICIENTS:
        row = table.loc[c]
        if c in lost:
            assert row["observable"] == "no: not identifiable" and row["CRLB σ"] == "∞"
            assert row["Kalman"].endswith("(arbitrary)") and row["least squares"].endswith("(arbitrary)")
        else:
            assert row["observable"] == "yes" and "arbitrary" not in row["Kalman"]


def test_full_rank_keeps_the_convergence_claim():
    text = ac.summary(ac.compute(values("Headings with roll and pitch")))
    assert "within one CRLB σ of its final value" in text and "Not identifiable" not in text


# --------------------------------------------------------------------------- 4. inputs by source
def test_inputs_shown_are_those_of_the_data_source():
    s = Scenario()
    tab = ac.calibration_tab(s)

    def shown():
        return {c[2:] for w in tab.select(pn.widgets.Widget) if w.visible
                for c in (w.css_classes or []) if c.startswith("w-cal_")}

    common = {"cal_source", "cal_convention", "cal_noise_nt", "cal_angle_noise_deg", "cal_be_n",
              "cal_be_e", "cal_be_d", "cal_iterations", "cal_p0_bp_nt"}
    want = {"Designed manoeuvre": common | {"cal_headings", "cal_roll_deg", "cal_pitch_deg",
                                            "cal_n_attitudes", "cal_seed"},
            "Seed 004 simulation": common | {"cal_n_attitudes", "cal_seed"},
            "Seed 004 Table 1": common, "Uploaded CSV": common}
    assert set(want) == set(s.ref("cal_source").objects)
    for source, names in want.items():
        s.calibration.cal_source = source
        assert shown() == names, source


# --------------------------------------------------------------------------- 5. float noise
def test_every_number_box_has_a_format_and_shown_numbers_are_short():
    """Every number box of the tab shows at most 4 decimals (the Table 1 preset's 100·√3 showed
    as 173.20508075688772); every decimal number in the text, table and buttons has at most 6
    significant digits (4 as a rule, 5-6 for nT to 0.1; float noise has 15-17)."""
    s = Scenario()
    s.update(ac.PRESETS["Seed 004 Table 1"])
    tab = ac.calibration_tab(s)
    boxes = {b.css_classes[0]: b for b in tab.select(pn.widgets.TextInput) if b.css_classes}
    numbers = [n for n in ac.FIELDS if isinstance(s.ref(n), param.Number)]
    assert len(numbers) == 11 and all(f"w-{n}" in boxes for n in numbers)
    assert boxes["w-cal_noise_nt"].value == "173.2051"
    for n in numbers:
        assert len(boxes[f"w-{n}"].value.partition(".")[2]) <= 4, (n, boxes[f"w-{n}"].value)
    res = ac.compute(values("Seed 004 Table 1"))
    shown = [ac.summary(res), ac.coefficient_table(res).to_string()]
    shown += [ac._fix_label(k, v) for k, v in ac.fixes(res).items() if v]
    for text in shown:
        for number in re.findall(r"\d+\.\d+", text):
            assert len(number.replace(".", "").lstrip("0")) <= 6, (number, text)


# --------------------------------------------------------------------------- 6. colours
def _lab(colour):
    """CIE L*a*b* (D65) of an sRGB hex colour."""
    rgb = np.array([int(colour[i:i + 2], 16) / 255 for i in (1, 3, 5)])
    rgb = np.where(rgb > 0.04045, ((rgb + 0.055) / 1.055) ** 2.4, rgb / 12.92)
    xyz = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722],
                    [0.0193, 0.1192, 0.9505]]) @ rgb / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


#: Least CIE76 colour difference between two coefficients' curves. ~2.3 is a just-noticeable
#: difference on large patches; thin lines in a legend need far more: the pairs issue 25 found
#: confusable (HoloViews' default cycle: k11/k33 blue, 17.7; k12/k32 red, 15.1) are below 20.
MIN_DELTA_E = 25.0


@pytest.mark.parametrize("which, names", [("K", cal.COEFFICIENTS[:9]), ("Bp", cal.COEFFICIENTS[9:])])
def test_convergence_curves_have_distinct_colours(which, names):
    """As the browser gets them (the Bokeh glyphs of the tab's figure): one line per
    coefficient, each pair at least MIN_DELTA_E apart in colour."""
    figs = Figures()
    figs.show(plot_data(ac.compute(values())))
    renderers = {r.name: r for r in figs.figures[which].renderers
                 if isinstance(r, GlyphRenderer) and r.name in names}
    assert sorted(renderers) == sorted(names)
    assert all(len(r.data_source.data["y"]) == 600 for r in renderers.values())  # 600 iterations
    lines = {n: r.glyph for n, r in renderers.items()}
    for a, b in itertools.combinations(names, 2):
        d = np.linalg.norm(_lab(lines[a].line_color) - _lab(lines[b].line_color))
        assert d >= MIN_DELTA_E, (a, lines[a].line_color, b, lines[b].line_color, d)


def test_table1_shows_seed_004s_printed_solution_beside_the_tabs():
    # issue 40 (low): seed 004's own K and Bp for its Table 1 were not shown beside the tab's
    res = ac.compute(values("Seed 004 Table 1"))
    table = ac.coefficient_table(res).set_index("coefficient")
    t1 = cal.SEED004_TABLE1
    printed = np.r_[np.ravel(t1["paper_K"]), t1["paper_Bp"]]
    shown = [float(t.replace("−", "-").removesuffix(" nT")) for t in table["seed 004 (printed)"]]
    np.testing.assert_allclose(shown, printed, rtol=5e-4)  # shown to 4 significant digits
    # no truth to compare with: no columns of dashes (they cut the table off at 1280 px)
    assert "truth" not in table and "(Kalman − truth)/σ" not in table
    # its geomagnetic solution on the same readings, beside seed 004's printed 266 nT
    B, rec = cal.seed004_table1()
    be = np.array(t1["be"])
    err = cal.geomagnetic_error(cal.geomagnetic_solution(B, rec, np.array(t1["paper_K"]),
                                                         np.array(t1["paper_Bp"]),
                                                         convention=res["convention"]), be)
    text = ac.summary(res)
    assert f"seed 004's printed K and Bp **{err.rms_nt:.1f} nT**" in text, text
    assert "seed 004 prints 266 nT and 1.9 %" in text
    # a simulated case has its truth, and no printed column (the paper's attitudes are not these)
    sim = ac.coefficient_table(ac.compute(values("Seed 004 simulation")))
    assert "truth" in sim and "(Kalman − truth)/σ" in sim and "seed 004 (printed)" not in sim


def test_the_newest_of_two_uploaded_files_is_the_one_used():
    # CI: a second log sent under another name (without the browser's delete of the first) was
    # ignored: FileDropper's value keeps both, the tab took the first, and nothing was computed
    upload = ac.upload_widget()
    assert ac.uploaded_bytes(upload) is None
    upload.value = {"first.csv": "B1\n1\n"}
    assert ac.uploaded_bytes(upload) == b"B1\n1\n"
    upload.value = {"first.csv": "B1\n1\n", "second.csv": b"B1\n2\n"}  # as Panel adds a file
    assert ac.uploaded_bytes(upload) == b"B1\n2\n"
