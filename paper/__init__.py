"""Reproduction of the source paper's Figs. 1–6 and a check of every claim it makes.

``python -m paper --out DIR [--n 121]`` writes, for both field models, one standalone Bokeh HTML
per figure and one PNG per panel, ``claims.json`` with every number behind the verdicts, and the
generated report ``paper-reproduction.md`` (see :mod:`paper.cli`). Built only on :mod:`core`.
"""

from .cli import main, run

__all__ = ["main", "run"]
