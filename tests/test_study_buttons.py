"""The page's study buttons without a browser (issue 48): the saved file embeds the uploaded
calibration log when the tab uses it; an opened file hands its log to the Calibration tab, or
says it could not; a refused file changes nothing."""

from pathlib import Path

from app.report import buttons
from app.state import scenario_file as sf
from app.state.scenario import Scenario

LOG = (Path(__file__).parents[1] / "data" / "seed004_table1.csv").read_bytes()


def _inputs(s):
    return s.values()


def test_a_saved_file_embeds_the_uploaded_log_only_when_the_tab_uses_it():
    s = Scenario()
    assert "calibration_log" not in buttons.save_text(s, LOG, "t1.csv")  # simulated data
    s.update(cal_source="Uploaded CSV")
    loaded = sf.loads(buttons.save_text(s, LOG, "t1.csv"))
    assert loaded.log == LOG and loaded.log_name == "t1.csv"


def test_an_opened_file_hands_its_log_to_the_calibration_tab_or_says_why_not():
    s = Scenario()
    s.update(cal_source="Uploaded CSV", Ph=140.0)
    text = buttons.save_text(s, LOG, "t1.csv").encode()
    got = {}
    page = Scenario()
    assert buttons.open_file(page, text, "s.yaml", lambda name, data: got.update({name: data}) or True)
    assert got == {"t1.csv": LOG} and _inputs(page) == _inputs(s) and "Opened s.yaml" in page.message
    later = Scenario()
    buttons.open_file(later, text, "s.yaml", lambda name, data: False)
    assert "is not loaded: open the Calibration tab" in later.message


def test_a_refused_file_changes_nothing_and_says_why():
    page = Scenario()
    page.update(d=33.0)
    before = _inputs(page)
    assert buttons.open_file(page, b"format: dipole-observability scenario\nversion: 2\n"
                                   b"inputs: {d: 50, Pv: -2}\n", "bad.yaml") is None
    assert _inputs(page) == before
    assert page.message.startswith("bad.yaml: Scenario file refused, nothing of it applied") and "Pv" in page.message
