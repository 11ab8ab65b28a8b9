"""Helpers shared by tests/ and bench/ (never shipped: not in pyproject's packages).

- :mod:`support.server`: ``panel serve app`` on a free loopback port, and websocket clients' care.
- :mod:`support.page`: Debian's headless Chromium through Playwright, and reading what a served
  page draws (the live Bokeh documents).
- :mod:`support.drag`: a slider dragged in Chromium, and each redraw of a map logged in the page.
- :mod:`support.symbolic`: the independent sympy reference of the field models.
- :mod:`support.screenshots`: the screenshots in docs/ (``python -m support.screenshots``).

Nothing in core/, app/ or paper/ imports this package; tests/ and bench/ import it, and it
imports neither of them.
"""

from pathlib import Path

#: The repository's root (tests and benchmarks run commands there).
ROOT = Path(__file__).resolve().parents[1]
