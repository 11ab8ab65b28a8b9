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


def save_text(scenario):
    """The scenario file of ``scenario`` (*Save scenario*)."""
    return sf.dumps(scenario)


def open_file(scenario, data, name=""):
    """Apply the scenario file ``data`` (bytes, as uploaded) to ``scenario`` at once, or none of
    it; say what was done. Returns the :class:`app.state.scenario_file.Loaded` or None."""
    try:
        loaded = sf.loads(data, where="page")
    except sf.ScenarioFileError as exc:
        scenario.param.update(message=f"{name or 'The file'}: {exc}", refused=[])
        return None
    sf.apply(scenario, loaded)
    said = [f"Opened {name or 'the scenario file'}."] + loaded.notes
    if loaded.log is not None:
        said.append(f"Its calibration log {loaded.log_name} is not loaded into the Calibration tab: "
                    "upload it there.")
    if not scenario.message:
        scenario.param.update(message=" ".join(said), refused=[])
    return loaded


def report_text(scenario, title="Observability study"):
    """The report (HTML text) of the scenario on the page (*Download report*)."""
    c = results.compute(scenario.values())
    return report.html_of(report.layout(c, results.summary(c), title=title,
                                        header={"format": sf.FORMAT, "version": sf.VERSION}), title)


def study_buttons(scenario):
    """The three buttons, in a column for the sidebar."""
    save = pn.widgets.FileDownload(callback=lambda: io.StringIO(save_text(scenario)),
                                   filename=SCENARIO_FILE, label="Save scenario", button_type="light",
                                   css_classes=["w-save-scenario"])
    opener = pn.widgets.FileInput(accept=".yaml,.yml", css_classes=["w-open-scenario"],
                                  sizing_mode="stretch_width")

    def opened(event):
        if event.new:
            open_file(scenario, event.new, opener.filename or "")

    opener.param.watch(opened, "value")
    get_report = pn.widgets.FileDownload(callback=lambda: io.StringIO(report_text(scenario)),
                                         filename=REPORT_FILE, label="Download report",
                                         button_type="light", css_classes=["w-download-report"])
    return pn.Column(pn.pane.Markdown("**Study** (the scenario as a file, checked as a link when "
                                      "opened; the report: one HTML file, every tab's figures "
                                      "and numbers)"),
                     pn.Row(save, get_report), pn.Row(pn.pane.Markdown("Open scenario:"), opener),
                     sizing_mode="stretch_width", margin=0)
