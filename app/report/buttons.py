"""The page's study buttons (docs/study.md): *Save scenario* downloads the scenario file of the
page, *Open scenario* takes one (checked as a link: all or nothing, and never a path read on the
server), *Download report* gives the self-contained report of the scenario on the page.

What is said about an opened file goes where the page says what it did with a link: the
scenario's message, about no input (``refused=[]``).
"""

from __future__ import annotations

import io

import panel as pn

from ..state import scenario_file as sf
from . import html as report
from . import results

#: The names of the files offered.
SCENARIO_FILE, REPORT_FILE = "scenario.yaml", "observability_report.html"


def save_text(scenario, log=None, log_name=""):
    """The scenario file of ``scenario`` (*Save scenario*), with the uploaded calibration ``log``
    (bytes) embedded when the Calibration tab uses it (refused above the embedded size: said in
    the file's place by the caller)."""
    uses = scenario.calibration.cal_source == "Uploaded CSV"
    return sf.dumps(scenario, log=log if uses else None, log_name=log_name)


def open_file(scenario, data, name="", put_log=None):
    """Apply the scenario file ``data`` (bytes, as uploaded) to ``scenario`` at once, or none of
    it; say what was done. ``put_log(name, bytes)``: hands the file's calibration log to the
    Calibration tab (False when it cannot: the tab not built yet). Returns the
    :class:`app.state.scenario_file.Loaded` or None."""
    try:
        loaded = sf.loads(data, where="page")
    except sf.ScenarioFileError as exc:
        scenario.param.update(message=f"{name or 'The file'}: {exc}", refused=[])
        return None
    sf.apply(scenario, loaded)
    said = [f"Opened {name or 'the scenario file'}."] + loaded.notes
    if loaded.log is not None and not (put_log and put_log(loaded.log_name, loaded.log)):
        said.append(f"Its calibration log {loaded.log_name} is not loaded: open the Calibration tab, "
                    "then the file again (or upload the log there).")
    if not scenario.message:
        scenario.param.update(message=" ".join(said), refused=[])
    return loaded


def report_text(scenario, title="Observability study"):
    """The report (HTML text) of the scenario on the page (*Download report*)."""
    c = results.compute(scenario.values())
    return report.html_of(report.layout(c, results.summary(c), title=title,
                                        header={"format": sf.FORMAT, "version": sf.VERSION}), title)


def study_buttons(scenario, log=None, put_log=None):
    """The three buttons, in a column for the sidebar. ``log()``: the uploaded calibration log
    (name, bytes or None); ``put_log(name, bytes)``: hands one to the Calibration tab."""
    def saved():
        name, data = log() if log else ("", None)
        try:
            return io.StringIO(save_text(scenario, data, name))
        except ValueError as exc:  # a log over the embedded size: the file without it, said
            scenario.param.update(message=f"Saved without the calibration log: {exc}.", refused=[])
            return io.StringIO(save_text(scenario))

    save = pn.widgets.FileDownload(callback=saved,
                                   filename=SCENARIO_FILE, label="Save scenario", button_type="light",
                                   css_classes=["w-save-scenario"])
    opener = pn.widgets.FileInput(accept=".yaml,.yml", css_classes=["w-open-scenario"],
                                  sizing_mode="stretch_width")

    def opened(event):
        if event.new:
            open_file(scenario, event.new, opener.filename or "", put_log)

    opener.param.watch(opened, "value")
    get_report = pn.widgets.FileDownload(callback=lambda: io.StringIO(report_text(scenario)),
                                         filename=REPORT_FILE, label="Download report",
                                         button_type="light", css_classes=["w-download-report"])
    return pn.Column(pn.pane.Markdown("**Study** (the scenario as a file, checked as a link when "
                                      "opened; the report: one HTML file, every tab's figures "
                                      "and numbers)"),
                     pn.Row(save, get_report), pn.Row(pn.pane.Markdown("Open scenario:"), opener),
                     sizing_mode="stretch_width", margin=0)
