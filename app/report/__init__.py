"""A study's numbers and its report (spec §12): every tab's computation for one scenario, the
numbers a planner quotes (:mod:`app.report.results`) and one self-contained HTML file of them
(:mod:`app.report.html`). Used by the page's *Download report* and by ``python -m study``."""
